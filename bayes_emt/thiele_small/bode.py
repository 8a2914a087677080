"""Does the recorded phase belong to the recorded |Z|? Bode's gain-phase check on a T/S fit's curve.

The electrical impedance of a passive one-port, a moving-coil transducer's among them, is
positive-real and so minimum-phase: its phase is fixed by its magnitude (Bode's gain-phase
relation; H. W. Bode, *Network Analysis and Feedback Amplifier Design*, 1945, ch. 14). Every coil
model here is minimum-phase too. A recording whose phase is not the minimum-phase partner of its
|Z| (a phase error of the measuring setup, magnitude and phase smoothed or measured apart, a driver
that drifts during the sweep) cannot be followed by any of them in both: a fit with the phase then
lands where the two disagree least, a fit of |Z| alone (``--magnitude-only``) where |Z| is met, and
the values set by the resonance peak's height and width (Re, Qes, Qts) differ between the two by
more than either posterior's width.

The check, on the T/S result's ``curve`` record (:mod:`.curve`: the recording and the fitted model
curve ``Z_m`` at the same frequencies): the minimum-phase partner of the recorded |Z_d| is

    φ_min(f) = φ_m(f) + H[ln |Z_d / Z_m|](f),

``H`` the minimum-phase transform of :func:`bayes_emt.io.minphase.minimum_phase_deg`. Since ``H``
is linear in ln|Z|, the model curve carries the parts of |Z| that run past the band's edges and
``H`` acts only on the residual ratio (near 1, flat at the edges): the band's truncation, which
moves a direct transform of |Z_d| by degrees near a band edge, hardly enters. The departure
``δ(f) = φ_d(f) − φ_min(f)`` is taken over the resonance region ``fs/3 … 3 fs`` (where Small's
method and the peak-set quantities live) and compared with the recorded phase's own noise (the
robust second-difference scatter of :mod:`.model_free`). A departure above
:data:`DEPARTURE_NOISE_FACTOR` times that noise and above :data:`DEPARTURE_MIN_DEG` is reported.

On the three DATS recordings (Dayton Audio Test System exports) the departure is 1.5-5.5° (phase
noise 0.015-0.033°; the figure depends on the model curve it is taken about, whose misfit at the
band's edges enters the transform); with UD, a complex fit of |Z_d| with φ_min in place of the
recorded phase gives Qes within 0.2-1.7 % of the |Z|-only fit, where the fit to the recorded phase
differs by 2.6-4.8 %. Three recordings from other benches depart by 0.17-0.58°.
"""

from __future__ import annotations

import math

import numpy as np

from ..io.minphase import minimum_phase_deg
from .model_free import _noise

__all__ = ["DEPARTURE_NOISE_FACTOR", "DEPARTURE_MIN_DEG", "RESONANCE_SPAN", "minimum_phase_partner",
           "phase_departure", "phase_departure_note"]

#: a departure is reported when it exceeds this many times the recorded phase's own noise ...
DEPARTURE_NOISE_FACTOR = 10.0
#: ... and this many degrees: a third of the smallest departure seen on the DATS exports (1.5° on
#: the SB26 tweeter, which moved its Qes by 3 % between the fits with and without the phase)
DEPARTURE_MIN_DEG = 0.5
#: the residual is continued beyond the band at the median of this many end values
EDGE_POINTS = 5
#: the resonance region: fs / RESONANCE_SPAN ... fs * RESONANCE_SPAN
RESONANCE_SPAN = 3.0


