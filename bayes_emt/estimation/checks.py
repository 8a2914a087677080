"""Pre-fit checks on a measurement: where the mechanical resonance is, and whether the data can
identify a model's parameters at all."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..errors import DataFormatError, IdentifiabilityWarning
from ..measurement import Measurement

__all__ = ["Resonance", "locate_resonance", "check_fit_inputs"]


@dataclass(frozen=True)
class Resonance:
    """The most prominent impedance peak.

    ``omega`` [rad/s] of the peak, ``prominence`` in natural-log units of |Z|, ``index`` into the
    measurement, and the half-prominence band ``omega_lo..omega_hi`` [rad/s] (a crude width).
    """

    omega: float
    prominence: float
    index: int
    omega_lo: float
    omega_hi: float


def locate_resonance(meas: Measurement, *, min_prominence: float = 0.02) -> Resonance | None:
    """The mechanical resonance as the most prominent interior peak of ``log |Z|``.

    The coil's inductive rise is monotonic, so it forms no interior peak; the motional term adds
    a bump of height ``φ̄²/(2ζω0)`` over ``R0``. Returns ``None`` when no interior peak stands out
    by ``min_prominence`` (≈ 2 % of |Z|) — the band then misses the resonance.
    """
    logz = np.log(np.abs(meas.Z))
    if logz.size < 5:
        return None
    # light smoothing against measurement noise: a 5-point running median
    pad = np.pad(logz, 2, mode="edge")
    smooth = np.median(np.lib.stride_tricks.sliding_window_view(pad, 5), axis=-1)
    peaks, props = signal.find_peaks(smooth, prominence=min_prominence, width=0, rel_height=0.5)
    if peaks.size == 0:
        return None
    best = int(np.argmax(props["prominences"]))
    i = int(peaks[best])
    lo = float(np.interp(props["left_ips"][best], np.arange(logz.size), meas.omega))
    hi = float(np.interp(props["right_ips"][best], np.arange(logz.size), meas.omega))
    return Resonance(float(meas.omega[i]), float(props["prominences"][best]), i, lo, hi)


def check_fit_inputs(meas: Measurement, n_params: int, *, label: str = "model") -> Resonance | None:
    """Raise when the data cannot determine ``n_params`` parameters; warn when the band misses
    the mechanical resonance (then ζ, ω0 and φ̄ are not identifiable)."""
    # each complex point carries two real numbers
    if 2 * meas.n_points <= n_params:
        raise DataFormatError(
            f"{meas.source}: {meas.n_points} points cannot determine the {n_params} parameters "
            f"of {label} (need more than {n_params // 2} points)")
    res = locate_resonance(meas)
    if res is None:
        warnings.warn(
            f"{meas.source}: no mechanical resonance found between {meas.omega[0]:.4g} and "
            f"{meas.omega[-1]:.4g} rad/s; zeta, omega0 and phi are not identifiable from this band",
            IdentifiabilityWarning, stacklevel=2)
    return res
