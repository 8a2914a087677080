"""Semi-inductance (Leach 1999): the loudspeaker world's lossy coil inductance ``K s^n``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec, Uniform
from ..term import Term, col
from ._starts import top

__all__ = ["SemiInductance"]


@dataclass(frozen=True)
class SemiInductance(Term):
    """``Z ← Z + K s^n`` (Leach 1999): the loudspeaker world's lossy inductance."""

    id = "semi_inductance"
    augmentation = True
    band = "coil"
    coil = True
    physics = "semi_inductance"
    description = "lossy coil inductance K s^n (Leach 1999), 0 < n < 1"
    signature = "|Z| rising as omega^n with a phase near n·90° at high frequency"
    parameters = (
        ParamSpec("K_semi", "ohm s^n", r"$K$", LogUniform(1e-10, 1e4), "semi-inductance scale (Leach 1999)"),
        ParamSpec("n_semi", "1", r"$n$", Uniform(0.0, 1.0),
                  "semi-inductance exponent (0: resistor, 1: inductor)"),
    )

    #: the largest share of ``R0`` the term's resistance ``Re K (jω0)^n`` may have at the driver's
    #: resonance ω0: eddy-current loss grows from nothing at DC (Vanderkooy 1989: ``Z ∝ √(jω)`` in
    #: the pole's skin-effect limit, Leach 2002's ``n`` between that and an inductor's 1), so at the
    #: mechanical resonance it is a few per cent of the DC resistance (the benchmark's and the tests'
    #: simulated coils 1.5-6 %, the truth-study woofer's fitted one 2.9 %); a "semi-inductance" with
    #: ``n`` near 0 is a resistor doing R0's job
    MAX_R0_SHARE_AT_RESONANCE = 0.1

    def implausible(self, values):
        w0, r0 = values.get("omega0"), values.get("R0")
        if not w0 or not r0 or r0 <= 0:
            return None
        k, n = values["K_semi"], values["n_semi"]
        r = k * w0**n * math.cos(n * math.pi / 2)
        if r > self.MAX_R0_SHARE_AT_RESONANCE * r0:
            return (f"its resistance at the resonance, Re K (j omega0)^n = {r:.3g} ohm (n = {n:.3g}), is "
                    f"{100 * r / r0:.0f} % of R0 = {r0:.4g} ohm: coil loss vanishes towards DC, so this is a "
                    "resistor taking over R0, not a lossy inductance")
        return None

    def evaluate(self, s, v, other):
        return col(v, 0) * np.exp(col(v, 1) * np.log(s))

    def start(self, ctx):
        sK, sn = self.params["K_semi"], self.params["n_semi"]
        band_top = top(ctx, 0.3)
        dz = (ctx.Z - ctx.Z_base)[band_top]
        w = ctx.omega[band_top]
        out = []
        ph = np.angle(dz)
        good = (ph > 0) & (ph < np.pi / 2)
        if np.count_nonzero(good) >= 3:
            n = float(np.clip(np.median(ph[good]) / (np.pi / 2), 0.05, 0.95))
            out.append((n, float(np.median(np.abs(dz[good]) / w[good] ** n))))
        zref = float(np.median(np.abs(ctx.Z[band_top])))
        for n in (0.3, 0.5, 0.7):
            out.append((n, 0.1 * zref / float(np.median(w)) ** n))
        return [{"K_semi": sK.clip_inside(K), "n_semi": sn.clip_inside(n)} for n, K in out]
