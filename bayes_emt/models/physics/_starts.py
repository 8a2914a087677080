"""What the catalogue terms' starts share: where in the band to look and how to find a peak in a
noisy residual (:meth:`~bayes_emt.models.term.Term.start`)."""

from __future__ import annotations

import numpy as np
from scipy import signal

from ..term import StartContext

__all__ = ["top", "peaks", "smooth"]


def top(ctx: StartContext, fraction: float = 0.15) -> np.ndarray:
    """Mask of the top ``fraction`` of the band (in log frequency)."""
    m = ctx.in_band()
    w = ctx.omega[m]
    lw = np.log(w)
    cut = lw[-1] - fraction * (lw[-1] - lw[0])
    out = np.zeros_like(m)
    out[np.flatnonzero(m)[lw >= cut]] = True
    return out


def peaks(x: np.ndarray, n: int, prominence: float = 0.0) -> np.ndarray:
    """Indices of the ``n`` most prominent interior local maxima of ``x`` (most prominent first);
    with ``prominence`` > 0 only those standing out by that much (noise bumps do not)."""
    i, props = signal.find_peaks(x, prominence=prominence)
    return i[np.argsort(-props["prominences"], kind="stable")][:n]


def smooth(x: np.ndarray, k: int = 5) -> np.ndarray:
    """Running median of ``k`` points (edges repeated)."""
    if x.size < k:
        return x
    pad = np.pad(x, k // 2, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(pad, k), axis=-1)
