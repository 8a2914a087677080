"""Parameter specifications: proper priors, specs and the default catalogue (SPEC §6 names, SI units).

One description every stage reuses: least-squares bounds, log-prior with its log-Jacobian, the
unit-cube transform for nested sampling, prior draws, labels and JSON.
"""

from .defaults import NOISE_PARAMS, NU_SPEC, default_spec, noise_param_set
from .priors import LogNormal, LogUniform, Normal, Prior, Uniform, prior_from_dict
from .spec import ParamSet, ParamSpec

__all__ = ["LogUniform", "Uniform", "Normal", "LogNormal", "Prior", "prior_from_dict", "ParamSpec",
           "ParamSet", "default_spec", "NOISE_PARAMS", "NU_SPEC", "noise_param_set"]
