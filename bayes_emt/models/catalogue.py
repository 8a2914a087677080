"""The catalogue of named physics terms that models are composed from.

A :class:`Term` couples a pure function of :mod:`bayes_emt.models.terms` to its parameter specs.
Terms are *series* impedances (summed into the terminal impedance) or *parallel* admittances
(added to ``1/Z``); their ``role`` tells downstream code which part of the plant they describe
(``motional`` for the mechanical branch, ``electrical`` for the coil and its resistance). The
discrepancy step draws augmentations from this same catalogue.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..params import ParamSet, default_spec
from . import terms as T

__all__ = ["Term", "TERMS", "make_term"]


@dataclass(frozen=True)
class Term:
    """A named physics term.

    Attributes
    ----------
    name : catalogue name (e.g. ``"bessel_eddy"``).
    kind : ``"series"`` (an impedance, ohm) or ``"parallel"`` (an admittance, S).
    role : ``"motional"`` or ``"electrical"``.
    params : the term's parameter specs, in the order ``evaluate`` expects its columns.
    func : ``func(s, values) -> complex``; ``s`` shape ``(F,)``, ``values`` shape ``(P, k)``,
        result ``(P, F)``.
    description : one line of physics, for reports.
    """

    name: str
    kind: Literal["series", "parallel"]
    role: Literal["motional", "electrical"]
    params: ParamSet
    func: Callable[[np.ndarray, np.ndarray], np.ndarray]
    description: str = ""

    def evaluate(self, s, values):
        return self.func(s, values)


def _specs(*names):
    return ParamSet(default_spec(n) for n in names)


def _col(values, i):
    return values[:, i : i + 1]


def motional() -> Term:
    return Term("motional", "series", "motional", _specs("zeta", "omega0", "phi"),
                lambda s, v: T.motional_impedance(s, _col(v, 0), _col(v, 1), _col(v, 2)),
                "moving mass on a spring with viscous damping, coupled by phi (eq. 47)")


def resistance() -> Term:
    return Term("resistance", "series", "electrical", _specs("R0"),
                lambda s, v: _col(v, 0) + 0 * s, "coil DC resistance R0")


def inductance() -> Term:
    return Term("inductance", "series", "electrical", _specs("L0"),
                lambda s, v: T.inductance(s, _col(v, 0)), "coil self-inductance L0 s (model I)")


def gap_inductance() -> Term:
    return Term("gap_inductance", "series", "electrical", _specs("Lg"),
                lambda s, v: T.inductance(s, _col(v, 0)), "air-gap inductance Lg s")


def lossy_inductance() -> Term:
    return Term("lossy_inductance", "series", "electrical", _specs("L0", "Rmu"),
                lambda s, v: T.lossy_inductance(s, _col(v, 0), _col(v, 1)),
                "inductance with lumped eddy loss Rmu || L0 s (model II)")


def bessel_eddy() -> Term:
    return Term("bessel_eddy", "series", "electrical", _specs("alpha", "beta"),
                lambda s, v: T.bessel_eddy(s, _col(v, 0), _col(v, 1)),
                "eddy currents distributed in a uniform cylindrical core (model III)")


def ring_ladder(n_rings: int, n_turns: float) -> Term:
    if int(n_rings) != n_rings or n_rings < 1:
        raise ValueError(f"rings must be a positive integer, got {n_rings!r}")
    n = int(n_rings)
    names = ["Pg"] + [f"P{j}" for j in range(1, n + 1)] + [f"R{j}" for j in range(1, n + 1)]

    def f(s, v):
        return T.ring_ladder(s, v[:, 0], v[:, 1 : n + 1], v[:, n + 1 :], n_turns)

    return Term("ring_ladder", "series", "electrical", _specs(*names), f,
                f"non-uniform core cut into {n} rings, eddy current lumped per ring (eq. 41)")


def uniform_rings(n_rings: int, n_turns: float) -> Term:
    n = int(n_rings)
    if n != n_rings or n < 1:
        raise ValueError(f"rings must be a positive integer, got {n_rings!r}")

    def f(s, v):
        Pg, P, R = T.uniform_rings(v[:, 0], v[:, 1], v[:, 2], n, n_turns)
        return T.ring_ladder(s, Pg, P, R, n_turns)

    return Term("uniform_rings", "series", "electrical", _specs("Lg", "alpha", "beta"), f,
                f"uniform core, air gap, eddy currents lumped in {n} equal-area rings (UL)")


TERMS: dict[str, Callable[..., Term]] = {
    "motional": motional,
    "resistance": resistance,
    "inductance": inductance,
    "gap_inductance": gap_inductance,
    "lossy_inductance": lossy_inductance,
    "bessel_eddy": bessel_eddy,
    "ring_ladder": ring_ladder,
    "uniform_rings": uniform_rings,
}


def make_term(name: str, **kwargs) -> Term:
    try:
        factory = TERMS[name]
    except KeyError:
        raise KeyError(f"unknown physics term {name!r}; the catalogue has {sorted(TERMS)}") from None
    return factory(**kwargs)
