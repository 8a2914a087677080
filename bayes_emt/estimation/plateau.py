"""Re from the recording's low-frequency plateau: the bench's own way of reading the coil resistance.

A bench that sweeps down to about 1 Hz (the Dayton Audio Test System does) reads Re off the lowest
rows of its curve, where the cone hardly moves and the impedance is the voice coil's resistance:
DATS's ``R(e)`` is |Z| at its first row. Those rows sit below the analyser's resolution (consecutive
rows repeat one FFT bin's value), so the readers do not fit them (:mod:`bayes_emt.io.resolution`),
but they keep one row per bin in ``meta["low_band"]``. A full-band model fit otherwise extrapolates
R0 from 10 Hz up, where the motional impedance already adds its own real part; on the real
woofers the two differ by 3-6 %, and every quantity proportional to Re (Qes, Qts) moves with it.

The reading, from a fit of the recording (``model``, ``theta``):

* rows used: those at or below ``fs / PLATEAU_FS_RATIO`` (the model's fs), at least one;
* per row the model's motional part is taken off: ``R_i = Re Z_meas(f_i) − (Re Z_model(f_i) − R0)``
  (phase known), or ``sqrt(|Z_meas(f_i)|² − X_model(f_i)²) − (Re Z_model(f_i) − R0)`` for a
  magnitude-only file (``X_model`` the model's reactance there);
* value: the median of the ``R_i``; standard deviation: the median's standard error from the rows'
  scatter (``1.2533 s/√n``; at least the written resolution of |Z|) combined with half the
  largest motional correction taken off, a type-B allowance for the model's part in it (JCGM
  100:2008, 4.3).

Beside it, ``raw``: the same rows read as a bench reads them, the median of |Z| with nothing taken
off (a bench's literal reading: DATS's ``R(e)`` lies within 1.3 % of it on three DATS exports),
with the median's standard error alone. The two differ by the
driver's own impedance above Re there (creep and coil losses keep a woofer's real part rising
towards DC); a bench that reports the raw reading is another method for Re
(:mod:`bayes_emt.thiele_small.definitional`).

:func:`plateau_reading` returns the reading as a :class:`~bayes_emt.estimation.meter.Meter` with
the rows it used, or ``None`` when the recording has no such rows below ``fs / PLATEAU_FS_RATIO``.
``ts`` does not hold R0 at it (on the real woofers a model held there misfits the band above): it
is Re for Small's model-free column and the second method for Re's definitional uncertainty
(:mod:`bayes_emt.thiele_small.definitional`); the robust shunt widens its R0 draws by the same
spread (:mod:`bayes_emt.shunt.r0_spread`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..estimation.meter import Meter

__all__ = ["PLATEAU_FS_RATIO", "PlateauReading", "plateau_reading"]

#: rows at or below fs / 8: there a driver's motional impedance is under ~2 % of Re for Qms ≥ 1
#: (|Z_mot| ≈ Re·Qms/Qes·(f/fs)/Qms) and its real part far smaller still
PLATEAU_FS_RATIO = 8.0


@dataclass(frozen=True)
class PlateauReading:
    """The plateau's Re reading: ``meter`` (value ± sd [Ω], mode cut), the rows used (``f_hz``,
    ``r_ohm`` after the motional correction), the largest correction taken off [Ω], the R0 [Ω]
    of the full-band fit (model ``fit_model``) the correction came from, and ``raw`` the same rows'
    median |Z| with nothing taken off (the bench's literal reading; module docstring)."""

    meter: Meter
    f_hz: tuple[float, ...]
    r_ohm: tuple[float, ...]
    max_correction_ohm: float
    r0_fit_ohm: float
    fit_model: str = ""
    raw: Meter | None = None

    def to_json_dict(self) -> dict:
        raw = {} if self.raw is None else {"raw_abs_z_ohm": self.raw.value, "raw_sd_ohm": self.raw.sd}
        return {"ohm": self.meter.value, "sd_ohm": self.meter.sd, "mode": self.meter.mode, **raw,
                "rows_f_hz": list(self.f_hz), "rows_ohm": list(self.r_ohm),
                "max_motional_correction_ohm": self.max_correction_ohm, "r0_fit_ohm": self.r0_fit_ohm,
                "fit_model": self.fit_model,
                "how": f"median of Re(Z) at the recording's lowest rows (f <= fs/{PLATEAU_FS_RATIO:g}) less "
                       "the model's motional part there"}


def plateau_reading(meas, model, theta, fs_hz: float) -> PlateauReading | None:
    """The Re reading of ``meas``'s low-frequency plateau (module docstring), or ``None``."""
    low = meas.meta.get("low_band") if hasattr(meas, "meta") else None
    if not low or not low.get("f_hz") or not (math.isfinite(fs_hz) and fs_hz > 0):
        return None
    f = np.asarray(low["f_hz"], float)
    mag = np.asarray(low["abs_ohm"], float)
    use = f <= fs_hz / PLATEAU_FS_RATIO
    if not np.any(use):
        return None
    f, mag = f[use], mag[use]
    theta = np.asarray(theta, float).ravel()
    r0 = float(theta[model.names.index("R0")])
    with np.errstate(all="ignore"):
        z_model = 1.0 / model.admittance(2 * math.pi * f, theta[None, :])[0]
    corr = z_model.real - r0
    if low.get("phase_deg") is not None:
        meas_r = mag * np.cos(np.deg2rad(np.asarray(low["phase_deg"], float)[use]))
    else:
        meas_r = np.sqrt(np.maximum(mag**2 - z_model.imag**2, 0.0))
    r = meas_r - corr
    if not np.all(np.isfinite(r)) or np.median(r) <= 0:
        return None
    value = float(np.median(r))
    sd = math.hypot(_median_se(r, mag[0]), 0.5 * float(np.max(np.abs(corr))))
    raw_sd = _median_se(mag, mag[0])
    return PlateauReading(Meter(value, sd, "cut"), tuple(float(x) for x in f), tuple(float(x) for x in r),
                          float(np.max(np.abs(corr))), r0, model.label,
                          raw=Meter(float(np.median(mag)), raw_sd, "cut"))


def _median_se(x: np.ndarray, written: float) -> float:
    """The standard uncertainty of the median of the rows ``x`` [Ω]: its standard error
    ``1.2533 s/√n`` (``s`` the rows' sample sd; the median of a normal sample), at least the
    resolution of a |Z| written as ``written`` (:func:`_written_resolution`)."""
    se = 1.2533 * float(np.std(x, ddof=1)) / math.sqrt(x.size) if x.size > 1 else 0.0
    return max(se, _written_resolution(float(written)))


def _written_resolution(x: float) -> float:
    """The standard uncertainty of rounding ``x`` to 4 significant digits (a rectangular
    distribution one unit in the last digit wide: ``unit/√12``)."""
    unit = 10.0 ** (math.floor(math.log10(abs(x))) - 3)
    return unit / math.sqrt(12.0)


def plateau_note(p: PlateauReading) -> dict:
    """The ``re_from_plateau`` note: the reading and how far the full-band fit's R0 was from it."""
    m = p.meter
    diff = 100.0 * (p.r0_fit_ohm - m.value) / m.value
    band = f"{p.f_hz[0]:.3g}-{p.f_hz[-1]:.3g} Hz"
    return {"code": "re_from_plateau",
            "short": f"Re {m.value:.4g} ± {m.sd:.2g} ohm on the recording's lowest rows ({band}); "
                     f"a full-band {p.fit_model} fit puts R0 {diff:+.1f} % off it",
            "message": f"Re {m.value:.4g} ± {m.sd:.2g} ohm is read off the recording's low-frequency plateau "
                       f"({len(p.f_hz)} rows, {band}, below fs/{PLATEAU_FS_RATIO:g}, the model's motional "
                       f"part there taken off: at most {p.max_correction_ohm:.2g} ohm), as the bench reads "
                       "its own Re; Small's model-free column uses it. A full-band fit of "
                       f"{p.fit_model} puts R0 at "
                       f"{p.r0_fit_ohm:.4g} ohm ({diff:+.1f} %): the real part a driver adds between the "
                       "plateau and fs (suspension and coil losses) goes to R0. Re's interval spans both "
                       "(definitional uncertainty); an ohmmeter reading (re=, --re) holds R0 instead"}
