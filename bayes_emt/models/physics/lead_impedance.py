"""Lead and fixture impedance: cables and fixture in series with the transducer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from ..term import FosterPart, Term, col
from ._starts import top

__all__ = ["LeadImpedance"]


@dataclass(frozen=True)
class LeadImpedance(Term):
    """``Z ← Z + Rl + s Ll``: cables and fixture in series."""

    id = "lead_impedance"
    augmentation = True
    band = "coil"
    physics = "lead_impedance"
    description = "cables and fixture in series with the transducer"
    signature = "a series resistance (indistinguishable from R0) and a small inductance at the top"
    identifiability = "Rl is not identifiable against R0: the data determine only R0 + Rl"
    parameters = (
        ParamSpec("Rl", "ohm", r"$R_l$", LogUniform(1e-5, 1e2), "lead and fixture resistance in series"),
        ParamSpec("Ll", "H", r"$L_l$", LogUniform(1e-10, 1e-2), "lead and fixture inductance in series"),
    )

    def evaluate(self, s, v, other):
        return col(v, 0) + col(v, 1) * s

    def jw_rational(self, v):
        return np.stack([v[:, 0], v[:, 1]], axis=-1), np.ones((v.shape[0], 1))

    def foster(self, v, sections):
        return FosterPart(R=float(v[0]), G=float(v[1]))

    def start(self, ctx):
        sR, sL = self.params["Rl"], self.params["Ll"]
        band_top = top(ctx)
        ll = float(np.median((ctx.Z - ctx.Z_base).imag[band_top] / ctx.omega[band_top]))
        Rl = 0.01 * ctx.base["R0"]
        return [{"Rl": sR.clip_inside(Rl), "Ll": sL.clip_inside(L)}
                for L in ([ll] if ll > 0 else []) + [1e-7, 1e-5]]
