"""A lower bound on log Z from posterior draws: a check on the estimators, not an estimator.

For any normalised density ``q``, Jensen's inequality gives
``log Z = log E_q[p̃/q] ≥ E_q[log p̃ − log q]`` (the evidence lower bound, ELBO), with ``p̃`` the
unnormalised posterior (likelihood × prior, in sampling space with its Jacobian, the density
bridge sampling integrates). Here ``q`` is the Gaussian of the emcee draws' mean and covariance,
truncated to the prior's support (its normaliser, the fraction of its draws with a finite
posterior, is estimated from the same draws); the bound is estimated by the mean over ``n``
seeded draws of ``q``, with its standard error.

The bound holds whatever the posterior's shape and whether or not the chain converged: the
draws only choose ``q``. An estimate of log Z several standard errors *below* it is therefore
wrong, and wrong in the way nested sampling fails when its live points never reach the
posterior (a spare ring of an over-sized NL model: a nested log Z 13000 nats below the bound)
and bridge sampling fails when its chain sits in a poor region. :func:`evidence_lower_bound`
gives the bound; :func:`below_bound` says whether an estimate falls below it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LowerBound", "evidence_lower_bound", "below_bound", "BOUND_SIGMAS"]

BOUND_SIGMAS = 5.0  # an estimate this many combined standard errors below the bound is refused


@dataclass(frozen=True)
class LowerBound:
    """``log_evidence`` ≥ ... [nats] (the estimate of the bound) and its standard error ``err``;
    ``n_calls`` posterior evaluations; ``inside`` the fraction of ``q``'s draws in the support."""

    log_evidence: float
    err: float
    n_calls: int
    inside: float

    def to_json_dict(self) -> dict:
        return {"method": "lower_bound", "log_evidence": self.log_evidence, "err": self.err,
                "n_calls": self.n_calls, "inside_support": self.inside,
                "what": "evidence lower bound E_q[log p - log q], q the Gaussian of the emcee draws"}


def evidence_lower_bound(log_density_z, draws_z: np.ndarray, *, n: int = 2000,
                         seed: int = 0) -> LowerBound | None:
    """The ELBO of ``log_density_z((m, k)) -> (m,)`` (unnormalised, natural log) with ``q`` the
    Gaussian of ``draws_z (..., k)`` (module docstring); ``None`` when fewer than 10 % of ``q``'s
    draws have a finite density or the draws' covariance is singular."""
    draws_z = np.asarray(draws_z, float)
    k = draws_z.shape[-1]
    draws_z = draws_z.reshape(-1, k)  # (steps, walkers, k) chains too
    mu = draws_z.mean(axis=0)
    cov = np.atleast_2d(np.cov(draws_z, rowvar=False))
    try:
        L = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return None
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, k))
    z = mu + u @ L.T
    log_q = (-0.5 * np.sum(u**2, axis=1) - np.sum(np.log(np.diag(L))) - 0.5 * k * math.log(2 * math.pi))
    lp = np.asarray(log_density_z(z), float)
    ok = np.isfinite(lp)
    inside = float(ok.mean())
    if inside < 0.1:
        return None
    w = lp[ok] - (log_q[ok] - math.log(inside))
    err = float(np.std(w, ddof=1) / math.sqrt(w.size)) if w.size > 1 else math.inf
    return LowerBound(float(np.mean(w)), err, n, inside)


def below_bound(estimate: float, err: float | None, bound: LowerBound | None) -> float | None:
    """How many combined standard errors ``estimate`` [nats] lies below ``bound`` when that is
    more than :data:`BOUND_SIGMAS` (and more than 1 nat), else ``None``."""
    if bound is None or estimate is None or not math.isfinite(estimate):
        return None
    gap = bound.log_evidence - estimate
    sig = math.hypot(err if err is not None and math.isfinite(err) else 0.0, bound.err)
    if gap > 1.0 and gap > BOUND_SIGMAS * sig:
        return gap / sig if sig > 0 else math.inf
    return None
