"""Closed-form linearisations the terms use to start themselves (Levy 1959; Sanathanan & Koerner 1963).

Small real least-squares problems on complex data: the paper's first-order rational Bessel
approximation for the eddy-current diffusion time ``α``, and its linearisation of model II's
``1/Zc``. Pure numpy; the estimation layer runs them through the terms' :class:`CoilStart`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["stacked_real", "lstsq_real", "rational_alpha", "lossy_inductance_linear"]


def stacked_real(A, b, w):
    """The real problem ``min ||w (A x − b)||`` over real ``x`` for complex ``A (F, c)``, ``b (F,)``:
    real and imaginary parts stacked, columns scaled to unit norm. Returns ``(A_scaled, b, scale)``;
    the solution of the scaled problem divided by ``scale`` solves the original."""
    Aw = A * w[:, None]
    bw = b * w
    Ar = np.vstack([Aw.real, Aw.imag])
    br = np.concatenate([bw.real, bw.imag])
    scale = np.linalg.norm(Ar, axis=0)
    scale[scale == 0] = 1.0
    return Ar / scale, br, scale


def lstsq_real(A, b, w):
    """Solve ``min ||w (A x − b)||`` over real ``x`` for complex ``A, b`` (columns scaled)."""
    As, br, scale = stacked_real(A, b, w)
    x, *_ = np.linalg.lstsq(As, br, rcond=None)
    return x / scale


def rational_alpha(s, Ze, w, with_gap: bool):
    """``α`` [s] from the paper's first-order rational approximation
    ``Z_III ≈ k s (α s + 8)/(4 α s + 16)``, ``k = β sqrt(α)`` (plus ``Lg s`` and ``R0``):
    ``16 Ze = −4 α s Ze + c2 s² + c1' s + 16 R0`` is linear in ``(α, c2, c1', R0)``, with
    ``c1' = 8k + 16 Lg + 4 α R0`` and ``c2 = (k + 4 Lg) α``. The approximation holds for
    ``|α s| ≲ 4`` (10 % error there), so the band is narrowed to that and solved again.
    Returns ``α`` or ``None`` if not physical."""
    keep = np.ones(s.size, bool)
    alpha = None
    cols = np.column_stack([-4 * s * Ze, s * s, s, 16 * np.ones_like(s)])
    for _ in range(3):
        if np.count_nonzero(keep) < 5:
            break
        a, c2, c1, R0 = lstsq_real(cols[keep], 16 * Ze[keep], w[keep])
        c1 = c1 - 4 * a * R0
        k = c1 / 4 - c2 / a if with_gap else c1 / 8
        if not (np.isfinite(a) and a > 0 and k > 0):
            break
        alpha = float(a)
        keep = np.abs(s) * alpha <= 4.0
    return alpha


def lossy_inductance_linear(s, Ze, w, R0_levy: float, L_lf: float) -> dict[str, float]:
    """Model II by the paper's linearisation: ``1/Zc = (1/L0)/s + 1/Rμ`` with the Levy ``R0``,
    weighted so that errors in ``Zc`` count relative to ``|Z|``. Returns ``{R0, L0, Rmu}`` [Ω, H, Ω]
    (``L_lf`` [H] and a high ``Rμ`` where a coefficient comes out non-positive)."""
    Zc = Ze - R0_levy
    x = lstsq_real(np.column_stack([1 / s, np.ones_like(s)]), 1.0 / Zc, np.abs(Zc) ** 2 * w)
    L0 = 1 / x[0] if x[0] > 0 else L_lf
    Rmu = 1 / x[1] if x[1] > 0 else 1e3 * L0 * float(np.max(np.abs(s)))
    return {"R0": R0_levy, "L0": float(L0), "Rmu": float(Rmu)}
