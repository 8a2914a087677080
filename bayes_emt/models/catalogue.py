"""The paper's terms: the motional branch, the coil resistance and the coil models (docs: Physics).

Each coil term carries its parameters with their priors, its own start
(:class:`~bayes_emt.models.term.CoilStart`: the columns and the one nonlinear parameter the linear
coil stage of the initial estimate scans), its Foster form and its serialised id; the augmentations
of the catalogue live one per module in :mod:`bayes_emt.models.physics`. The six base models are made of
these terms (:data:`~bayes_emt.models.registry.BASE_MODELS`), several sharing a parameter (``L0``,
``Lg``, ``alpha``, ``beta``): each such spec is declared once here.

Priors are proper, log-uniform over wide decade ranges that bracket every transducer from a 1 cm
tweeter to the paper's 2 kg shaker, and identical for a name whatever the model, so that evidences
of different models are comparable (shared parameters' prior volumes cancel in a Bayes factor).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import special

from ..params import LogUniform, ParamSet, ParamSpec
from . import terms as T
from .linearise import lossy_inductance_linear, rational_alpha
from .term import CoilStart, FosterPart, Term, col, indexed

__all__ = ["Motional", "Resistance", "Inductance", "GapInductance", "LossyInductance", "BesselEddy",
           "RingLadder", "UniformRings", "bessel_sections"]

ZETA = ParamSpec("zeta", "1", r"$\zeta$", LogUniform(1e-5, 2.0), "mechanical damping ratio")
OMEGA0 = ParamSpec("omega0", "rad/s", r"$\omega_0$", LogUniform(1e-1, 1e6),
                   "mechanical natural angular frequency")
PHI = ParamSpec("phi", "N/(A kg^0.5)", r"$\bar\varphi$", LogUniform(1e-3, 1e4),
                "mass-normalised electromechanical coupling phi/sqrt(m)")
R0 = ParamSpec("R0", "ohm", r"$R_0$", LogUniform(1e-3, 1e4), "coil DC resistance")
L0 = ParamSpec("L0", "H", r"$L_0$", LogUniform(1e-8, 1e1), "coil self-inductance")
RMU = ParamSpec("Rmu", "ohm", r"$R_\mu$", LogUniform(1e-3, 1e5), "lumped eddy-current loss resistance")
ALPHA = ParamSpec("alpha", "s", r"$\alpha$", LogUniform(1e-10, 1e2), "eddy-current diffusion time constant")
BETA = ParamSpec("beta", "H s^-0.5", r"$\beta$", LogUniform(1e-6, 1e4), "semi-inductance scale")
LG = ParamSpec("Lg", "H", r"$L_g$", LogUniform(1e-9, 1e1), "air-gap inductance")
PG = ParamSpec("Pg", "H", r"$P_g$", LogUniform(1e-16, 1e-2), "air-gap permeance (per turn squared)")
#: ring j = 1..n of NL's core (indexed specs: ``P3``, ``R3``; ``R0`` is the coil, not a ring)
P_RING = ParamSpec("P{j}", "H", r"$P_{j}$", LogUniform(1e-16, 1e-2), "permeance of core ring {j}")
R_RING = ParamSpec("R{j}", "ohm", r"$R_{j}$", LogUniform(1e-12, 1e2),
                   "eddy-current resistance of core ring {j}")

_EDDY = "eddy currents in the pole and core (excess real part and phase deficit rising with frequency)"


def _s(s):
    return s


@dataclass(frozen=True)
class Motional(Term):
    """The primary mechanical branch (eq. 47): ``Z_mot = φ̄² s/(s² + 2ζω0 s + ω0²)``."""

    id = "motional"
    stage = "motional"
    physics = "mechanics"
    description = "moving mass on a spring with viscous damping, coupled by phi (eq. 47)"
    signature = "the impedance peak and its phase swing at the mechanical resonance"

    parameters = (ZETA, OMEGA0, PHI)

    def evaluate(self, s, v, other):
        """The motional *impedance* [Ω] (the model turns it into an admittance when modifiers act)."""
        return T.motional_impedance(s, col(v, 0), col(v, 1), col(v, 2))

    def jw_rational(self, v):
        return T.motional_polynomials(v[:, 0], v[:, 1], v[:, 2])


@dataclass(frozen=True)
class Resistance(Term):
    """The coil's DC resistance ``R0`` [Ω]."""

    id = "resistance"
    description = "coil DC resistance R0"
    signature = "the real part of Z at low frequency, away from the resonance"

    parameters = (R0,)

    def evaluate(self, s, v, other):
        return col(v, 0) + 0 * s

    def jw_rational(self, v):
        return T.resistance_polynomials(v[:, 0])

    def foster(self, v, sections):
        return FosterPart(R=float(v[0]))


