"""bayes_emt: what is inside an electromagnetic transducer, from its electrical terminals alone.

Public API: the verbs of :mod:`bayes_emt.api` and the types they return. Plotting lives in
:mod:`bayes_emt.plotting` and is never imported here.
"""

from .api import (
    as_measurement,
    as_model,
    compare,
    design_shunt,
    diagnose,
    fit,
    load,
    load_concealed_bench,
    load_paper_bench,
    read,
    read_posterior,
    robust_shunt,
    sample,
    ts,
)
from .discovery.diagnose import Diagnosis
from .errors import (
    BayesEMTError,
    ConvergenceWarning,
    DataFormatError,
    FitError,
    IdentifiabilityWarning,
)
from .estimation.results import FitResult
from .evidence.records import Comparison
from .inference.posterior import Posterior
from .io.simulate import log_omega_grid, simulate
from .measurement import Measurement
from .models import MODEL_NAMES, Model, build_model
from .params import LogNormal, LogUniform, Normal, ParamSet, ParamSpec, Uniform
from .shunt import ShuntDesign

__version__ = "0.1.0"

__all__ = [
    "read", "fit", "sample", "compare", "robust_shunt", "ts", "design_shunt", "diagnose", "read_posterior",
    "load", "as_model", "as_measurement", "load_paper_bench", "load_concealed_bench",
    "Measurement", "FitResult", "Posterior", "Comparison", "Diagnosis", "ShuntDesign",
    "BayesEMTError", "ConvergenceWarning", "DataFormatError", "FitError", "IdentifiabilityWarning",
    "MODEL_NAMES", "Model", "build_model",
    "LogNormal", "LogUniform", "Normal", "ParamSet", "ParamSpec", "Uniform",
    "log_omega_grid", "simulate",
]
