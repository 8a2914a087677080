"""The Gaussian noise model's sums over frequencies, without a transcendental per point.

With ``σ_k² = (σ_rel² |Y_k|² + σ_abs²)/w_k²`` (:mod:`bayes_emt.inference.likelihood`) and
``ρ = σ_abs/σ_rel``, ``a_k = 1/|Y_k|²``, ``e_k = |r_k|² w_k² a_k`` (the scaled squared residual),
the total Gaussian log-likelihood of ``F`` complex points is

    log L = −F log 2π − 2F log σ_rel − C − L(ρ) − S(ρ) / (2 σ_rel²)

with the data constant ``C = Σ log(|Y_k|²/w_k²)`` and

    S(ρ) = Σ_k e_k / (1 + ρ² a_k),      L(ρ) = Σ_k log(1 + ρ² a_k).

Where ``x = ρ² max_k a_k ≤`` :data:`SERIES_X` (the absolute floor is small against every
reading), both are power series in ``ρ²``: ``S = Σ_j (−ρ²)^j G_j`` with ``G_j = Σ_k e_k a_k^j``
(one ``(W, F) @ (F, J + 1)`` matrix product) and ``L = Σ_{j≥1} (−1)^{j+1} ρ^{2j} A_j / j`` with
the data's power sums ``A_j = Σ_k a_k^j``. Where instead ``x = 1/(ρ² min_k a_k) ≤ SERIES_X`` (the
floor dominates every reading), they are series in ``1/ρ²``:
``S = Σ_j (−1)^j ρ^{−2(j+1)} Σ_k e_k a_k^{−(j+1)}`` and
``L = F log ρ² + Σ_k log a_k + Σ_{j≥1} (−1)^{j+1} ρ^{−2j} Σ_k a_k^{−j} / j``.
Truncated after ``J`` = :data:`SERIES_TERMS` terms, the relative error of ``S`` is below
``x^{J+1}/(1 − x)`` ≈ 1e-15 and the absolute error of ``L`` below ``F x^{J+1}/(J + 1)``
(4e-13 nats for 2000 points). Parameter sets in between get the sums point by point.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["GaussianNoiseSums", "SERIES_X", "SERIES_TERMS"]

SERIES_X = 1e-3
SERIES_TERMS = 4


class GaussianNoiseSums:
    """Precomputed data sums for one measurement ``Y`` [S] with squared weights ``w2``."""

    def __init__(self, Y, w2):
        Y = np.asarray(Y, complex)
        w2 = np.asarray(w2, float)
        abs2 = Y.real**2 + Y.imag**2
        self.F = Y.size
        self.a = 1.0 / abs2
        self.a_max = float(np.max(self.a))
        self.scale = np.sqrt(w2 * self.a)  # e_k = |r_k|² scale_k²
        self.const = float(np.sum(np.log(abs2 / w2)))
        self.a_min = float(np.min(self.a))
        j = np.arange(SERIES_TERMS + 1)
        # a^j (small ρ) and a^-(j+1) (large ρ), j = 0..J
        self.powers_low = np.ascontiguousarray(self.a[:, None] ** j[None, :])
        self.powers_high = np.ascontiguousarray(self.a[:, None] ** -(j[None, :] + 1.0))
        lsign = np.array([(-1.0) ** (i + 1) / i for i in range(1, SERIES_TERMS + 1)])
        self._l_low = lsign * np.sum(self.a[:, None] ** j[None, 1:], axis=0)
        self._l_high = lsign * np.sum(self.a[:, None] ** -j[None, 1:], axis=0)
        self._sum_log_a = float(np.sum(np.log(self.a)))

    def sums(self, e, rho2) -> tuple[np.ndarray, np.ndarray]:
        """``(S(ρ), L(ρ))`` for scaled squared residuals ``e (W, F)`` and ``ρ² (W,)``."""
        rho2 = np.asarray(rho2, float)
        J = SERIES_TERMS + 1
        j = np.arange(J)
        S = np.empty(rho2.shape)
        L = np.empty(rho2.shape)
        with np.errstate(all="ignore"):
            low = rho2 * self.a_max <= SERIES_X
            high = ~low & (1.0 / (rho2 * self.a_min) <= SERIES_X)
            for rows, powers in ((low, self.powers_low), (high, self.powers_high)):
                if not np.any(rows):
                    continue
                sel = slice(None) if np.all(rows) else np.flatnonzero(rows)
                G = e[sel] @ powers  # (n, J)
                r = rho2[sel]
                if powers is self.powers_low:
                    S[sel] = np.sum(G * (-r[:, None]) ** j, axis=1)
                    L[sel] = (r[:, None] ** j[1:]) @ self._l_low
                else:
                    inv = 1.0 / r
                    S[sel] = np.sum(G * (-inv[:, None]) ** j, axis=1) * inv
                    L[sel] = self.F * np.log(r) + self._sum_log_a + (inv[:, None] ** j[1:]) @ self._l_high
        mid = np.flatnonzero(~(low | high))
        if mid.size:
            with np.errstate(all="ignore"):
                x = rho2[mid, None] * self.a[None, :]
                S[mid] = np.sum(e[mid] / (1.0 + x), axis=1)
                L[mid] = np.sum(np.log1p(x), axis=1)
        return S, L

    def total(self, e, sigma_rel, sigma_abs) -> np.ndarray:
        """Total Gaussian log-likelihood [nats] per row of ``e (W, F)``; ``-inf`` where not finite."""
        srel = np.asarray(sigma_rel, float)
        with np.errstate(all="ignore"):
            rho2 = (np.asarray(sigma_abs, float) / srel) ** 2
            S, L = self.sums(e, rho2)
            ll = (-self.F * math.log(2.0 * math.pi) - 2.0 * self.F * np.log(srel) - self.const - L
                  - S / (2.0 * srel * srel))
        return np.where(np.isfinite(ll), ll, -np.inf)