@dataclass(frozen=True)
class Inductance(Term):
    """Model I: ``L0 s`` [Ω]."""

    id = "inductance"
    coil = True
    physics = "eddy_current"
    description = "coil self-inductance L0 s (model I)"
    signature = "|Z| rising in proportion to frequency, phase toward +90°"
    #: the one parameter, and its start when the linear coil stage gives it 0 (a multiple of the
    #: plant's low-frequency inductance)
    parameters = (L0,)
    fallback_factor: ClassVar[float] = 1.0

    def evaluate(self, s, v, other):
        return T.inductance(s, col(v, 0))

    def jw_rational(self, v):
        return T.inductance_polynomials(v[:, 0])

    def foster(self, v, sections):
        return FosterPart(G=float(v[0]))

    def coil_start(self):
        k, name = self.fallback_factor, self.parameters[0].name
        return CoilStart(linear={name: _s}, fallback={name: lambda L_lf: k * L_lf})


@dataclass(frozen=True)
class GapInductance(Inductance):
    """The air-gap inductance ``Lg s`` [Ω] of model UD."""

    id = "gap_inductance"
    description = "air-gap inductance Lg s"
    signature = "an inductive part of Z that eddy currents do not damp"
    parameters = (LG,)
    fallback_factor = 1e-3


@dataclass(frozen=True)
class LossyInductance(Term):
    """Model II: ``Rμ L0 s/(Rμ + L0 s)`` [Ω]."""

    id = "lossy_inductance"
    coil = True
    physics = "eddy_current"
    description = "inductance with lumped eddy loss Rmu || L0 s (model II)"
    signature = _EDDY

    parameters = (L0, RMU)

    def evaluate(self, s, v, other):
        return T.lossy_inductance(s, col(v, 0), col(v, 1))

    def jw_rational(self, v):
        return T.lossy_inductance_polynomials(v[:, 0], v[:, 1])

    def foster(self, v, sections):
        return FosterPart(L=np.array([v[0]]), tau=np.array([v[0] / v[1]]))

    def coil_start(self):
        # the scan runs over tau = L0/Rmu; the paper's own linearisation of 1/Zc competes
        return CoilStart(
            scan="tau", scan_range=(1e-12, 1e6),
            basis=lambda s, p: s[None, :] / (1.0 + p[:, None] * s[None, :]),
            to_params=lambda p, c: {"L0": c, "Rmu": c / p},
            direct=lambda s, Ze, w, R0, L_lf: [("linear 1/L0, 1/Rmu",
                                                lossy_inductance_linear(s, Ze, w, R0, L_lf))])


def _alpha_seeds(s, Ze, w, has_inductance):
    a = rational_alpha(s, Ze, w, has_inductance)
    return [] if a is None else [("rational Bessel alpha", a)]


def bessel_sections(alpha: float, beta: float, sections: int):
    """The first ``sections`` eddy-current modes of ``Z_III`` (Mittag-Leffler expansion of
    ``I1/I0``), the rest lumped as an inductance, and the error coefficient ``E`` [Ω s²]:
    ``L_k = 2β sqrt(α)/j_k²``, ``τ_k = α/j_k²`` (``j_k`` the zeros of ``J0``); the tail's inductance
    ``β sqrt(α)/2 − Σ L_k`` keeps the low-frequency limit exact (``Σ 1/j_k² = 1/4``), and
    ``E = 2 β α^{3/2} (1/32 − Σ_{k ≤ K} j_k⁻⁴)`` (Rayleigh's sum ``Σ j_k⁻⁴ = 1/32``)."""
    if int(sections) != sections or sections < 1:
        raise ValueError(f"sections must be a positive integer, got {sections!r}")
    j = special.jn_zeros(0, int(sections))
    L = 2.0 * beta * np.sqrt(alpha) / j**2
    tau = alpha / j**2
    tail_L = max(beta * np.sqrt(alpha) * (0.25 - np.sum(1.0 / j**2)) * 2.0, 0.0)
    E = 2.0 * beta * alpha**1.5 * max(1.0 / 32.0 - float(np.sum(j**-4.0)), 0.0)
    return L, tau, tail_L, E


@dataclass(frozen=True)
class BesselEddy(Term):
    """Model III: ``β sqrt(s) I1(sqrt(α s))/I0(sqrt(α s))`` [Ω] (eddy currents in a uniform core)."""

    id = "bessel_eddy"
    coil = True
    physics = "eddy_current"
    description = "eddy currents distributed in a uniform cylindrical core (model III)"
    signature = _EDDY + "; semi-inductor above 1/alpha (|Z| ∝ sqrt(ω), 45°)"

    parameters = (ALPHA, BETA)

    def evaluate(self, s, v, other):
        return T.bessel_eddy(s, col(v, 0), col(v, 1))

    def jw_bessel(self, v):
        return v[:, 0], v[:, 1]

    def foster(self, v, sections):
        L, tau, tail, E = bessel_sections(float(v[0]), float(v[1]), sections)
        return FosterPart(G=tail, L=L, tau=tau, error_coeff=E,
                          note=f"{int(sections)} eddy-current modes (Mittag-Leffler) + lumped tail")

    def coil_start(self):
        prior = self.params["alpha"].prior
        return CoilStart(scan="alpha", scan_range=(prior.lower, prior.upper),
                         basis=lambda s, p: T.bessel_eddy(s[None, :], p[:, None], 1.0),
                         to_params=lambda p, c: {"alpha": p, "beta": c}, seeds=_alpha_seeds)


