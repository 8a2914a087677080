"""Rows below the analyser's resolution: runs of identical consecutive rows at the low end.

A bench that interpolates a coarse FFT spectrum onto a finer logarithmic grid (the Dayton Audio
Test System exports 1/24-octave points from 1.03 Hz while its FFT bins are about 0.3 Hz apart)
writes the same |Z| and phase on several consecutive rows at low frequency: there the grid step
is finer than the analyser's resolution and the rows are copies, not measurements. Fitted as
data they look like a misfit and a port resonance at 1-3 Hz.

Rule (applied by every reader of magnitude/phase text): a *run* is two or more consecutive rows
(in frequency order) with the same magnitude and the same phase (bitwise equal as written). The
dropped band runs from the first row to the last row of the highest run such that, at or below
it, at least half of the rows belong to runs and there are at least :data:`MIN_REPEATED` such
rows. Every row in that band is dropped (the rows between runs there are interpolated from the
same coarse bins), and one note names the band [Hz]. An isolated coincidence higher up (two
equal neighbouring rows in a 3-digit export) does not qualify.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_REPEATED", "resolution_band"]

MIN_REPEATED = 4  # rows in runs needed before a low band counts as below the resolution


def resolution_band(f_hz: np.ndarray, a: np.ndarray, b: np.ndarray) -> int:
    """Number of leading rows (in increasing frequency) to drop as below the analyser's resolution.

    Parameters
    ----------
    f_hz : (F,) increasing frequencies [Hz].
    a, b : (F,) the two value columns as written (magnitude and phase, or real and imaginary).

    Returns
    -------
    int
        ``k`` such that rows ``0..k-1`` are dropped; 0 when the file shows no such band.
    """
    n = f_hz.size
    if n < 3:
        return 0
    same = (a[1:] == a[:-1]) & (b[1:] == b[:-1])
    in_run = np.zeros(n, bool)
    in_run[1:] |= same
    in_run[:-1] |= same
    if not in_run.any():
        return 0
    counts = np.cumsum(in_run)
    best = 0
    for i in np.flatnonzero(in_run):
        if counts[i] >= MIN_REPEATED and counts[i] >= 0.5 * (i + 1):
            best = i + 1
    # keep at least half the file: a curve that is flat over most of its band is not an artefact
    return best if best <= n // 2 else 0


def drop_note(path, f_hz: np.ndarray, k: int, n: int) -> str:
    """The one note line naming the dropped band."""
    return (f"{path}: dropped {k} of {n} rows, {f_hz[0]:.4g}-{f_hz[k - 1]:.4g} Hz: consecutive rows "
            "repeat the same values there (the grid is finer than the analyser's resolution), so they "
            "are copies, not measurements; fitted from "
            f"{f_hz[k]:.4g} Hz up")
