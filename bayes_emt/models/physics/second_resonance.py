"""A second mechanical mode in series: rocking, cone break-up or a fixture mode."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from .. import terms as T
from ..term import Term, col
from ._starts import peaks, smooth

__all__ = ["SecondResonance"]


@dataclass(frozen=True)
class SecondResonance(Term):
    """``Z ← Z + φ2² s/(s² + 2 ζ2 ω2 s + ω2²)``: another mechanical mode (rocking, cone, fixture)."""

    id = "second_resonance"
    augmentation = True
    band = "anywhere"
    generic = True
    narrow_when = ("zeta2", 0.05)
    physics = "second_resonance"
    description = "another mechanical mode in series (rocking, cone break-up or fixture mode)"
    signature = "a narrow peak and phase swing of width about 2 zeta2 omega2 at omega2"
    parameters = (
        ParamSpec("zeta2", "1", r"$\zeta_2$", LogUniform(1e-4, 2.0),
                  "damping ratio of a second mechanical mode"),
        ParamSpec("omega2", "rad/s", r"$\omega_2$", LogUniform(1e-1, 1e6),
                  "natural angular frequency of a second mode"),
        ParamSpec("phi2", "N/(A kg^0.5)", r"$\bar\varphi_2$", LogUniform(1e-3, 1e4),
                  "mass-normalised coupling of a second mode"),
    )

    def evaluate(self, s, v, other):
        z, w, p = col(v, 0), col(v, 1), col(v, 2)
        return p * p * s / (s * s + 2.0 * z * w * s + w * w)

    def jw_rational(self, v):
        return T.motional_polynomials(v[:, 0], v[:, 1], v[:, 2])  # the same form as eq. 47's branch

    def start(self, ctx):
        sz, sw, sp = (self.params[n] for n in ("zeta2", "omega2", "phi2"))
        m = ctx.in_band()
        w = ctx.omega[m]
        dz = smooth((ctx.Z - ctx.Z_base).real[m])
        out = []
        for i in peaks(dz, 3, prominence=0.0):
            h = dz[i]
            if h <= 0:
                continue
            half = dz > 0.5 * h
            lo = i
            while lo > 0 and half[lo - 1]:
                lo -= 1
            hi = i
            while hi < dz.size - 1 and half[hi + 1]:
                hi += 1
            zeta = max((w[hi] - w[lo]) / (2.0 * w[i]), 2e-3)
            out.append({"zeta2": sz.clip_inside(zeta), "omega2": sw.clip_inside(w[i]),
                        "phi2": sp.clip_inside(np.sqrt(h * 2 * zeta * w[i]))})
        # and a coarse grid over the band: a weak mode anywhere
        zref = float(np.median(np.abs(ctx.Z[m])))
        for wg in np.geomspace(w[0], w[-1], 8)[1:-1]:
            zeta = 0.05
            out.append({"zeta2": zeta, "omega2": sw.clip_inside(wg),
                        "phi2": sp.clip_inside(np.sqrt(0.02 * zref * 2 * zeta * wg))})
        return out
