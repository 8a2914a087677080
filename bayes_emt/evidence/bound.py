"""A lower bound on log Z from posterior draws: a check on the estimators, not an estimator.

For any normalised density ``q``, Jensen's inequality gives
``log Z = log E_q[p̃/q] ≥ E_q[log p̃ − log q]`` (the evidence lower bound, ELBO), with ``p̃`` the
unnormalised posterior (likelihood × prior, in sampling space with its Jacobian, the density
bridge sampling integrates). Here ``q`` is a Gaussian of the emcee draws' mean and covariance
(times a factor chosen on pilot draws), truncated to the prior's support (its normaliser, the
fraction of its draws with a finite posterior, is estimated from the same draws); the bound is
estimated by the mean over ``n`` fresh seeded draws of ``q``, with its standard error.

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
    ``n_calls`` posterior evaluations; ``inside`` the fraction of ``q``'s draws in the support;
    ``scale`` the multiple of the draws' covariance that ``q`` uses."""

    log_evidence: float
    err: float
    n_calls: int
    inside: float
    scale: float = 1.0

    def to_json_dict(self) -> dict:
        return {"method": "lower_bound", "log_evidence": self.log_evidence, "err": self.err,
                "n_calls": self.n_calls, "inside_support": self.inside, "covariance_scale": self.scale,
                "what": "evidence lower bound E_q[log p - log q], q a Gaussian of the emcee draws"}


SCALES = (1.0, 0.5, 0.25, 0.1, 0.05, 0.02)  # covariance multipliers tried for q


def _elbo_terms(log_density_z, mu, L, rng, n: int, max_draws: int):
    """``(w, n_drawn)``: ``log p̃ − log q`` at the draws of ``q = N(mu, L Lᵀ)`` with a finite
    density (drawn in batches of ``n`` until ``n/2`` are inside or ``max_draws`` were made)."""
    k = mu.size
    log_norm = -np.sum(np.log(np.diag(L))) - 0.5 * k * math.log(2 * math.pi)
    vals, n_drawn = [], 0
    while n_drawn < max_draws and sum(v.size for v in vals) < n // 2:
        u = rng.standard_normal((n, k))
        lp = np.asarray(log_density_z(mu + u @ L.T), float)
        n_drawn += n
        ok = np.isfinite(lp)
        vals.append(lp[ok] - (log_norm - 0.5 * np.sum(u[ok] ** 2, axis=1)))
    return np.concatenate(vals), n_drawn


def evidence_lower_bound(log_density_z, draws_z: np.ndarray, *, n: int = 2000, max_draws: int = 40000,
                         seed: int = 0) -> LowerBound | None:
    """The ELBO of ``log_density_z((m, k)) -> (m,)`` (unnormalised, natural log) with ``q`` a
    Gaussian of the mean and a multiple of the covariance of ``draws_z (..., k)``, truncated to
    where the density is finite (module docstring).

    The multiple is chosen among :data:`SCALES` by the highest bound on pilot draws (``n/4`` per
    scale): a posterior with long flat directions (spare rings) puts some of its own Gaussian's
    draws millions of nats down, where a narrower ``q`` bounds far better; the bound reported is
    then estimated from ``n`` fresh draws, so the choice does not bias it upwards. ``q`` is drawn
    in batches until ``n/2`` draws have a finite density or ``max_draws`` were made (parameters
    against a prior bound put much of the Gaussian outside). ``None`` when fewer than 100 landed
    inside, or the draws' covariance is singular. ``err`` includes the error of the estimated log
    fraction inside."""
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
    n_calls = 0
    best, best_val = None, -math.inf
    for c in SCALES:
        w, drawn = _elbo_terms(log_density_z, mu, math.sqrt(c) * L, rng, max(n // 4, 50), max_draws // 4)
        n_calls += drawn
        if w.size >= 25:
            val = float(np.mean(w)) + math.log(w.size / drawn)
            if val > best_val:
                best, best_val = c, val
    if best is None:
        return None
    w, n_drawn = _elbo_terms(log_density_z, mu, math.sqrt(best) * L, rng, n, max_draws)
    n_calls += n_drawn
    if w.size < 100:
        return None
    inside = w.size / n_drawn
    w = w + math.log(inside)  # log q_truncated = log q - log(fraction inside)
    err_frac = math.sqrt((1.0 - inside) / (n_drawn * inside))  # of log(inside), binomial
    err = math.hypot(float(np.std(w, ddof=1) / math.sqrt(w.size)), err_frac)
    return LowerBound(float(np.mean(w)), err, n_calls, inside, best)


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
