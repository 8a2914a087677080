"""T/S sets of results that already exist: a least-squares fit (:func:`from_fit`) or a posterior
(:func:`from_posterior`); one model, no spread, no mixture."""

from __future__ import annotations

import math

import numpy as np

from .relations import NAMES, UNITS, free_air, with_mass, with_sd
from .result import ThieleSmall

__all__ = ["from_fit", "from_posterior", "laplace_theta", "LAPLACE_DRAWS"]

LAPLACE_DRAWS = 4000


def laplace_theta(params, z_hat, cov, n, rng):
    """``n`` draws of the physical vector from ``N(z_hat, cov)`` in sampling space (clipped to the
    support)."""
    lo, hi = params.bounds_z()
    z = rng.multivariate_normal(z_hat, cov, size=n, method="eigh")
    return params.from_z(np.clip(z, lo, hi))


def from_fit(fit, *, seed: int = 0) -> ThieleSmall:
    """The free-air T/S set of a least-squares fit (one recording), intervals from the fit's
    Gaussian approximation as ``thiele_small(..., fast=True)`` gives them (4000 draws of its
    sampling-space covariance, seeded; ``value`` their median). A fit without covariance gives its
    point values with ``ci90`` None and says so. No model spread (one model)."""
    model = fit.model
    point = free_air(model, fit.theta[None, :])
    draws, warns = None, []
    if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)):
        theta = laplace_theta(model.params, model.params.to_z(fit.theta), fit.cov_z, LAPLACE_DRAWS,
                         np.random.default_rng(seed))
        draws = free_air(model, theta)
    else:
        warns.append({"code": "no_covariance", "message": "the fit has no covariance (singular Jacobian): "
                      "point values only, no intervals"})
    params = {}
    for name in NAMES:
        if name not in point:
            continue
        v0 = float(np.asarray(point[name], float).ravel()[0])
        if not math.isfinite(v0):
            continue
        entry = {"value": v0, "ci90": None, "unit": UNITS[name], "model_spread": None}
        if draws is not None:
            v = np.asarray(draws[name], float)
            v = v[np.isfinite(v)]
            if v.size:
                lo, med, hi = np.quantile(v, [0.05, 0.5, 0.95])
                entry.update(value=float(med), ci90=[float(lo), float(hi)])
        params[name] = entry
    return ThieleSmall(model=model.spec, method="free_air", parameters=params,
                       inputs={"uncertainty": "laplace" if draws is not None else "none", "seed": int(seed)},
                       warnings=tuple(warns))


def from_posterior(post, *, sd: float | None = None, air_density: float = 1.18,
                   sound_speed: float = 343.0) -> ThieleSmall:
    """The T/S set of an existing posterior (``sample``'s): a single recording gives the free-air set;
    an added-mass pair (:class:`~bayes_emt.added_mass.posterior.AddedMassPosterior`) also Bl, Mms,
    Cms, Kms, Rms and, with ``sd``, Vas, η0 and SPL. No model spread (one model)."""
    model = post.model
    theta = post.theta()
    if hasattr(post, "thetas"):  # added-mass pair: m is the first joint parameter
        mms = post.flat()[:, 0]
        ts = with_mass(free_air(model, theta), model, theta, mms)
        method = "added_mass"
    else:
        ts, method = free_air(model, theta), "free_air"
    if sd is not None and "Cms" in ts:
        ts = with_sd(ts, sd, air_density, sound_speed)
    params = {}
    for name in NAMES:
        if name in ts:
            v = np.asarray(ts[name], float)
            v = v[np.isfinite(v)]
            if v.size:
                lo, med, hi = np.quantile(v, [0.05, 0.5, 0.95])
                params[name] = {"value": float(med), "ci90": [float(lo), float(hi)], "unit": UNITS[name],
                                "model_spread": None}
    warns = [] if post.converged else [{"code": "not_converged", "message": "the posterior did not meet the "
                                        "stopping rule: its T/S intervals are not to be trusted"}]
    return ThieleSmall(model=model.spec, method=method, parameters=params,
                       inputs={"uncertainty": "posterior", "sd_m2": sd, "air_density_kg_m3": air_density,
                               "sound_speed_m_s": sound_speed}, warnings=tuple(warns))
