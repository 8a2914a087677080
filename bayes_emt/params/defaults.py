"""The noise parameters every likelihood appends (``sigma_rel``, ``sigma_abs`` and, when sampled,
``nu``), identical for every model so that evidences of different models are comparable.

The physics parameters' specs (documented names, SI units, labels, proper priors) belong to the terms
that declare them (:mod:`bayes_emt.models`; look one up by name with
:func:`bayes_emt.models.param_spec`): ``params`` holds the mechanism, not the catalogue.
"""

from __future__ import annotations

from .priors import LogUniform
from .spec import ParamSet, ParamSpec

__all__ = ["NOISE_PARAMS", "NU_SPEC", "DISCREPANCY_PARAMS", "noise_param_set"]

#: Noise parameters appended to every model's parameter vector (identical across models).
NOISE_PARAMS = ParamSet([
    ParamSpec("sigma_rel", "1", r"$\sigma_\mathrm{rel}$", LogUniform(1e-6, 1.0),
              "relative noise std of the real and imaginary parts (fraction of |Y|)"),
    ParamSpec("sigma_abs", "S", r"$\sigma_\mathrm{abs}$", LogUniform(1e-12, 1e2),
              "absolute noise floor: std of the real and imaginary parts"),
])

#: Student-t degrees of freedom, when sampled: log-uniform from Cauchy-like (1) to Gaussian-like (100).
NU_SPEC = ParamSpec("nu", "1", r"$\nu$", LogUniform(1.0, 100.0), "Student-t degrees of freedom")


#: The correlated likelihood's model discrepancy (:mod:`bayes_emt.inference.discrepancy`): its size
#: relative to |Y| (same prior as ``sigma_rel``: the misfit of a poor model can be as large as the
#: noise of a poor instrument) and its correlation length over log10 frequency [decades]. Lower end
#: 1e-4 decades, below the spacing of any bench sweep (2000 points over 3 decades are 1.5e-3
#: decades apart): an uncorrelated discrepancy is inside the prior. Upper end 1 decade: a residual
#: correlated over more than a decade is a change of level or slope across the band, which the
#: model's own parameters (resistance, inductance, mass, compliance) describe; a process allowed to
#: take it would trade against them (Brynjarsdottir & O'Hagan 2014).
DISCREPANCY_PARAMS = ParamSet([
    ParamSpec("sigma_disc", "1", r"$\sigma_\mathrm{disc}$", LogUniform(1e-6, 1.0),
              "model discrepancy: std of the real and imaginary parts (fraction of |Y|)"),
    ParamSpec("ell", "dec", r"$\ell$", LogUniform(1e-4, 1.0),
              "correlation length of the model discrepancy over log10 frequency"),
])


def noise_param_set(kind: str = "gaussian", nu: float | None = 4.0, noise: str = "white") -> ParamSet:
    """The default noise parameters of a likelihood: :data:`NOISE_PARAMS`, plus :data:`NU_SPEC`
    for a Student-t likelihood whose ``nu`` is sampled (``nu=None``), plus :data:`DISCREPANCY_PARAMS` for
    the correlated discrepancy (``noise="correlated"``), in that order."""
    out = NOISE_PARAMS + ParamSet([NU_SPEC]) if kind == "student" and nu is None else NOISE_PARAMS
    return out + DISCREPANCY_PARAMS if noise == "correlated" else out
