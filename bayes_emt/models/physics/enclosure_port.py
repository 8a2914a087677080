"""A vented box or passive radiator (Thiele 1971): box compliance and port mass coupled to the driver's
motional branch."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from ..term import Term, col
from ._starts import peaks, smooth

__all__ = ["EnclosurePort"]


@dataclass(frozen=True)
class EnclosurePort(Term):
    """``1/Z_mot ← 1/Z_mot + (s/Lb)/(s² + 2 ζb ωb s + ωb²)``: a vented box or passive radiator."""

    id = "enclosure_port"
    stage = "motional_parallel"
    augmentation = True
    band = "mechanical"
    requires_setup = ("vented", "unknown")
    unknown_setup_needs = "two_impedance_maxima"
    moves_resonance = True
    physics = "enclosure_port"
    description = ("vented box or passive radiator: box compliance and port mass coupled to the driver's "
                   "motional branch")
    signature = "two impedance peaks with a minimum near the port tuning omegab between them"
    parameters = (
        ParamSpec("Lb", "H", r"$L_b$", LogUniform(1e-9, 1e3),
                  "box/port branch inductance (box stiffness seen through the motional branch)"),
        ParamSpec("omegab", "rad/s", r"$\omega_b$", LogUniform(1e-1, 1e6),
                  "port (Helmholtz) tuning angular frequency"),
        ParamSpec("zetab", "1", r"$\zeta_b$", LogUniform(1e-4, 2.0),
                  "damping ratio of the port/box resonance"),
    )

    def evaluate(self, s, v, other):
        L, w, z = col(v, 0), col(v, 1), col(v, 2)
        return (s / L) / (s * s + 2.0 * z * w * s + w * w)

    #: port tuning over the driver's resonance a vented box or passive radiator realises
    TUNING_RANGE = (0.3, 3.0)

    def implausible(self, values):
        ratio = values["omegab"] / values["omega0"]
        lo, hi = self.TUNING_RANGE
        if not lo <= ratio <= hi:
            return (f"port tuning omegab = {values['omegab']:.4g} rad/s is {ratio:.3g} x the driver's "
                    f"resonance (a box realises {lo:g}-{hi:g} x): another mode, not a port")
        return None

    def start(self, ctx):
        sL, sw, sz = (self.params[n] for n in ("Lb", "omegab", "zetab"))
        zeta0, w0, phi = ctx.base["zeta"], ctx.base["omega0"], ctx.base["phi"]
        logz = smooth(np.log(np.abs(ctx.Z)))
        pk = np.sort(peaks(logz, 2, prominence=0.02))
        plans = []
        if pk.size == 2:
            # a vented box: two peaks f_L, f_H with the port tuning at the minimum between them;
            # the driver's own resonance obeys f_L f_H = f_s f_b (Thiele)
            i = pk[0] + int(np.argmin(logz[pk[0] : pk[1] + 1]))
            wb = ctx.omega[i]
            ws = ctx.omega[pk[0]] * ctx.omega[pk[1]] / wb
            plans.append((wb, ws))
        for f in (0.6, 0.8, 1.25):
            plans.append((f * w0, w0))
        out = []
        for wb, ws in plans:
            L_mot = phi * phi / (ws * ws)  # the motional branch's inductance (per-mass units)
            for ratio in (1.0, 3.0):  # box stiffness over suspension stiffness
                out.append({"Lb": sL.clip_inside(L_mot / ratio), "omegab": sw.clip_inside(wb),
                            "zetab": sz.clip_inside(0.1), "omega0": float(ws), "zeta": float(zeta0)})
        return out
