"""bayes_emt: what is inside an electromagnetic transducer, from its electrical terminals alone.

Public API: the verbs of :mod:`bayes_emt.api` and the types they return. Plotting lives in
:mod:`bayes_emt.plotting` and is never imported here.
"""

from .api import as_model, design_shunt, fit, read, read_posterior, sample
from .errors import (
    BayesEMTError,
    ConvergenceWarning,
    DataFormatError,
    FitError,
    IdentifiabilityWarning,
)
from .estimation.results import FitResult
from .inference.posterior import Posterior
from .io.simulate import log_omega_grid, simulate
from .measurement import Measurement
from .models import MODEL_NAMES, Model, build_model
from .params import LogNormal, LogUniform, Normal, ParamSet, ParamSpec, Uniform
from .shunt import ShuntDesign

__version__ = "0.1.0"

__all__ = [
    "read", "fit", "sample", "design_shunt", "read_posterior", "as_model",
    "Measurement", "FitResult", "Posterior", "ShuntDesign",
    "BayesEMTError", "ConvergenceWarning", "DataFormatError", "FitError", "IdentifiabilityWarning",
    "MODEL_NAMES", "Model", "build_model",
    "LogNormal", "LogUniform", "Normal", "ParamSet", "ParamSpec", "Uniform",
    "log_omega_grid", "simulate",
]
