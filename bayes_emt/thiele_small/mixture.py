"""Model form in every interval: the evidence-weighted mixture of the candidate models' posteriors.

A T/S value depends on which coil model explains the curve (on a real woofer, Re moves by 5-10 %
between UD, NL(3) and UD with a semi-inductance, each with a posterior of ±1-2 %). The interval a
user reads must include that: with candidate models ``M_i`` and equal prior odds, the posterior of
a quantity ``q`` is the mixture

    p(q | data) = Σ_i P_i p(q | data, M_i),      P_i = Z_i / Σ_j Z_j,

(Bayesian model averaging: Hoeting, Madigan, Raftery & Volinsky 1999, "Bayesian model averaging:
a tutorial", Statistical Science 14(4), 382-417), with ``Z_i`` each candidate's evidence under the
same likelihood (the correlated discrepancy one by default) and proper priors identical for shared
parameters. The requested model's component is its MCMC posterior; the other components are each
candidate's Gaussian (Laplace) approximation at its posterior mode under the same likelihood
(:func:`laplace_draws`), which costs a mode search and a Hessian instead of a sampler run, and
``Z_i`` is the Laplace evidence of :func:`~bayes_emt.evidence.fit_evidence.fit_log_evidence`.
The ``ci90`` is the mixture's 5-95 % quantiles (weighted draws, :func:`weighted_quantiles`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Collection

import numpy as np

__all__ = ["laplace_draws", "weighted_quantiles", "mixture_weights", "MIXTURE_METHOD"]

MIXTURE_METHOD = (
    "evidence-weighted mixture (Bayesian model averaging, equal prior odds) of the candidate models "
    "whose parameters are all determined and whose Laplace evidence could be computed under the same "
    "likelihood; the main model's component is its posterior, the others their Laplace approximation at "
    "the posterior mode; a candidate whose largest likelihood is more than 25 nats below the best evidence "
    "has weight 0 (below 1e-10 whatever its evidence) and its evidence is not computed")


def laplace_draws(lik, fit, n: int, rng: np.random.Generator) -> tuple[np.ndarray | None, str]:
    """``n`` draws of the model parameters (physical values, ``(n, model.ndim)``) from the Gaussian
    approximation of ``lik``'s posterior at its mode, found from the least-squares ``fit``
    (:func:`~bayes_emt.inference.start.posterior_mode` from the Laplace screen's start). The
    covariance is the inverse Hessian of the log posterior in the model's sampling space with the
    noise parameters at their mode (central differences in coordinates whitened by the fit's
    covariance); a parameter at a prior bound at the mode (a step leaves the support) is held there.
    Returns ``(None, why)`` when there is no mode or the Hessian is not positive definite."""
    from ..evidence.fit_evidence import fit_start
    from ..evidence.laplace import hessian_fd
    from ..inference.start import posterior_mode

    k = lik.model.ndim
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            z0, scale, _ = fit_start(lik, fit)
            mode = posterior_mode(lik, z0[None, :], scale + 1e-12 * np.eye(lik.ndim))
            L = np.linalg.cholesky(scale[:k, :k] + 1e-12 * np.max(np.abs(np.diag(scale[:k, :k]))) * np.eye(k))

            h = 1e-2

            def f(u, free):
                u = np.atleast_2d(u)
                z = np.tile(mode, (u.shape[0], 1))
                z[:, :k] = mode[:k] + u @ L[:, free].T
                return lik.log_posterior_z(z)

            # a coordinate whose step leaves the prior's support (a parameter at its bound) is
            # held at the mode: the approximation is then conditional on it
            steps = np.vstack([np.eye(k) * h, -np.eye(k) * h])
            edge = ~np.isfinite(f(steps, np.arange(k)).reshape(2, k)).all(axis=0)
            free = np.flatnonzero(~edge)
            if free.size == 0:
                return None, "every parameter is at a prior bound at the posterior mode"
            H, f0, _ = hessian_fd(lambda u: f(u, free), np.zeros(free.size), h)
            if not np.isfinite(f0) or not np.all(np.isfinite(H)):
                return None, "the log posterior is not finite around its mode"
            w, V = np.linalg.eigh(-0.5 * (H + H.T))
            if np.min(w) <= 0:
                return None, "the Hessian at the posterior mode is not positive definite"
            cov_u = np.zeros((k, k))
            cov_u[np.ix_(free, free)] = (V / w) @ V.T
            cov = L @ cov_u @ L.T
            z = rng.multivariate_normal(mode[:k], cov, size=n, method="eigh")
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
        return None, str(exc)
    lo, hi = lik.model.params.bounds_z()
    return lik.model.params.from_z(np.clip(z, lo, hi)), ""


def mixture_weights(log_z: dict[str, float], bounded: Collection[str] = ()) -> dict[str, float]:
    """Posterior model probabilities ``P_i = Z_i / Σ Z_j`` (equal prior odds) of the models with a
    finite ``log_z``; the others get none, except those in ``bounded`` (an evidence not computed
    because the likelihood's maximum lies far below the best evidence): weight 0 beside the others
    (none when no model has a weight). In ``log_z``'s order."""
    ok = {m: v for m, v in log_z.items() if math.isfinite(v)}
    if not ok:
        return {}
    top = max(ok.values())
    w = {m: math.exp(v - top) for m, v in ok.items()}
    s = sum(w.values())
    return {m: w[m] / s if m in w else 0.0 for m in log_z if m in w or m in bounded}


def weighted_quantiles(values, weights, q) -> np.ndarray:
    """Quantiles ``q`` of the distribution putting mass ``weights`` on ``values`` (non-finite
    values dropped; the weights of each model's draws sum to its probability)."""
    v = np.asarray(values, float)
    w = np.asarray(weights, float)
    ok = np.isfinite(v) & (w > 0)
    v, w = v[ok], w[ok]
    if v.size == 0:
        return np.full(len(q), np.nan)
    order = np.argsort(v)
    v, w = v[order], w[order]
    c = np.cumsum(w) - 0.5 * w
    c /= w.sum()
    return np.interp(q, c, v)
