"""The noise parameters every likelihood appends (``sigma_rel``, ``sigma_abs`` and, when sampled,
``nu``), identical for every model so that evidences of different models are comparable.

The physics parameters' specs (documented names, SI units, labels, proper priors) belong to the terms
that declare them (:mod:`bayes_emt.models`; look one up by name with
:func:`bayes_emt.models.param_spec`): ``params`` holds the mechanism, not the catalogue.
"""

from __future__ import annotations

from .priors import LogUniform
from .spec import ParamSet, ParamSpec

__all__ = ["NOISE_PARAMS", "NU_SPEC", "noise_param_set"]

#: Noise parameters appended to every model's parameter vector (identical across models).
NOISE_PARAMS = ParamSet([
    ParamSpec("sigma_rel", "1", r"$\sigma_\mathrm{rel}$", LogUniform(1e-6, 1.0),
              "relative noise std of the real and imaginary parts (fraction of |Y|)"),
    ParamSpec("sigma_abs", "S", r"$\sigma_\mathrm{abs}$", LogUniform(1e-12, 1e2),
              "absolute noise floor: std of the real and imaginary parts"),
])

#: Student-t degrees of freedom, when sampled: log-uniform from Cauchy-like (1) to Gaussian-like (100).
NU_SPEC = ParamSpec("nu", "1", r"$\nu$", LogUniform(1.0, 100.0), "Student-t degrees of freedom")


def noise_param_set(kind: str = "gaussian", nu: float | None = 4.0) -> ParamSet:
    """The default noise parameters of a likelihood: :data:`NOISE_PARAMS`, plus :data:`NU_SPEC`
    for a Student-t likelihood whose ``nu`` is sampled (``nu=None``)."""
    return NOISE_PARAMS + ParamSet([NU_SPEC]) if kind == "student" and nu is None else NOISE_PARAMS
