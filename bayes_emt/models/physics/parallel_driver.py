"""A second driver of the same type wired in parallel with the first (two woofers on one amplifier
channel, a dual-driver enclosure, a test of a pair).

Two drivers in parallel draw the sum of their admittances, ``Y = Y_1 + Y_2``. Driver 1 is the model
itself (its coil, R0 and motional branch, eq. 47 and its augmentations); driver 2 is

    Y_2 = 1 / ( R0_2 + kcoil_2 Zc(s) + 1 / (Y_mot,2 + Y_box) ),
    Y_mot,2 = (s² + 2 ζ_2 ω_2 s + ω_2²) / (φ̄_2² s),

with ``Zc`` the model's own coil impedance (every coil term, scaled by ``kcoil_2``: a driver of the
same type has the same coil and pole, its size within the sample spread) and ``Y_box`` the admittance a
vented box or passive radiator adds to the motional branch (the model's ``enclosure_port`` term, when it
has one: both drivers load the same box and port; 0 otherwise). Driver 2 has its own DC resistance
``R0_2``, resonance ``ω_2``, damping ``ζ_2`` and mass-normalised coupling ``φ̄_2``; stiffness modifiers of
driver 1 (suspension creep) are not copied to it. Two drivers wired in series are the dual case
(impedances add) and are not this term.

One lumped driver has a single mechanical resonance: fitted to a pair, it leaves a broadband mismatch
or ends on broken physics (a resonance merged with a port's, a damping at its prior's edge), which is
when discrepancy discovery proposes this term (:attr:`~bayes_emt.models.term.Term.structural`). Two
identical drivers (``ω_2 = ω0``, ``ζ_2 = ζ``, ...) are one lumped driver of half the impedance: the data
cannot tell them apart, so the term is only identified by a pair whose resonances differ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec
from .. import terms as T
from ..catalogue import (
    BesselEddy,
    GapInductance,
    Inductance,
    LossyInductance,
    Motional,
    Resistance,
    RingLadder,
    UniformRings,
)
from ..term import Term, col, resolve_spec
from ._starts import peaks, smooth
from .enclosure_port import EnclosurePort
from .lead_impedance import LeadImpedance
from .lr2 import LR2
from .second_resonance import SecondResonance
from .semi_inductance import SemiInductance

__all__ = ["ParallelDriver"]

#: units of the parameters an impedance [Ω] scales with (a time constant [s] or an exponent [1] does
#: not; a box branch's Lb [H] does: its admittance is shared between the two drivers)
_IMPEDANCE_UNITS = ("H", "ohm", "H s^-0.5", "ohm s^n")
#: the unit of a mass-normalised coupling (a motional impedance scales with its square)
_COUPLING_UNIT = "N/(A kg^0.5)"
_SPECS = {p.name: p for c in (Resistance, Inductance, GapInductance, LossyInductance, BesselEddy,
                              UniformRings, Motional, SemiInductance, LR2, LeadImpedance, SecondResonance,
                              EnclosurePort)
          for p in c.parameters}
_RINGS = RingLadder.parameters


def _unit(name: str) -> str:
    """The unit of a base model's parameter ``name`` (``""`` for one the start does not scale)."""
    p = _SPECS.get(name) or resolve_spec(_RINGS, name)
    return "" if p is None else p.unit


@dataclass(frozen=True)
class ParallelDriver(Term):
    """``Y ← Y + 1/(R0_2 + kcoil_2 Zc + 1/(Y_mot,2 + Y_box))``: a second driver in parallel."""

    id = "parallel_driver"
    stage = "parallel"
    augmentation = True
    band = "mechanical"
    structural = True
    sees_driver = True
    moves_resonance = True
    needs = ("zeta",)
    physics = "parallel_driver"
    description = ("a second driver of the same type wired in parallel (its own R0, resonance, damping and "
                   "coupling; the same coil scaled, the same box)")
    signature = ("a second mechanical resonance a lumped driver cannot hold: a broadband mismatch, or a "
                 "lumped fit whose resonance merges with another mode")
    identifiability = ("two drivers with the same resonance are one lumped driver of half the impedance: "
                       "only a pair whose resonances differ is identified")
    parameters = (
        ParamSpec("R0_2", "ohm", r"$R_{0,2}$", LogUniform(1e-3, 1e4),
                  "DC resistance of the second driver's coil"),
        ParamSpec("omega0_2", "rad/s", r"$\omega_{0,2}$", LogUniform(1e-1, 1e6),
                  "resonance angular frequency of the second driver"),
        ParamSpec("phi_2", "N/(A kg^0.5)", r"$\bar\varphi_2'$", LogUniform(1e-3, 1e4),
                  "mass-normalised coupling of the second driver"),
        ParamSpec("kcoil_2", "1", r"$k_{c,2}$", LogUniform(0.1, 10.0),
                  "the second driver's coil impedance over the first's"),
    )

    def evaluate(self, s, v, other):
        r0, w0, phi, k = (col(v, i) for i in range(4))
        zeta = other["zeta"]
        y_mot = T.mechanical_polynomial(s, zeta, w0) / (phi * phi * s)
        box = other.get("y_mot_extra")
        if box is not None:
            y_mot = y_mot + box
        coil = other.get("coil")
        z = r0 + 1.0 / y_mot
        if coil is not None:
            z = z + k * coil
        return 1.0 / z

    def start(self, ctx):
        """Driver 1 and 2 from the lumped fit: two equal drivers in parallel are one of half the
        impedance, so each starts with twice the lumped R0, coil, φ̄² and box branch ``Lb``; the
        resonances split around the lumped one (ratios 1-1.5) or driver 2 at a peak of the lumped fit's
        real-part residual."""
        spec = {n: self.params[n] for n in self.names}
        b = ctx.base
        split = {}
        for n, x in b.items():
            unit = _unit(n)
            if unit in _IMPEDANCE_UNITS:
                split[n] = 2.0 * x
            elif unit == _COUPLING_UNIT:
                split[n] = math.sqrt(2.0) * x
        w0, zeta = b["omega0"], max(b["zeta"], 0.02)
        split["zeta"] = zeta
        pairs = [(w0 / math.sqrt(r), w0 * math.sqrt(r)) for r in (1.1, 1.25, 1.5)] + [(w0, w0)]
        m = (ctx.omega > w0 / 3.0) & (ctx.omega < 3.0 * w0)
        if np.count_nonzero(m) > 5:
            dz = smooth((ctx.Z - ctx.Z_base).real[m])
            pairs += [(w0, float(ctx.omega[m][i])) for i in peaks(np.abs(dz), 2)]
        out = []
        for w1, w2 in pairs:
            out.append({**split, "omega0": w1, "R0_2": spec["R0_2"].clip_inside(2.0 * b["R0"]),
                        "omega0_2": spec["omega0_2"].clip_inside(w2),
                        "phi_2": spec["phi_2"].clip_inside(math.sqrt(2.0) * b["phi"]), "kcoil_2": 1.0})
        return out
