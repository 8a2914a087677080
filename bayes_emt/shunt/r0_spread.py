"""R0 as honest as the T/S interval of Re: the posterior's R0 draws widened by the spread between the
fit's R0 and the recording's low-frequency plateau.

A negative-resistance shunt stays stable only while the real coil resistance is not much below the
R0 it was designed for (:mod:`bayes_emt.shunt.safety`). The posterior's R0 says how well R0 is known
*if the model were the driver*; on real woofers a full-band fit's R0 and the bench's own reading of
Re off its lowest rows differ by 3-12 %, far beyond that posterior (the T/S documentation's truth
corpus). The shunt therefore uses the same honest interval as ``ts``'s Re
(:mod:`bayes_emt.thiele_small.definitional`): when the recording carries rows below the analyser's
resolution (``meta["low_band"]``, kept by the bench readers), each model's R0 draws are multiplied by
``exp(τ/R0·ε)``, ``ε ~ N(0, 1)`` (seeded), with τ the between-method standard deviation
(:mod:`bayes_emt.estimation.dark_uncertainty`) of the draws' median R0 and the plateau reading
(:mod:`bayes_emt.estimation.plateau`, from the draws' median parameters), each with its own
standard uncertainty. τ = 0 (nothing widened) where the two agree within those; a recording without
such rows has no second method and keeps the posterior's R0 (the result says so). Every draw's
design, the robust choice's stability constraint and the stability-margin check then see that R0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..estimation.dark_uncertainty import between_method_sd, widen
from ..estimation.plateau import plateau_reading
from .draws import DrawGroup

__all__ = ["R0Spread", "r0_spread", "widen_r0"]


@dataclass(frozen=True)
class R0Spread:
    """One model's R0 against the plateau reading [Ω]: the draws' median ``r0_ohm`` and standard
    deviation ``r0_sd_ohm``, the reading ``plateau_ohm`` ± ``plateau_sd_ohm`` on rows ``band_hz``,
    and the between-method standard deviation ``tau_ohm`` (0: they agree)."""

    model: str
    r0_ohm: float
    r0_sd_ohm: float
    plateau_ohm: float
    plateau_sd_ohm: float
    tau_ohm: float
    band_hz: tuple[float, float]

    def to_json_dict(self) -> dict:
        return {"model": self.model, "r0_ohm": self.r0_ohm, "r0_sd_ohm": self.r0_sd_ohm,
                "plateau_ohm": self.plateau_ohm, "plateau_sd_ohm": self.plateau_sd_ohm,
                "tau_ohm": self.tau_ohm, "band_hz": list(self.band_hz)}

    def line(self) -> str:
        """One line for the output."""
        diff = 100.0 * (self.plateau_ohm - self.r0_ohm) / self.r0_ohm
        lo, hi = self.band_hz
        if self.tau_ohm > 0:
            return (f"R0 draws of {self.model} widened by the spread to the low-frequency plateau: fit R0 "
                    f"{self.r0_ohm:.4g} ohm, plateau {self.plateau_ohm:.4g} ohm at {lo:.3g}-{hi:.3g} Hz "
                    f"({diff:+.1f} %), tau {self.tau_ohm:.3g} ohm")
        return (f"R0 of {self.model} agrees with the low-frequency plateau ({self.plateau_ohm:.4g} ohm at "
                f"{lo:.3g}-{hi:.3g} Hz, {diff:+.1f} %) within their uncertainties: not widened")


def r0_spread(model, thetas, meas) -> R0Spread | None:
    """The R0 spread of one model's draws ``thetas`` ``(n, k)`` [SI] on the recording ``meas``
    (module docstring); ``None`` when the model has no R0 or the recording no plateau rows."""
    if "R0" not in model.params.names or meas is None:
        return None
    thetas = np.atleast_2d(np.asarray(thetas, float))
    if thetas.shape[0] == 0:
        return None
    i = model.params.index("R0")
    med = np.median(thetas, axis=0)
    with np.errstate(all="ignore"):
        w0 = float(np.asarray(model.mechanics(med[None, :])[1], float).ravel()[0])
    if not (math.isfinite(w0) and w0 > 0):
        return None
    reading = plateau_reading(meas, model, med, w0 / (2 * math.pi))
    if reading is None:
        return None
    r0 = thetas[:, i]
    sd = float(np.std(r0, ddof=1)) if r0.size > 1 else 0.0
    tau = between_method_sd(float(med[i]), reading.meter.value, sd, reading.meter.sd)
    return R0Spread(model.label, float(med[i]), sd, float(reading.meter.value), float(reading.meter.sd),
                    float(tau), (float(reading.f_hz[0]), float(reading.f_hz[-1])))


def widen_r0(groups, measurements, seed: int) -> tuple[list[DrawGroup], list[R0Spread]]:
    """``groups`` with each one's R0 draws (and spare draws) widened by its :func:`r0_spread` on the
    matching recording in ``measurements`` (one per group, ``None`` for none); the spreads found."""
    rng = np.random.default_rng([int(seed), 2028])
    out, spreads = [], []
    for g, meas in zip(groups, measurements, strict=True):
        s = r0_spread(g.model, g.thetas, meas)
        if s is None:
            out.append(g)
            continue
        spreads.append(s)
        if not s.tau_ohm > 0:
            out.append(g)
            continue
        i = g.model.params.index("R0")
        th = np.array(g.thetas, float)
        th[:, i] = widen(th[:, i], s.r0_ohm, s.tau_ohm, rng)
        spare = None
        if g.spare is not None:
            spare = np.array(g.spare, float)
            spare[:, i] = widen(spare[:, i], s.r0_ohm, s.tau_ohm, rng)
        out.append(replace(g, thetas=th, spare=spare))
    return out, spreads
