"""Winding capacitance: inter-turn and lead capacitance across the terminals."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from .. import terms as T
from ..term import Term, col
from ._starts import top

__all__ = ["WindingCapacitance"]


@dataclass(frozen=True)
class WindingCapacitance(Term):
    """``Y ← Y + s Cp``: inter-turn and lead capacitance across the terminals."""

    id = "winding_capacitance"
    stage = "parallel"
    augmentation = True
    band = "coil"
    physics = "winding_capacitance"
    description = "inter-turn and lead capacitance across the terminals"
    signature = ("|Z| falls and the phase turns negative at the top of the band; self-resonance at "
                 "1/sqrt(L Cp)")
    parameters = (ParamSpec("Cp", "F", r"$C_p$", LogUniform(1e-13, 1e-5),
                            "winding and lead capacitance across the terminals"),)

    def evaluate(self, s, v, other):
        return s * col(v, 0)

    def jw_rational(self, v):
        return T.inductance_polynomials(v[:, 0])  # the admittance Cp s

    def start(self, ctx):
        cp = self.params["Cp"]
        band_top = top(ctx)
        dy = (ctx.Y - ctx.Y_base)[band_top]
        est = float(np.median(dy.imag / ctx.omega[band_top]))
        # the capacitive admittance at the top of the band as a fraction of |Y| there
        ref = float(np.median(np.abs(ctx.Y[band_top]) / ctx.omega[band_top]))
        out = [est] if est > 0 else []
        out += [f * ref for f in (0.03, 0.3)]
        return [{"Cp": cp.clip_inside(c)} for c in out]
