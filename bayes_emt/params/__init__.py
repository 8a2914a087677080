"""Parameter specifications: proper priors, specs, transforms and the noise parameters (SI units).

One description every stage reuses: least-squares bounds, log-prior with its log-Jacobian, the
unit-cube transform for nested sampling, prior draws, labels and JSON. The physics parameters'
specs are declared by the terms of :mod:`bayes_emt.models` (:func:`bayes_emt.models.param_spec`).
"""

from .defaults import DISCREPANCY_PARAMS, NOISE_PARAMS, NU_SPEC, noise_param_set
from .priors import LogNormal, LogUniform, Normal, Prior, Uniform, prior_from_dict
from .spec import CLIP_MARGIN, ParamSet, ParamSpec, clip_inside

__all__ = ["LogUniform", "Uniform", "Normal", "LogNormal", "Prior", "prior_from_dict", "ParamSpec",
           "ParamSet", "clip_inside", "CLIP_MARGIN", "NOISE_PARAMS", "NU_SPEC",
           "DISCREPANCY_PARAMS", "noise_param_set"]
