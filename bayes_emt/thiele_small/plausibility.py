"""Plausibility of a T/S workflow's inputs and results: the mistakes a person makes at a bench
(a mass in grams given as kilograms, an area in cm² as m², a box in litres as m³, a vented-box
curve given as free air) caught before or after the fit, each as a one-line refusal or warning
naming the keyword and its command-line option.

Ranges (generous on purpose: a refusal is for a value no loudspeaker, shaker or shunt-damper
transducer has, a warning for one that is rare):

==================  ======================  ========================================================
quantity            refused beyond          why
==================  ======================  ========================================================
added mass Δm       > 2 kg                  recommended Δm is 50–100 % of Mms; the heaviest 21"
                                            cones have Mms ≈ 0.5 kg (a bare ``8.017`` meant grams)
known Mms           > 2 kg                  as above
Sd                  > 1 m²                  a 21" driver's Sd is ≈ 0.15 m² (a bare ``85`` meant cm²)
test box Vb         > 2 m³                  a test box is litres (a bare ``20`` meant L)
η0                  > 100 %                 impossible: Sd, Δm or Mms is wrong
Bl                  > 100 T·m (warning      the strongest motors are ≈ 40 T·m
                    above 60, below 0.3)
Mms (result)        > 2 kg, warning beyond  micro-speakers ≈ 0.05 g, 21" woofers ≈ 0.5 kg
                    [0.05 g, 1 kg]
Mms/Sd              warning outside         a cone's moving mass per area: tweeters ≈ 0.3,
                    [0.05, 30] kg/m²        8" woofers ≈ 1.4, 18" subwoofers ≈ 2.5 kg/m²
Δm/Mms              warning below 0.1       fs moves by < 5 %: Mms and Bl are poorly determined
==================  ======================  ========================================================

The vented-box signature (:func:`vented_signature`): |Z| with two resonance peaks, each at least
1.5 times the curve's minimum (≈ Re), within a factor 10 in frequency, and between them a minimum at
most 0.6 of the lower peak (the port tuning), and the phase crossing zero at the upper peak from +
to − (a resonance, not a bump on the coil's inductive rise); a free-air driver has one such peak.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BayesEMTError
from ..measurement import Measurement

__all__ = ["ImplausibleInput", "check_inputs", "check_result", "vented_signature", "setup_warnings", "OPTION"]

#: the command-line option of each keyword (the messages name both)
OPTION = {"sd": "--sd", "mms": "--mms", "bl": "--bl", "delta_m": "--delta-m", "box_volume": "--box-volume"}

MAX_MASS_KG = 2.0
MAX_SD_M2 = 1.0
MAX_BOX_M3 = 2.0
MAX_BL_TM = 100.0
BL_WARN = (0.3, 60.0)
MMS_WARN_KG = (0.05e-3, 1.0)
AREAL_DENSITY_WARN = (0.05, 30.0)  # kg/m^2
MIN_MASS_RATIO = 0.1
_BARE = "bare numbers are SI: kg, m^2, m^3; write 8.017g, 85cm2, 20L"


class ImplausibleInput(BayesEMTError, ValueError):
    """An input (or the result it leads to) no transducer has; the message names the option."""


def _name(key: str) -> str:
    return f"{key} ({OPTION[key]})" if key in OPTION else key


def check_inputs(*, sd=None, mms=None, bl=None, deltas=(), box_volume=None) -> None:
    """Refuse inputs beyond any transducer's range before any fit (module docstring's table)."""
    for i, dm in enumerate(deltas):
        if abs(dm) > MAX_MASS_KG:
            which = f" #{i + 1}" if len(deltas) > 1 else ""
            raise ImplausibleInput(
                f"{_name('delta_m')}{which} = {dm:g} kg is heavier than any cone (recommended: 50-100 % of "
                f"Mms, a few grams to a few hundred); did you mean {dm:g}g?")
    if mms is not None and mms > MAX_MASS_KG:
        raise ImplausibleInput(f"{_name('mms')} = {mms:g} kg is heavier than any cone (21-inch woofers: "
                               f"about 0.5 kg); did you mean {mms:g}g?")
    if bl is not None and bl > MAX_BL_TM:
        raise ImplausibleInput(f"{_name('bl')} = {bl:g} T m is beyond any motor (the strongest are about "
                               "40 T m)")
    if sd is not None and sd > MAX_SD_M2:
        hint = f"{sd:g}cm2" if sd * 1e-4 <= MAX_SD_M2 else f"{sd:g}mm2"
        raise ImplausibleInput(f"{_name('sd')} = {sd:g} m^2 is larger than any cone (a 21-inch driver's "
                               f"Sd is about 0.15 m^2 = 1500 cm^2); did you mean {hint}?")
    if box_volume is not None and box_volume > MAX_BOX_M3:
        raise ImplausibleInput(f"{_name('box_volume')} = {box_volume:g} m^3 is not a test box; did you "
                               f"mean {box_volume:g}L?")


def _median(params: dict, name: str) -> float | None:
    p = params.get(name)
    return None if p is None else float(p["value"])


def check_result(params: dict, *, method: str, sd=None, mms=None, bl=None, deltas=()) -> list[dict]:
    """Warnings (``{"code", "short", "message"}``) for implausible T/S values; raises
    :class:`ImplausibleInput` for impossible ones (η0 > 100 %, Mms > 2 kg, Bl > 100 T·m),
    naming the input that most likely carries the mistake."""
    src = ("delta_m" if method == "added_mass" else "sd" if method == "added_volume"
           else "mms" if mms is not None else "bl" if bl is not None else None)
    culprit = _name(src) if src else "the inputs"
    out = []
    m, b, eta = _median(params, "Mms"), _median(params, "Bl"), _median(params, "eta0")
    if eta is not None and eta > 1.0:
        raise ImplausibleInput(
            f"eta0 = {100 * eta:.3g} % is impossible (above 100 %): check {_name('sd')} (m^2 unless a unit "
            f"is given, e.g. 85cm2) and {culprit}")
    if b is not None and b > MAX_BL_TM:
        raise ImplausibleInput(f"Bl = {b:.4g} T m from {culprit} is beyond any motor (about 40 T m at most): "
                               f"check its unit ({_BARE})")
    if m is not None and m > MAX_MASS_KG:
        raise ImplausibleInput(f"Mms = {m:.4g} kg from {culprit} is heavier than any cone: check its unit "
                               f"({_BARE})")
    if m is not None and not MMS_WARN_KG[0] <= m <= MMS_WARN_KG[1]:
        out.append({"code": "implausible_mms", "short": f"Mms = {1e3 * m:.4g} g is outside the usual "
                    f"{1e3 * MMS_WARN_KG[0]:g} g .. {MMS_WARN_KG[1]:g} kg: check {culprit}",
                    "message": f"Mms = {1e3 * m:.4g} g is outside the range of loudspeaker cones "
                               f"({1e3 * MMS_WARN_KG[0]:g} g .. {MMS_WARN_KG[1]:g} kg): check the value and "
                               f"unit of {culprit}"})
    if b is not None and not BL_WARN[0] <= b <= BL_WARN[1]:
        out.append({"code": "implausible_bl", "short": f"Bl = {b:.4g} T m is outside the usual "
                    f"{BL_WARN[0]:g} .. {BL_WARN[1]:g} T m: check {culprit}",
                    "message": f"Bl = {b:.4g} T m is outside the range of loudspeaker motors "
                               f"({BL_WARN[0]:g} .. {BL_WARN[1]:g} T m): check the value and unit of "
                               f"{culprit}"})
    if m is not None and sd is not None:
        rho = m / sd
        if not AREAL_DENSITY_WARN[0] <= rho <= AREAL_DENSITY_WARN[1]:
            out.append({"code": "implausible_sd", "short": f"Mms/Sd = {rho:.3g} kg/m^2 does not fit a cone "
                        f"of Sd = {1e4 * sd:.4g} cm^2: check {_name('sd')}",
                        "message": f"the moving mass per cone area Mms/Sd = {rho:.3g} kg/m^2 is outside the "
                                   f"range of real cones ({AREAL_DENSITY_WARN[0]:g} .. "
                                   f"{AREAL_DENSITY_WARN[1]:g} kg/m^2; an 8-inch woofer: 1.4): check "
                                   f"{_name('sd')} = "
                                   f"{1e4 * sd:.4g} cm^2 and its unit"})
    if eta is not None and eta > 0.1:
        out.append({"code": "implausible_eta0", "short": f"eta0 = {100 * eta:.3g} % is above any "
                    f"loudspeaker's 10 %: check {_name('sd')}",
                    "message": f"the reference efficiency eta0 = {100 * eta:.3g} % is above any direct "
                               f"radiator's (at most a few %): check {_name('sd')} and {culprit}"})
    if method == "added_mass" and m is not None and deltas:
        ratio = max(abs(d) for d in deltas) / m
        if ratio < MIN_MASS_RATIO:
            shift = 100 * (1 - 1 / math.sqrt(1 + ratio))
            out.append({"code": "small_added_mass", "short": f"the added mass is {100 * ratio:.2g} % of "
                        f"Mms: fs moves {shift:.2g} %, Mms and Bl poorly determined",
                        "message": f"the largest added mass is {100 * ratio:.2g} % of Mms, so fs moves by "
                                   f"only {shift:.2g} %: Mms and Bl are poorly determined; add 50-100 % of "
                                   f"Mms ({_name('delta_m')})"})
    return out


def _resonant(ph: np.ndarray, f: np.ndarray, dip: int, j: int) -> bool:
    """Whether the upper peak ``j`` is a resonance (the phase crosses zero from + to − between the
    dip and 1.5 f_j) after a crossing from − to + at the port tuning (between the lower peak and
    ``j``): a bump on the coil's inductive rise keeps a positive phase and is not one."""
    hi = int(np.searchsorted(f, 1.5 * f[j]))
    seg = np.sign(ph[dip:hi])
    down = np.flatnonzero((seg[:-1] > 0) & (seg[1:] < 0))
    up = np.flatnonzero((seg[:-1] < 0) & (seg[1:] > 0))
    lo = np.sign(ph[: dip + 1])
    up_before = np.flatnonzero((lo[:-1] < 0) & (lo[1:] > 0))
    return bool(down.size and (up.size and up[0] < down[-1] or up_before.size))