def _check_rings(n_rings) -> int:
    if isinstance(n_rings, bool) or int(n_rings) != n_rings or n_rings < 1:
        raise ValueError(f"rings must be a positive integer, got {n_rings!r}")
    return int(n_rings)


def _check_turns(n_turns) -> float:
    if not (np.isfinite(n_turns) and n_turns > 0):
        raise ValueError(f"n_turns must be positive, got {n_turns!r}")
    return float(n_turns)


@dataclass(frozen=True)
class _Rings(Term):
    """What the two ring models share: a coil term with ``n_rings`` rings of ``n_turns`` turns."""

    n_rings: int = 5
    n_turns: float = 480.0
    coil = True
    physics = "eddy_current"
    signature = _EDDY

    def __post_init__(self):
        object.__setattr__(self, "n_rings", _check_rings(self.n_rings))
        object.__setattr__(self, "n_turns", _check_turns(self.n_turns))


@dataclass(frozen=True)
class RingLadder(_Rings):
    """Model NL: the coil coupled to ``n_rings`` resistive rings of a non-uniform core (eq. 41)."""

    id = "ring_ladder"
    description = "non-uniform core cut into n rings, eddy current lumped per ring (eq. 41)"

    parameters = (PG, P_RING, R_RING)

    @classmethod
    def default_params(cls, n_rings: int = 5, n_turns: float = 480.0):
        n = _check_rings(n_rings)
        return ParamSet([PG, *[indexed(P_RING, j) for j in range(1, n + 1)],
                         *[indexed(R_RING, j) for j in range(1, n + 1)]])

    def evaluate(self, s, v, other):
        n = self.n_rings
        return T.ring_ladder(s, v[:, 0], v[:, 1 : n + 1], v[:, n + 1 :], self.n_turns)

    def jw_rational(self, v):
        """The ladder's continued fraction as a polynomial pair (``terms.ladder_polynomials``)."""
        n = self.n_rings
        return T.ladder_polynomials(v[:, 0], v[:, 1 : n + 1], v[:, n + 1 :], self.n_turns)

    def foster(self, v, sections):
        n = self.n_rings
        gap, Lk, tau = T.ring_ladder_modes(np.asarray(v[0]), v[1 : n + 1], v[n + 1 :], self.n_turns)
        return FosterPart(G=float(gap), L=Lk, tau=tau)

    def surrogate(self):
        """Uniform rings (UL): three coil parameters put the 2n+1 ring parameters close."""
        n, N = self.n_rings, self.n_turns

        def convert(p):
            Pg, P, R = T.uniform_rings(p["Lg"], p["alpha"], p["beta"], n, N)
            out = {"Pg": float(Pg)}
            out.update({f"P{j + 1}": float(P[j]) for j in range(n)})
            out.update({f"R{j + 1}": float(R[j]) for j in range(n)})
            return out

        return UniformRings.make(n_rings=n, n_turns=N), convert


@dataclass(frozen=True)
class UniformRings(_Rings):
    """Model UL: a uniform core with an air gap, eddy currents lumped in equal-area rings."""

    id = "uniform_rings"
    description = "uniform core, air gap, eddy currents lumped in n equal-area rings (UL)"

    parameters = (LG, ALPHA, BETA)

    @classmethod
    def default_params(cls, n_rings: int = 5, n_turns: float = 480.0):
        _check_rings(n_rings)
        return ParamSet(cls.parameters)

    def _rings(self, v):
        return T.uniform_rings(v[:, 0], v[:, 1], v[:, 2], self.n_rings, self.n_turns)

    def evaluate(self, s, v, other):
        Pg, P, R = self._rings(v)
        return T.ring_ladder(s, Pg, P, R, self.n_turns)

    def jw_rational(self, v):
        Pg, P, R = self._rings(v)
        return T.ladder_polynomials(Pg, P, R, self.n_turns)

    def foster(self, v, sections):
        Pg, P, R = T.uniform_rings(v[0], v[1], v[2], self.n_rings, self.n_turns)
        gap, Lk, tau = T.ring_ladder_modes(np.asarray(Pg), P, R, self.n_turns)
        return FosterPart(G=float(gap), L=Lk, tau=tau)

    def coil_start(self):
        n, N = self.n_rings, self.n_turns
        prior = self.params["alpha"].prior

        def basis(s, p):
            Pg, P, R = T.uniform_rings(np.zeros_like(p), p, np.ones_like(p), n, N)
            return T.ring_ladder(s, Pg, P, R, N)

        # the Bessel term and the uniform rings both scale with beta at fixed alpha
        return CoilStart(scan="alpha", scan_range=(prior.lower, prior.upper), basis=basis,
                         to_params=lambda p, c: {"alpha": p, "beta": c}, linear_with_basis={"Lg": _s},
                         seeds=_alpha_seeds, fallback={"Lg": lambda L_lf: 1e-3 * L_lf})
