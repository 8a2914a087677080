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
rows. The analyser's resolution is then estimated as that band's width over the number of distinct
values in it, and the band extends over the following rows whose spacing to the next row is still
below it (a 1/24-octave grid over 0.3 Hz bins: up to about 10 Hz). Every row in the band is
dropped (the rows between runs there are interpolated from the same coarse bins), and one note
names the band [Hz]. An isolated coincidence higher up (two equal neighbouring rows in a 3-digit
export) does not qualify.

The dropped rows are not thrown away: each run of copies is one reading of a coarse FFT bin, so
:func:`low_band_rows` keeps one row per run (at the run's geometric-mean frequency, the bin's
frequency to within half the analyser's resolution) in ``meta["low_band"]``. They are not fitted (their
frequency labels are only good to that half bin), but where the driver's motion is negligible they
read the voice coil's resistance: the low-frequency plateau a bench reads its own Re from
(:mod:`bayes_emt.estimation.plateau`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_REPEATED", "resolution_band", "low_band_rows"]

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
    if best == 0 or best > n // 2:
        return 0
    # the analyser's resolution: the band's width over the number of distinct values in it; above
    # the band, rows closer than that to the next are still finer than the resolution
    distinct = 1 + int(np.count_nonzero(~same[:best - 1]))
    resolution = (f_hz[best] - f_hz[0]) / distinct
    while best < n // 2 and f_hz[best + 1] - f_hz[best] < resolution:
        best += 1
    return best


def drop_note(path, f_hz: np.ndarray, k: int, n: int) -> str:
    """The one note line naming the dropped band."""
    return (f"{path}: dropped {k} of {n} rows, {f_hz[0]:.4g}-{f_hz[k - 1]:.4g} Hz: consecutive rows "
            "repeat the same values there (the grid is finer than the analyser's resolution), so they "
            "are copies, not measurements; fitted from "
            f"{f_hz[k]:.4g} Hz up")


def low_band_rows(f_hz: np.ndarray, mag: np.ndarray, phase_deg: np.ndarray | None) -> dict:
    """One row per run of identical rows in a dropped low band: ``{"f_hz", "abs_ohm", "phase_deg"}``
    (lists; ``phase_deg`` None for a magnitude-only file), the frequency of a run the geometric mean
    of its rows' frequencies. JSON-serialisable (it travels in ``Measurement.meta``)."""
    f_hz, mag = np.asarray(f_hz, float), np.asarray(mag, float)
    ph = None if phase_deg is None else np.asarray(phase_deg, float)
    new = np.ones(f_hz.size, bool)
    new[1:] = (mag[1:] != mag[:-1]) | (False if ph is None else (ph[1:] != ph[:-1]))
    run = np.cumsum(new) - 1
    n = int(run[-1]) + 1 if run.size else 0
    f_run = np.exp(np.bincount(run, np.log(f_hz), n) / np.bincount(run, None, n)) if n else np.empty(0)
    first = np.flatnonzero(new)
    return {"f_hz": [float(x) for x in f_run], "abs_ohm": [float(x) for x in mag[first]],
            "phase_deg": None if ph is None else [float(x) for x in ph[first]]}