def vented_signature(meas: Measurement) -> str | None:
    """Words describing a vented box's two resonance peaks in ``meas``'s |Z| (module docstring), or
    ``None`` when the curve does not have them."""
    z = np.abs(meas.Z)
    if z.size < 15:
        return None
    f = meas.f_hz
    k = 5
    pad = np.pad(np.log(z), k // 2, mode="edge")
    sm = np.exp(np.median(np.lib.stride_tricks.sliding_window_view(pad, k), axis=-1))
    floor = float(np.min(sm))
    ph = np.median(np.lib.stride_tricks.sliding_window_view(np.pad(np.angle(meas.Z), 4, mode="edge"), 9),
                   axis=-1)
    peaks = [i for i in range(1, sm.size - 1) if sm[i] >= sm[i - 1] and sm[i] > sm[i + 1]
             and sm[i] >= 1.5 * floor]
    for a, i in enumerate(peaks):
        for j in peaks[a + 1:]:
            if f[j] / f[i] > 10.0:
                break
            dip = i + int(np.argmin(sm[i : j + 1]))
            if sm[dip] <= 0.6 * min(sm[i], sm[j]) and dip not in (i, j) and _resonant(ph, f, dip, j):
                return (f"|Z| has two resonance peaks, {sm[i]:.3g} ohm at {f[i]:.4g} Hz and "
                        f"{sm[j]:.3g} ohm at {f[j]:.4g} Hz, with a minimum of {sm[dip]:.3g} ohm at "
                        f"{f[dip]:.4g} Hz between them")
    return None


def setup_warnings(meas: Measurement, box: Measurement | None = None) -> list[dict]:
    """``vented_curve`` warnings: the free-air recording ``meas``, or the sealed test box's ``box``,
    shows a vented box's two resonance peaks (:func:`vented_signature`)."""
    out = []
    vented = vented_signature(meas)
    if vented is not None:
        out.append({"code": "vented_curve", "short": "the curve has a vented box's two peaks, not free "
                    "air's one: these are not free-air T/S values",
                    "message": f"{meas.source}: {vented}: a vented box's signature, not a free-air "
                               "driver's; the T/S method assumes DATA is the driver in free air (for a "
                               "box, diagnose --setup vented reads the port's tuning fb)"})
    vented_box = None if box is None else vented_signature(box)
    if vented_box is not None:
        out.append({"code": "vented_curve", "short": "the box recording has a vented box's two peaks: "
                    "the added-volume method needs a sealed box",
                    "message": f"{box.source}: {vented_box}: the box is ported; the added-volume "
                               "method assumes a sealed box (Vas would be wrong)"})
    return out
