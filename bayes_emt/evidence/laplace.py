"""log Z by the Laplace approximation at the posterior mode: a fast screen, not a verdict.

With ``q(ξ)`` the unnormalised posterior in the unbounded coordinates of
:mod:`bayes_emt.evidence.warp` (sampling space with the bounded coordinates whose posterior comes near
a bound logit-mapped, so that a posterior pressed against a prior bound, like the noise floor's,
still has a mode and a finite curvature), ``ξ̂`` its mode and ``H = −∇² log q(ξ̂)``,

    log Z ≈ log q(ξ̂) + (k/2) log 2π − ½ log det H          (Tierney & Kadane 1986; Kass & Raftery 1995 eq. 5)

exact for a Gaussian posterior; it misses skewness and heavy tails (STACK.md measured −1.0 nat
on a skewed 10-D target), so it screens, and :mod:`bayes_emt.evidence.compare` never lets it
decide alone.

Numerics: the mode is refined by BFGS in coordinates whitened by a scale matrix ``S`` (the fit's
covariance, or the posterior draws'), ``η = S^-½ (ξ − ξ0)``, with central-difference gradients
(``2k`` points per vectorised call). ``H`` comes from central second differences in whitened
coordinates with step ``h = 0.1`` (all ``1 + 2k + 2k(k−1)`` points in one vectorised call), is
re-whitened by its own inverse and computed again, so the step is a tenth of the posterior's own
width in every direction whatever the start scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from ..params import ParamSet
from .warp import Warp

__all__ = ["LaplaceResult", "laplace_evidence", "hessian_fd"]

_H = 0.1  # whitened finite-difference step: a tenth of a posterior standard deviation


@dataclass(frozen=True)
class LaplaceResult:
    """The Laplace approximation.

    Attributes
    ----------
    log_z : log evidence [nats] (``nan`` when the Hessian is not positive definite).
    log_q_mode : log unnormalised posterior at the mode (in the warped coordinates).
    log_det_hessian : ``log det H``.
    mode_z : (k,) the mode mapped back to sampling space.
    n_calls : log-density evaluations.
    ok : whether the optimiser converged and ``H`` is positive definite.
    message : why not, if not.
    """

    log_z: float
    log_q_mode: float
    log_det_hessian: float
    mode_z: np.ndarray
    n_calls: int
    ok: bool
    message: str = ""

    def to_json_dict(self) -> dict:
        return {"method": "laplace", "log_evidence": self.log_z if math.isfinite(self.log_z) else None,
                "err": None, "n_calls": self.n_calls, "ok": self.ok, "message": self.message}


def hessian_fd(f, x0: np.ndarray, h: float = _H) -> tuple[np.ndarray, float, int]:
    """Central-difference Hessian of a vectorised scalar function ``f ((n, k) -> (n,))`` at ``x0``,
    all points in one call; returns ``(H, f(x0), points evaluated)``."""
    k = x0.size
    eye = np.eye(k) * h
    pts = [x0]
    pts += [x0 + eye[i] for i in range(k)] + [x0 - eye[i] for i in range(k)]
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    for i, j in pairs:
        pts += [x0 + eye[i] + eye[j], x0 + eye[i] - eye[j], x0 - eye[i] + eye[j], x0 - eye[i] - eye[j]]
    with np.errstate(invalid="ignore"):
        vals = np.asarray(f(np.array(pts)), float)
    f0 = vals[0]
    fp, fm = vals[1 : k + 1], vals[k + 1 : 2 * k + 1]
    H = np.diag((fp - 2 * f0 + fm) / h**2)
    off = vals[2 * k + 1 :].reshape(-1, 4)
    for (i, j), (pp, pm, mp, mm) in zip(pairs, off, strict=True):
        H[i, j] = H[j, i] = (pp - pm - mp + mm) / (4 * h * h)
    return H, float(f0), len(pts)


def laplace_evidence(log_density_z, params: ParamSet, z0: np.ndarray, scale_z: np.ndarray, *,
                     warp: Warp | None = None) -> LaplaceResult:
    """The Laplace approximation of ``Z = ∫ exp(log_density_z(z)) dz``.

    Parameters
    ----------
    log_density_z : vectorised unnormalised log posterior in sampling space ``(n, k) -> (n,)``.
    params : the sampled ParamSet (its bounds define the logit warp).
    z0 : (k,) start in sampling space, near the mode (the least-squares fit, or the best draw).
    scale_z : (k, k) a covariance of roughly the posterior's size in sampling space (the fit's,
        or the draws'); only used to whiten, the answer does not depend on it.
    warp : which coordinates to logit-map (default: the bounded ones within three standard
        deviations of ``scale_z`` of a bound; pass :meth:`Warp.near_bounds` of posterior draws
        when there are some).
    """
    z0 = np.asarray(z0, float)
    sd = np.sqrt(np.clip(np.diag(np.asarray(scale_z, float)), 0, None))
    warp = Warp.near_bounds(params, z0, z0, sd, n_sd=3.0) if warp is None else warp
    log_q = warp.log_density(log_density_z)
    xi0 = warp.to_xi(np.asarray(z0, float))
    if not np.all(np.isfinite(xi0)):
        raise ValueError("the Laplace start lies on a prior bound")
    # scale in ξ: the warp's local derivative dξ/dz = 1/(z − lo) + 1/(hi − z) on bounded coordinates
    d = np.ones_like(xi0)
    b = warp.bounded
    d[b] = 1.0 / (z0[b] - warp.lo[b]) + 1.0 / (warp.hi[b] - z0[b])
    S = np.asarray(scale_z, float) * np.outer(d, d)
    calls = 0
    message = ""
    ok = True
    xi = xi0
    for _ in range(2):
        L = _sqrt_psd(S)
        x_of = affine_map(xi, L)

        def nlp(eta, x_of=x_of):
            return -float(log_q(x_of(eta[None, :]))[0])

        def grad(eta, x_of=x_of):
            nonlocal calls
            k = eta.size
            e = np.eye(k) * 1e-4
            vals = log_q(x_of(np.vstack([eta + e, eta - e])))
            calls += 2 * k
            with np.errstate(invalid="ignore"):
                g = -(vals[:k] - vals[k:]) / 2e-4
            return np.where(np.isfinite(g), g, 0.0)

        res = optimize.minimize(nlp, np.zeros(xi.size), jac=grad, method="BFGS",
                                options={"gtol": 1e-6, "maxiter": 500})
        calls += res.nfev
        xi = x_of(res.x[None, :])[0]
        at_mode = affine_map(xi, L)
        H_eta, f0, n = hessian_fd(lambda e, x_of=at_mode: log_q(x_of(e)), np.zeros(xi.size))
        calls += n
        if not np.all(np.isfinite(H_eta)):
            ok, message = False, "the log posterior is not finite around the optimum (prior bound?)"
            break
        H_eta = -H_eta
        Linv = np.linalg.inv(L)
        H = Linv.T @ H_eta @ Linv  # −∇² log q in ξ
        try:
            S = np.linalg.inv(H)
            np.linalg.cholesky(S)
        except np.linalg.LinAlgError:
            ok = False
            message = "the Hessian of the log posterior is not positive definite at the optimum"
            break
        if not res.success:
            message = f"optimiser: {res.message}"
    sign, logdet = np.linalg.slogdet(H) if ok else (0.0, math.nan)
    f0 = f0 if ok else math.nan
    if ok and sign <= 0:
        ok, message = False, "the Hessian of the log posterior is not positive definite at the optimum"
    k = xi.size
    log_z = f0 + 0.5 * k * math.log(2 * math.pi) - 0.5 * logdet if ok else math.nan
    return LaplaceResult(float(log_z), float(f0), float(logdet), warp.from_xi(xi), int(calls), bool(ok),
                         message)


def _sqrt_psd(S: np.ndarray) -> np.ndarray:
    """A square root ``L`` with ``L Lᵀ = S`` (eigenvalues floored to stay invertible)."""
    S = 0.5 * (S + S.T)
    w, V = np.linalg.eigh(S)
    w = np.maximum(w, 1e-12 * max(float(np.max(w)), 1e-300))
    return V * np.sqrt(w)


def affine_map(xi0: np.ndarray, L: np.ndarray):
    def x_of(eta):
        return xi0 + np.asarray(eta, float) @ L.T

    return x_of
