"""The LR-2 coil (Klippel): a second inductance shunted by a resistance, in series."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from .. import terms as T
from ..term import FosterPart, Term, col

__all__ = ["LR2"]


@dataclass(frozen=True)
class LR2(Term):
    """LR-2 coil (Klippel): ``Zc = s Le + R2 s L2/(R2 + s L2)``, with ``Le`` the base coil's own
    inductance; this term adds the ``R2 ‖ L2`` section (parameters ``L_lr2``, ``R_lr2``: ring
    resistances of NL are already called ``R1..Rn``)."""

    id = "lr2"
    augmentation = True
    band = "coil"
    generic = True
    coil = True
    physics = "lr2"
    description = "LR-2 coil: a second inductance L2 shunted by R2 in series with the coil"
    signature = "same band as eddy currents: excess real part and phase deficit rising with frequency"
    parameters = (
        ParamSpec("L_lr2", "H", r"$L_2$", LogUniform(1e-8, 1e1), "LR-2 coil: second inductance"),
        ParamSpec("R_lr2", "ohm", r"$R_2$", LogUniform(1e-3, 1e5), "LR-2 coil: resistance shunting L_lr2"),
    )

    def evaluate(self, s, v, other):
        L, R = col(v, 0), col(v, 1)
        return R * L * s / (R + L * s)

    def jw_rational(self, v):
        return T.lossy_inductance_polynomials(v[:, 0], v[:, 1])  # model II's form

    def foster(self, v, sections):
        return FosterPart(L=np.array([v[0]]), tau=np.array([v[0] / v[1]]))

    def start(self, ctx):
        sL, sR = self.params["L_lr2"], self.params["R_lr2"]
        m = ctx.in_band()
        w = ctx.omega[m]
        dz = (ctx.Z - ctx.Z_base)[m]
        s = 1j * w
        out = []
        for tau in np.geomspace(0.3 / w[-1], 3.0 / w[0], 7):
            e = s / (1 + tau * s)
            c = float(np.real(np.vdot(e, dz)) / np.real(np.vdot(e, e)))
            if c > 0:
                out.append((c, float(np.sum(np.abs(dz - c * e) ** 2)), tau))
        out.sort(key=lambda x: x[1])
        zref = float(np.median(np.abs(ctx.Z[m])))
        cands = [(c, c / tau) for c, _, tau in out[:3]] or [(0.1 * zref / w[-1], 0.1 * zref)]
        return [{"L_lr2": sL.clip_inside(L), "R_lr2": sR.clip_inside(R)} for L, R in cands]