def phase_departure(curve: dict | None, fs_hz: float | None) -> dict | None:
    """``{"max_deg", "signed_deg", "f_at_max_hz", "band_hz", "noise_deg", "n_points"}`` (degrees,
    Hz): the largest departure of the recorded phase from the minimum-phase partner of the recorded
    |Z| over the resonance region (module docstring), or ``None`` without a fitted curve or with
    fewer than 5 points there. A magnitude-only result's curve carries the minimum-phase estimate as
    its phase, so there is nothing to check: callers skip it."""
    if not curve or "fit_abs_z_ohm" not in curve or fs_hz is None or not math.isfinite(fs_hz) or fs_hz <= 0:
        return None
    f = np.asarray(curve["f_hz"], float)
    mag_d, ph_d = np.asarray(curve["data_abs_z_ohm"], float), np.asarray(curve["data_phase_deg"], float)
    mag_m, ph_m = np.asarray(curve["fit_abs_z_ohm"], float), np.asarray(curve["fit_phase_deg"], float)
    ok = np.isfinite(f) & np.isfinite(mag_d) & np.isfinite(ph_d) & np.isfinite(mag_m) & np.isfinite(ph_m)
    ok &= (mag_d > 0) & (mag_m > 0) & (f > 0)
    f, mag_d, ph_d, mag_m, ph_m = f[ok], mag_d[ok], ph_d[ok], mag_m[ok], ph_m[ok]
    if f.size < 5:
        return None
    dev = (ph_d - minimum_phase_partner(f, mag_d, mag_m, ph_m) + 180.0) % 360.0 - 180.0
    band = (f >= fs_hz / RESONANCE_SPAN) & (f <= fs_hz * RESONANCE_SPAN)
    if np.count_nonzero(band) < 5:
        return None
    i = int(np.argmax(np.abs(np.where(band, dev, 0.0))))
    return {"max_deg": float(abs(dev[i])), "signed_deg": float(dev[i]), "f_at_max_hz": float(f[i]),
            "band_hz": [float(fs_hz / RESONANCE_SPAN), float(fs_hz * RESONANCE_SPAN)],
            "noise_deg": _noise(ph_d, np.log(f)), "n_points": int(np.count_nonzero(band))}


def minimum_phase_partner(f_hz, abs_z_data, abs_z_model, phase_model_deg) -> np.ndarray:
    """``φ_min`` [deg]: the minimum-phase partner of the recorded |Z| (``abs_z_data`` [Ω] at
    ``f_hz``), taken about a minimum-phase model curve (its |Z| and phase at the same frequencies):
    ``φ_m + H[ln |Z_d / Z_m|]`` (module docstring)."""
    f = np.asarray(f_hz, float)
    r = np.log(np.asarray(abs_z_data, float) / np.asarray(abs_z_model, float))
    return np.asarray(phase_model_deg, float) + _residual_transform(f, r)


def _residual_transform(f: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``H[r]`` [deg] at ``f`` for the log-magnitude residual ``r``, continued flat beyond the band
    (at the median of its :data:`EDGE_POINTS` end values, from two decades out): the model curve
    carries what lies beyond the band, and a slope from the last two noisy points, continued to
    infinity, would move the transform near the edges by degrees."""
    k = min(EDGE_POINTS, r.size)
    lo, hi = float(np.median(r[:k])), float(np.median(r[-k:]))
    fx = np.concatenate([[f[0] * 1e-4, f[0] * 1e-2], f, [f[-1] * 1e2, f[-1] * 1e4]])
    rx = np.concatenate([[lo, lo], r, [hi, hi]])
    return minimum_phase_deg(fx, np.exp(rx))[2:-2]


def phase_departure_note(curve: dict | None, fs_hz: float | None) -> list[dict]:
    """The ``phase_not_minimum`` note (a list of one warning record) when the recorded phase departs
    from the minimum-phase partner of the recorded |Z| beyond the noise (module docstring), else
    ``[]``."""
    d = phase_departure(curve, fs_hz)
    if d is None or not (d["max_deg"] > DEPARTURE_MIN_DEG
                         and d["max_deg"] > DEPARTURE_NOISE_FACTOR * d["noise_deg"]):
        return []
    lo, hi = d["band_hz"]
    return [{"code": "phase_not_minimum",
             "short": f"the recorded phase departs {d['max_deg']:.2g} deg from the minimum-phase partner "
                      f"of |Z| near resonance (noise {d['noise_deg']:.2g} deg): Re, Qes, Qts depend on "
                      "whether the phase is fitted",
             "message": f"the recorded phase departs by up to {d['max_deg']:.2g} deg (at "
                        f"{d['f_at_max_hz']:.4g} Hz; {lo:.4g}-{hi:.4g} Hz examined) from the minimum-phase "
                        "partner of the recorded |Z| (Bode's gain-phase relation, taken about the fitted "
                        f"curve), {d['max_deg'] / max(d['noise_deg'], 1e-12):.3g} times the phase's own "
                        f"noise ({d['noise_deg']:.2g} deg). A passive impedance is minimum-phase, so the "
                        "phase and |Z| in this file are not one impedance (a phase error of the setup, "
                        "magnitude and phase smoothed or measured apart, a driver drifting during the "
                        "sweep); every coil model is minimum-phase and cannot follow both, so the values "
                        "the resonance peak sets (Re, Qes, Qts) differ between this fit and a fit of |Z| "
                        "alone (--magnitude-only) by more than either interval; a second sweep, or the "
                        "bench's phase calibration, tells which channel to trust"}]
