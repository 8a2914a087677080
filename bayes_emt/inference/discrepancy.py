"""The correlated model-discrepancy likelihood: instrument noise plus a model discrepancy that is
an Ornstein–Uhlenbeck (Matérn-½) process over log-frequency.

Why
---
A white likelihood (independent errors per frequency) is right when the model is exact and only
the instrument's noise is left. On a real transducer the residual is mostly *model error*: smooth,
structured, correlated over frequency. Treated as independent, a structured misfit over ``F``
points narrows the posterior like ``1/√F`` around parameters that a second, equally competent
model places many "standard deviations" away. Kennedy & O'Hagan (2001, "Bayesian calibration of
computer models", J. R. Statist. Soc. B 63(3), 425–464) add a discrepancy process beside the
observation error for exactly this reason; Brynjarsdóttir & O'Hagan (2014, "Learning about
physical parameters: the importance of model discrepancy", Inverse Problems 30, 114007) show that a
discrepancy with a vague prior trades off against the physical parameters, and that it must be
constrained by what is known about it.

The model
---------
Each measured admittance's real and imaginary parts are, independently and alike,

    Y_k = Y_model,k + g_k δ_k + σ_k ε_k,        g_k = σ_disc |Y_k|,

with ``σ_k`` the instrument noise of :mod:`bayes_emt.inference.likelihood` (relative part plus
absolute floor over the point weight; ``ε_k`` independent N(0, 1)) and ``δ`` a zero-mean,
unit-variance stationary OU process in ``x = log10 f`` with correlation
``corr(δ_j, δ_k) = exp(−|x_j − x_k| / ℓ)``. What is known constrains the discrepancy: zero mean
(the model carries the mean), one smoothness scale ``ℓ`` over log-frequency, and a size relative
to the reading ``σ_disc`` inferred from the residual; both have proper log-uniform priors
(:data:`~bayes_emt.params.DISCREPANCY_PARAMS`). ``σ_disc → 0`` is exactly the white likelihood.

Evaluation, exact and O(F): the OU process is Markov, so its precision matrix ``Q = K⁻¹`` is
tridiagonal on any grid (with ``ρ_j = exp(−(x_j − x_{j−1})/ℓ)``, ``c_j = ρ_j²/(1 − ρ_j²)``:
``Q_kk = 1 + c_k + c_{k+1}``, ``Q_{k−1,k} = −ρ_k/(1 − ρ_k²)``; Rasmussen & Williams, *Gaussian
Processes for Machine Learning*, 2006, §B.2). With ``C = D + G K G`` (``D = diag σ_k²``,
``G = diag g_k``) the Woodbury identity and the matrix determinant lemma give, with the tridiagonal
``A = Q + G D⁻¹ G`` and ``b = G D⁻¹ r``,

    rᵀ C⁻¹ r = Σ r_k²/σ_k² − bᵀ A⁻¹ b,
    log det C = Σ log σ_k² + Σ_j log(1 − ρ_j²) + log det A,

``A`` factorised by LAPACK's tridiagonal ``dpttrf`` once per parameter set for both parts. The
pointwise log-likelihood (PSIS-LOO, diagnostics) is the sequence of one-step predictive densities
``log p(r_k | r_<k)`` from the equivalent Kalman filter (their sum is the total).

What it does to intervals: where the residual is white, ``σ_disc`` falls to where it no longer
matters and the intervals are the white ones; where the model misses a smooth structure,
``σ_disc`` takes its size and ``ℓ`` its extent, and the physical parameters are informed by the
structure the process cannot explain rather than by ``F`` independent points: intervals widen where
and as much as the misfit says.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lapack

__all__ = ["NoiseCorrelation", "ou_rho", "discrepancy_start", "NOISE_KINDS"]

#: noise kinds: ``correlated`` (this module, the default of ``sample`` and ``ts``) or ``white``
#: (independent errors: the posterior "if the model were exact")
NOISE_KINDS = ("correlated", "white")


def ou_rho(x, ell) -> np.ndarray:
    """``ρ_j = exp(−(x_j − x_{j−1})/ℓ)``, shape ``(..., F − 1)``, for grid ``x (F,)`` [decades] and
    ``ell (...)`` [decades]."""
    dx = np.diff(np.asarray(x, float))
    ell = np.asarray(ell, float)[..., None]
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        return np.exp(-dx / ell)


class NoiseCorrelation:
    """The log-frequency grid of one measurement and the correlated log-likelihood on it."""

    def __init__(self, omega, absY):
        self.x = np.log10(np.asarray(omega, float) / (2 * math.pi))
        self.absY = np.asarray(absY, float)
        self.F = self.x.size

    def _parts(self, r):
        return np.stack([r.real, r.imag], axis=-1)  # (W, F, 2)

    def total(self, r, sigma, sigma_disc, ell) -> np.ndarray:
        """Total log-likelihood [nats] ``(W,)`` of complex residuals ``r (W, F)`` [S], noise scales
        ``sigma (W, F)`` [S], relative discrepancy sizes ``sigma_disc (W,)`` and correlation lengths
        ``ell (W,)`` [decades]; ``-inf`` where not finite (module docstring)."""
        W, F = r.shape
        out = np.full(W, -np.inf)
        with np.errstate(all="ignore"):
            rho = ou_rho(self.x, ell)                          # (W, F-1)
            one_m = -np.expm1(2.0 * np.log(rho))               # 1 - rho^2, exact near rho = 1
            c = rho * rho / one_m
            off = -rho / one_m
            diag = np.ones((W, F))
            diag[:, 1:] += c
            diag[:, :-1] += c
            iv = 1.0 / (sigma * sigma)                         # D^-1
            g = np.asarray(sigma_disc, float)[:, None] * self.absY
            diag += g * g * iv
            parts = self._parts(r)                             # (W, F, 2)
            white_q = np.sum((r.real**2 + r.imag**2) * iv, axis=1)
            b = (g * iv)[..., None] * parts
            base = (-F * math.log(2 * math.pi) - np.sum(np.log(sigma * sigma), axis=1)
                    - np.sum(np.log(one_m), axis=1))
        ok = np.isfinite(base) & np.isfinite(white_q) & np.all(np.isfinite(diag), axis=1) \
            & np.all(np.isfinite(off), axis=1) & np.all(np.isfinite(b), axis=(1, 2))
        for i in np.flatnonzero(ok):
            d, e, info = lapack.dpttrf(diag[i], off[i])
            if info != 0:
                continue
            x, info = lapack.dpttrs(d, e, b[i])
            if info != 0:
                continue
            quad = white_q[i] - float(np.sum(b[i] * x))
            out[i] = base[i] - np.sum(np.log(d)) - 0.5 * quad
        return np.where(np.isfinite(out), out, -np.inf)

    def pointwise(self, r, sigma, sigma_disc, ell) -> np.ndarray:
        """Per-frequency log-likelihood [nats] ``(W, F)`` (real plus imaginary part): the one-step
        predictive densities ``log p(r_k | r_<k)`` of the Kalman filter of the same model; their sum
        is :meth:`total`. ``-inf`` where not finite."""
        r = np.atleast_2d(r)
        W, F = r.shape
        parts = self._parts(r)                                 # (W, F, 2)
        with np.errstate(all="ignore"):
            rho = ou_rho(self.x, ell)
            g = np.asarray(sigma_disc, float)[:, None] * self.absY
            s2 = sigma * sigma
            ll = np.empty((W, F))
            m = np.zeros((W, 2))                               # filtered mean of delta, both parts
            P = np.ones(W)                                     # its variance (stationary at k = 0)
            for k in range(F):
                if k:
                    rk = rho[:, k - 1]
                    m = rk[:, None] * m
                    P = rk * rk * P + (1.0 - rk * rk)
                gk = g[:, k]
                S = gk * gk * P + s2[:, k]
                v = parts[:, k, :] - gk[:, None] * m
                ll[:, k] = -math.log(2 * math.pi) - np.log(S) - 0.5 * np.sum(v * v, axis=1) / S
                K = gk * P / S
                m = m + K[:, None] * v
                P = P - K * gk * P
        return np.where(np.isfinite(ll), ll, -np.inf)


def discrepancy_start(x, u) -> tuple[list[float], list[float]]:
    """Start ``([log σ_disc, log ℓ], spread)`` in sampling space from a fit's relative residual
    ``u (F,)`` (complex, ``(Y_model − Y)/|Y|``) on grid ``x = log10 f``: ``σ_disc`` at its rms per
    part; ``ℓ = −median(Δx)/log ρ̂`` from the lag-one correlation ``ρ̂`` of the real and imaginary
    parts pooled; both clipped inside their priors."""
    from ..params import DISCREPANCY_PARAMS

    u = np.asarray(u, complex)
    a = np.r_[u.real, u.imag]
    den = float(np.dot(a, a))
    rho = float(np.dot(np.r_[u.real[:-1], u.imag[:-1]], np.r_[u.real[1:], u.imag[1:]])) / den \
        if den > 0 and u.size > 1 else 0.0
    dx = float(np.median(np.diff(x))) if len(x) > 1 else 1e-2
    p_s, p_l = DISCREPANCY_PARAMS
    ell = p_l.prior.lower * 10 if not math.isfinite(rho) or rho <= 1e-3 else -dx / math.log(min(rho, 0.999))
    ell = min(max(ell, p_l.prior.lower * 1.5), p_l.prior.upper / 1.5)
    sd = min(max(math.sqrt(den / max(a.size, 1)), p_s.prior.lower * 1.5), p_s.prior.upper / 1.5)
    return [math.log(sd), math.log(ell)], [0.3, 0.3]
