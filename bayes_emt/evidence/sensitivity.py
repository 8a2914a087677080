"""Prior sensitivity of log Z: every prior's width doubled, evidence re-weighted from the posterior.

Width, per prior type, in sampling space (where the sampler and the estimators work):

* ``LogUniform(a, b)``: uniform in ``z = log x`` on ``[log a, log b]``; width ``w = log(b/a)``
  [nats of x]. Doubled about its centre: ``[log a − w/2, log b + w/2]``, i.e.
  ``LogUniform(a sqrt(a/b), b sqrt(b/a))``.
* ``Uniform(a, b)``: width ``b − a``; doubled about the midpoint.
* ``Normal(mu, sigma)``: width ``sigma``; doubled: ``Normal(mu, 2 sigma)``.
* ``LogNormal(median, sigma_log)``: width ``sigma_log`` (in ``log x``); doubled: ``2 sigma_log``.

Evidence under the widened prior ``π'``: with ``Z = ∫ L π``, on the old support
``∫ L π' = Z E_post[π'(z)/π(z)]`` (exact; posterior draws in sampling space). A widened
uniform-type prior also adds support beyond the old bounds, where the posterior was not sampled.
Where the posterior stays clear of a bound that part is negligible; where it reaches a bound (the
noise floor ``sigma_abs``, whose likelihood is flat below the relative noise) the likelihood is
taken as flat beyond it, which adds ``Z E[π'/π] p_i(b) e_i`` for a bound ``b`` of coordinate ``i``,
``p_i(b)`` the posterior marginal density at the bound (per unit z, from the draws within a tenth
of a posterior standard deviation of it) and ``e_i = w_i/2`` the added length. That assumption is
reported in the warnings whenever it is used. Priors are independent, so

    log Z' = log Z + log E_post[Π_i π'_i/π_i] + log(1 + Σ_bounds p_i(b) e_i).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import special

from ..params import LogNormal, LogUniform, Normal, ParamSet, Prior, Uniform

__all__ = ["widen_prior", "widen_params", "widened_log_evidence"]


def widen_prior(prior: Prior, factor: float = 2.0) -> Prior:
    """``prior`` with its sampling-space width (module docstring) multiplied by ``factor``."""
    if isinstance(prior, LogUniform):
        w = math.log(prior.upper / prior.lower)
        ext = 0.5 * (factor - 1.0) * w
        return LogUniform(prior.lower * math.exp(-ext), prior.upper * math.exp(ext))
    if isinstance(prior, Uniform):
        ext = 0.5 * (factor - 1.0) * (prior.upper - prior.lower)
        return Uniform(prior.lower - ext, prior.upper + ext)
    if isinstance(prior, Normal):
        return Normal(prior.mu, factor * prior.sigma)
    if isinstance(prior, LogNormal):
        return LogNormal(prior.median, factor * prior.sigma_log)
    raise TypeError(f"no width defined for a {type(prior).__name__} prior")


def widen_params(params: ParamSet, factor: float = 2.0) -> ParamSet:
    """Every prior of ``params`` widened by ``factor`` (:func:`widen_prior`)."""
    return ParamSet(replace(s, prior=widen_prior(s.prior, factor)) for s in params)


def widened_log_evidence(log_z: float, params: ParamSet, draws_z: np.ndarray,
                         factor: float = 2.0) -> tuple[float, list[str]]:
    """``(log Z', warnings)``: log evidence with every prior widened by ``factor``.

    Parameters
    ----------
    log_z : log evidence under ``params``' priors [nats].
    params : the sampled ParamSet.
    draws_z : (n, k) posterior draws in sampling space.
    factor : width multiplier (2: doubled).
    """
    draws_z = np.asarray(draws_z, float).reshape(-1, len(params))
    wide = widen_params(params, factor)
    with np.errstate(invalid="ignore", divide="ignore"):
        log_ratio = wide.log_prior_z(draws_z) - params.log_prior_z(draws_z)
    log_mean = float(special.logsumexp(log_ratio) - math.log(log_ratio.size))
    lo, hi = params.bounds_z()
    wlo, whi = wide.bounds_z()
    extra, notes = 0.0, []
    for i, spec in enumerate(params):
        col = draws_z[:, i]
        sd = float(np.std(col))
        if not (sd > 0):
            continue
        delta = 0.1 * sd
        for bound, new, side in ((lo[i], wlo[i], "lower"), (hi[i], whi[i], "upper")):
            if not (np.isfinite(bound) and np.isfinite(new)):
                continue
            near = np.mean(np.abs(col - bound) < delta)
            if near <= 0:
                continue
            density = near / delta
            extra += density * abs(new - bound)
            notes.append(f"prior sensitivity: the posterior of {spec.name} reaches its {side} prior bound; "
                         "the widened evidence assumes the likelihood stays flat beyond it")
    return log_z + log_mean + math.log1p(extra), notes
