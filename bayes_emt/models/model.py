"""Models: plant admittance (eq. 47) composed from catalogue terms, and the registry of the
paper's six coil models.

A :class:`Model` evaluates, for parameter vectors ``theta`` of shape ``(..., k)`` (physical SI
values, in ``model.params`` order) and frequencies of shape ``(F,)``, complex arrays of shape
``(..., F)``: one call serves one parameter set (least squares) or a whole ensemble (emcee).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from ..params import ParamSet, Prior
from .catalogue import Term, make_term

__all__ = ["Model", "build_model", "MODEL_NAMES", "DEFAULT_N_TURNS", "DEFAULT_RINGS"]

MODEL_NAMES = ("I", "II", "III", "UD", "NL", "UL")
ModelName = Literal["I", "II", "III", "UD", "NL", "UL"]
DEFAULT_N_TURNS = 480.0  # the paper's coil (SPEC §2)
DEFAULT_RINGS = 5  # the paper's NL choice (SPEC §3.3)

_COIL_TERMS = {
    "I": ("inductance",),
    "II": ("lossy_inductance",),
    "III": ("bessel_eddy",),
    "UD": ("gap_inductance", "bessel_eddy"),
    "NL": ("ring_ladder",),
    "UL": ("uniform_rings",),
}


@dataclass(frozen=True)
class Model:
    """A transducer model: an ordered tuple of catalogue terms.

    Parameter order is the concatenation of the terms' parameters; the paper's models put
    ``[zeta, omega0, phi, R0]`` first, then the coil parameters.
    """

    name: str
    terms: tuple[Term, ...]
    n_turns: float = DEFAULT_N_TURNS
    rings: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "params", ParamSet(p for t in self.terms for p in t.params))
        slices, i = [], 0
        for t in self.terms:
            slices.append(slice(i, i + len(t.params)))
            i += len(t.params)
        object.__setattr__(self, "_slices", tuple(slices))

    # ---- bookkeeping -----------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    @property
    def ndim(self) -> int:
        return len(self.params)

    @property
    def label(self) -> str:
        return f"{self.name}({self.rings})" if self.rings is not None else self.name

    def vector(self, values) -> np.ndarray:
        return self.params.vector(values)

    def as_dict(self, theta) -> dict[str, float]:
        return self.params.as_dict(theta)

    def with_priors(self, overrides: dict[str, Prior | dict], *, where: str = "priors") -> Model:
        """A copy whose parameter priors are overridden (unknown names raise)."""
        new_params = self.params.with_priors(overrides, where=where)
        new_terms = []
        for t, sl in zip(self.terms, self._slices, strict=True):
            new_terms.append(replace(t, params=ParamSet(new_params[sl])))
        return replace(self, terms=tuple(new_terms))

    def with_term(self, term: Term, name: str | None = None) -> Model:
        """A copy augmented by one more catalogue term (the discrepancy step's building block)."""
        return replace(self, name=name or f"{self.name}+{term.name}", terms=self.terms + (term,))

    def to_dict(self) -> dict:
        return {"model": self.name, "rings": self.rings, "n_turns": self.n_turns,
                "terms": [t.name for t in self.terms], "parameters": self.params.to_dict()}

    # ---- evaluation --------------------------------------------------------------------------
    def _prepare(self, theta):
        theta = np.asarray(theta, dtype=float)
        if theta.shape[-1:] != (self.ndim,):
            raise ValueError(
                f"model {self.label} takes {self.ndim} parameters {list(self.names)}, "
                f"got an array of shape {theta.shape}")
        lead = theta.shape[:-1]
        return theta.reshape(-1, self.ndim), lead

    def _sum(self, s, theta, *, kind, roles):
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        flat, lead = self._prepare(theta)
        out = np.zeros((flat.shape[0], s.size), dtype=complex)
        for t, sl in zip(self.terms, self._slices, strict=True):
            if t.kind == kind and t.role in roles:
                out += t.evaluate(s.ravel(), flat[:, sl])
        return out.reshape(lead + s.shape)

    def impedance_s(self, s, theta):
        """Series impedance ``Z(s)`` [ohm] (coil + R0 + motional), at complex ``s``."""
        return self._sum(s, theta, kind="series", roles=("motional", "electrical"))

    def admittance_s(self, s, theta):
        """Terminal admittance ``Y(s)`` [S] (eq. 47 plus any parallel terms), at complex ``s``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            y = 1.0 / self.impedance_s(s, theta)
        return y + self._sum(s, theta, kind="parallel", roles=("motional", "electrical"))

    def admittance(self, omega, theta):
        """Terminal admittance ``Y(jω)`` [S]; ``omega`` in rad/s."""
        return self.admittance_s(1j * np.asarray(omega, dtype=float), theta)

    def impedance(self, omega, theta):
        """Terminal impedance ``1/Y(jω)`` [ohm]; ``omega`` in rad/s."""
        return 1.0 / self.admittance(omega, theta)

    def electrical_impedance_s(self, s, theta):
        """Blocked (non-motional) series impedance ``Zc(s) + R0`` [ohm]."""
        return self._sum(s, theta, kind="series", roles=("electrical",))

    def coil_impedance(self, omega, theta):
        """The coil's own impedance ``Zc(jω)`` [ohm] (without R0), ``omega`` in rad/s."""
        theta = np.asarray(theta, dtype=float)
        r0 = theta[..., self.params.index("R0")]
        return self.electrical_impedance_s(1j * np.asarray(omega, float), theta) - r0[..., None]

    def mechanics(self, theta):
        """``(zeta, omega0, phi)`` arrays of shape ``theta.shape[:-1]``."""
        theta = np.asarray(theta, dtype=float)
        return tuple(theta[..., self.params.index(n)] for n in ("zeta", "omega0", "phi"))


def build_model(name: str, *, rings: int | None = None, n_turns: float = DEFAULT_N_TURNS) -> Model:
    """One of the paper's six models (SPEC §2): ``I, II, III, UD, NL, UL``.

    ``rings`` applies to NL and UL only (default 5); ``n_turns`` is the coil's turn count N.
    """
    key = str(name).upper()
    if key not in _COIL_TERMS:
        raise ValueError(f"unknown model {name!r}; choose one of {', '.join(MODEL_NAMES)}")
    if not (np.isfinite(n_turns) and n_turns > 0):
        raise ValueError(f"n_turns must be positive, got {n_turns!r}")
    if key in ("NL", "UL"):
        rings = DEFAULT_RINGS if rings is None else rings
        if isinstance(rings, bool) or int(rings) != rings or rings < 1:
            raise ValueError(f"rings must be a positive integer, got {rings!r}")
        rings = int(rings)
    elif rings is not None:
        raise ValueError(f"--rings applies to NL and UL only, not to model {key}")
    terms = [make_term("motional"), make_term("resistance")]
    for tname in _COIL_TERMS[key]:
        if tname in ("ring_ladder", "uniform_rings"):
            terms.append(make_term(tname, n_rings=rings, n_turns=n_turns))
        else:
            terms.append(make_term(tname))
    return Model(key, tuple(terms), float(n_turns), rings)
