"""bayes_emt: what is inside an electromagnetic transducer, from its electrical terminals alone.

Public API (plotting lives in :mod:`bayes_emt.plotting` and is never imported here).
"""

from .data import Measurement
from .errors import (
    BayesEMTError,
    ConvergenceWarning,
    DataFormatError,
    FitError,
    IdentifiabilityWarning,
)
from .models import MODEL_NAMES, Model, build_model
from .params import LogNormal, LogUniform, Normal, ParamSet, ParamSpec, Uniform
from .simulate import log_omega_grid, simulate

__version__ = "0.1.0"

__all__ = [
    "Measurement",
    "BayesEMTError",
    "ConvergenceWarning",
    "DataFormatError",
    "FitError",
    "IdentifiabilityWarning",
    "MODEL_NAMES",
    "Model",
    "build_model",
    "LogNormal",
    "LogUniform",
    "Normal",
    "ParamSet",
    "ParamSpec",
    "Uniform",
    "log_omega_grid",
    "simulate",
]
