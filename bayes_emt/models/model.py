"""A model is its terms: the terminal admittance (eq. 47 and its augmentations) composed from them.

A :class:`Model` evaluates, for parameter vectors ``theta`` of shape ``(..., k)`` (physical SI
values, in ``model.params`` order) and frequencies of shape ``(F,)``, complex arrays of shape
``(..., F)``: one call serves one parameter set (least squares) or a whole ensemble (emcee).
Terms enter at their stage (:mod:`bayes_emt.models.term`):

    Y_mot = (s² + 2ζω0 s + ω0² κ(s)) / (φ̄² s) + Σ motional-parallel admittances
    Z     = 1/Y_mot + Σ series impedances                       (R0, coil, other modes, leads)
    Y     = factor(s) · (1/Z + Σ parallel admittances)          (winding capacitance, a second driver;
                                                                  artefacts)

A term that copies the model's own driver (:attr:`~bayes_emt.models.term.Term.sees_driver`: a second
driver in parallel) is evaluated after the others, given the driver's series impedance besides R0
and its motional-parallel admittance.

Models compare equal by value, pickle, and serialise to a dict from which
:func:`~bayes_emt.models.spec.model_from_dict` rebuilds them (terms, configuration and priors).
Nothing outside ``models/`` needs a model's name: behaviour comes from the terms.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..params import ParamSet, Prior
from . import terms as T
from .registry import BASE_MODELS
from .term import Term

__all__ = ["Model", "Loop", "JwForm"]


@dataclass(frozen=True)
class Loop:
    """The plant as the shunt sees it, at frequencies ``s``: arrays ``(..., F)`` (``phi`` ``(...)``).

    ``G(s) = (1/m) / (mech + φ̄² s / (z_series + Zx))`` (the source paper's eq. 50 generalised) with ``Zx`` the
    external network across the terminals: the shunt in parallel with ``y_parallel``.

    Attributes
    ----------
    mech : the mass-normalised mechanical polynomial with every stiffness modifier and motional
        load, ``φ̄² s Y_mot`` [1/s²].
    phi : ``φ̄`` [N/(A kg^½)].
    z_series : the device's series impedance besides the primary motional branch [Ω] (``Zc + R0``
        and any other series term).
    y_parallel : the device's admittance across the terminals [S] (0 for the paper's models).
    """

    mech: np.ndarray
    phi: np.ndarray
    z_series: np.ndarray
    y_parallel: np.ndarray


@dataclass(frozen=True)
class JwForm:
    """A model's measured admittance on ``s = jω`` for ``W`` parameter sets, from its terms' fast
    kernels (:meth:`Model.jw_form`):

        Y(s) = den(s) / (num(s) + den(s) Σ_i β_i sqrt(s) I1(sqrt(α_i s))/I0(sqrt(α_i s)))

    ``num``, ``den`` : polynomial coefficients ``(W, d + 1)`` (lowest power first): without
    parallel terms ``num/den`` is the rational part of the series impedance [Ω]; with them (and then
    no Bessel term) ``den/num`` is the whole admittance [S].
    ``bessel`` : ``((alpha (W,) [s], beta (W,) [Ω s^½]), ...)``, one pair per Bessel series term.
    """

    num: np.ndarray
    den: np.ndarray
    bessel: tuple[tuple[np.ndarray, np.ndarray], ...] = ()


@dataclass(frozen=True)
class Model:
    """A transducer model: an ordered tuple of terms (parameters are their concatenation)."""

    terms: tuple[Term, ...]

    def __post_init__(self):
        object.__setattr__(self, "terms", tuple(self.terms))
        motional = [t for t in self.terms if t.stage == "motional"]
        if len(motional) != 1:
            raise ValueError(f"a model needs exactly one motional term, got {len(motional)}")
        params = ParamSet(p for t in self.terms for p in t.params)
        missing = [n for t in self.terms for n in t.needs if n not in params.names]
        if missing:
            raise ValueError(f"terms need parameters the model lacks: {missing}")
        slices, i = [], 0
        for t in self.terms:
            slices.append(slice(i, i + len(t.params)))
            i += len(t.params)
        object.__setattr__(self, "params", params)
        object.__setattr__(self, "_slices", tuple(slices))

    def __reduce__(self):
        return (Model, (self.terms,))

    # ---- identity ----------------------------------------------------------------------------
    @property
    def base_terms(self) -> tuple[Term, ...]:
        return tuple(t for t in self.terms if not t.augmentation)

    @property
    def augmentations(self) -> tuple[Term, ...]:
        return tuple(t for t in self.terms if t.augmentation)

    @property
    def base(self) -> str | None:
        """The paper's model the base terms make (``"UD"``), or ``None`` for another combination."""
        coil = tuple(t.id for t in self.base_terms if t.stage == "series" and t.id != "resistance")
        return next((name for name, ids in BASE_MODELS.items() if ids == coil), None)

    @property
    def rings(self) -> int | None:
        """Ring count of a ring-bearing coil term (NL, UL), else ``None``."""
        return next((t.n_rings for t in self.terms if hasattr(t, "n_rings")), None)

    @property
    def n_turns(self) -> float | None:
        return next((t.n_turns for t in self.terms if hasattr(t, "n_turns")), None)

    @property
    def spec(self) -> str:
        """The model spec a user types: ``"UD+second_resonance"``, ``"NL+winding_capacitance"``."""
        return "+".join([self._base_label()] + [t.id for t in self.augmentations])

    def _base_label(self) -> str:
        """The base model's name, or its coil terms' ids for a combination that is none of the paper's."""
        return self.base or "+".join(t.id for t in self.base_terms if t.coil)

    @property
    def label(self) -> str:
        """Display label: the spec with the ring count, ``"NL(5)+winding_capacitance"``."""
        base = self._base_label()
        if self.rings is not None:
            base = f"{base}({self.rings})"
        return "+".join([base] + [t.id for t in self.augmentations])

    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    @property
    def ndim(self) -> int:
        return len(self.params)

    def term_slice(self, term: Term) -> slice:
        return self._slices[self.terms.index(term)]

    def vector(self, values) -> np.ndarray:
        return self.params.vector(values)

    def as_dict(self, theta) -> dict[str, float]:
        return self.params.as_dict(theta)

    # ---- derived models ------------------------------------------------------------------------
    def with_priors(self, overrides: Mapping[str, Prior | dict], *, where: str = "priors") -> Model:
        """A copy whose parameter priors are overridden (unknown names raise)."""
        new = self.params.with_priors(overrides, where=where)
        return Model(tuple(t.with_params(ParamSet(new[sl])) for t, sl in zip(self.terms, self._slices,
                                                                               strict=True)))

    def with_term(self, term: Term) -> Model:
        """A copy augmented by one more term (the discrepancy step's building block)."""
        if any(t.id == term.id for t in self.terms):
            raise ValueError(f"model {self.label} already has the term {term.id}")
        return Model(self.terms + (term,))

    def without(self, term: Term) -> Model:
        return Model(tuple(t for t in self.terms if t is not term))

    def replace_term(self, old: Term, new: Term) -> Model:
        return Model(tuple(new if t is old else t for t in self.terms))

    def base_model(self) -> Model:
        """The model without its augmentations."""
        return Model(self.base_terms)

    def bind(self, omega) -> Model:
        """The model configured for data at ``omega`` [rad/s] (see :meth:`Term.bind`)."""
        terms = tuple(t.bind(omega) for t in self.terms)
        return self if terms == self.terms else Model(terms)

    def to_dict(self) -> dict:
        """``{"spec", "label", "rings", "n_turns", "terms", "parameters"}``: what rebuilds it."""
        return {"spec": self.spec, "label": self.label, "rings": self.rings, "n_turns": self.n_turns,
                "terms": [t.to_dict() for t in self.terms], "parameters": self.params.to_dict()}

    # ---- fast kernels on s = jω ------------------------------------------------------------------
    def jw_form(self, theta) -> JwForm | None:
        """The admittance as :class:`JwForm` for parameter sets ``theta (W, k)``, composed from the
        terms' :meth:`~bayes_emt.models.term.Term.jw_rational` and
        :meth:`~bayes_emt.models.term.Term.jw_bessel`; ``None`` when some term offers neither, or
        its stage does not compose into that form (stiffness and motional-parallel modifiers, a
        measurement factor, a Bessel kernel anywhere but in series, or parallel terms beside a
        Bessel kernel). Stages compose as in the module docstring: the motional impedance plus the
        series terms summed as one polynomial pair ``Z = num/den``; parallel admittances ``p/q``
        folded in as ``Y = (den q + p num)/(num q)``."""
        flat = np.asarray(theta, float)
        if flat.ndim != 2 or flat.shape[1] != self.ndim:
            raise ValueError(f"model {self.label} jw_form takes (W, {self.ndim}) parameter sets, "
                             f"got {flat.shape}")
        z = par = None
        bessel = []
        for t, sl in zip(self.terms, self._slices, strict=True):
            if t.stage not in ("motional", "series", "parallel"):
                return None
            v = flat[:, sl]
            pair = t.jw_rational(v)
            if pair is None:
                b = t.jw_bessel(v) if t.stage == "series" else None
                if b is None:
                    return None
                bessel.append(b)
            elif t.stage == "parallel":
                par = pair if par is None else T.add_rational(par, pair)
            else:
                z = pair if z is None else T.add_rational(z, pair)
        if par is not None:
            if bessel:
                return None
            y_num, y_den = T.add_rational((z[1], z[0]), par)  # den/num + p/q as one pair
            z = (y_den, y_num)
        return JwForm(z[0], z[1], tuple(bessel))

    # ---- evaluation ------------------------------------------------------------------------------
    def _prepare(self, theta):
        theta = np.asarray(theta, dtype=float)
        if theta.shape[-1:] != (self.ndim,):
            raise ValueError(
                f"model {self.label} takes {self.ndim} parameters {list(self.names)}, "
                f"got an array of shape {theta.shape}")
        lead = theta.shape[:-1]
        return theta.reshape(-1, self.ndim), lead

    def _parts(self, s, flat, *, device_only: bool):
        """Stage sums at ``s`` (F,) for parameter blocks ``flat`` (P, k) (module docstring)."""
        P = flat.shape[0]
        other = {}
        for t in self.terms:
            for n in t.needs:
                i = self.params.index(n)
                other[n] = flat[:, i : i + 1]
        out = {"kappa": None, "y_mot_extra": None, "series": None, "parallel": None, "factor": None}
        motional = None
        sees = any(t.sees_driver for t in self.terms)
        coil = np.zeros((P, s.size), complex) if sees else None
        later = []
        for t, sl in zip(self.terms, self._slices, strict=True):
            if device_only and not t.device:
                continue
            v = flat[:, sl]
            if t.stage == "motional":
                motional = (t, v)
                continue
            if t.sees_driver:  # evaluated last, with the driver's coil and box (Term.sees_driver)
                later.append((t, v))
                continue
            c = t.evaluate(s, v, other)
            if sees and t.stage == "series" and t.device and (t.coil or t.augmentation):
                coil = coil + c  # the driver's series impedance besides R0 (Term.sees_driver)
            self._add_part(out, t.stage, c, P, s.size)
        for t, v in later:
            c = t.evaluate(s, v, {**other, "coil": coil, "y_mot_extra": out["y_mot_extra"]})
            self._add_part(out, t.stage, c, P, s.size)
        out["motional"] = motional
        return out

    @staticmethod
    def _add_part(out, stage, c, P, F) -> None:
        """Add a term's contribution ``c`` to its stage's sum in ``out`` (factors multiply)."""
        key = {"stiffness": "kappa", "motional_parallel": "y_mot_extra", "series": "series",
               "parallel": "parallel", "measurement": "factor"}[stage]
        prev = out[key]
        if prev is None:
            out[key] = np.broadcast_to(c, (P, F)).astype(complex)
        elif key in ("kappa", "factor"):
            out[key] = prev * c
        else:
            out[key] = prev + c

    @staticmethod
    def _mech(s, v, kappa):
        zeta, omega0 = v[:, 0:1], v[:, 1:2]
        if kappa is None:
            return T.mechanical_polynomial(s, zeta, omega0)
        return s * s + 2.0 * zeta * omega0 * s + omega0 * omega0 * kappa

    def _series_impedance(self, s, parts):
        """``Z = 1/Y_mot + Σ series`` (P, F); the plain motional impedance when nothing modifies it."""
        t, v = parts["motional"]
        if parts["kappa"] is None and parts["y_mot_extra"] is None:
            z = t.evaluate(s, v, {})
        else:
            phi2 = v[:, 2:3] ** 2
            y = self._mech(s, v, parts["kappa"]) / (phi2 * s)
            if parts["y_mot_extra"] is not None:
                y = y + parts["y_mot_extra"]
            z = 1.0 / y
        return z if parts["series"] is None else z + parts["series"]

    def _admittance(self, s, theta, *, device_only: bool):
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        flat, lead = self._prepare(theta)
        parts = self._parts(s.ravel(), flat, device_only=device_only)
        with np.errstate(divide="ignore", invalid="ignore"):
            y = 1.0 / self._series_impedance(s.ravel(), parts)
        if parts["parallel"] is not None:
            y = y + parts["parallel"]
        if parts["factor"] is not None:
            y = y * parts["factor"]
        return y.reshape(lead + s.shape)

    def admittance_s(self, s, theta):
        """Terminal admittance ``Y(s)`` [S] as measured (every term), at complex ``s``."""
        return self._admittance(s, theta, device_only=False)

    def admittance(self, omega, theta):
        """Terminal admittance ``Y(jω)`` [S]; ``omega`` in rad/s."""
        return self.admittance_s(1j * np.asarray(omega, dtype=float), theta)

    def impedance(self, omega, theta):
        """Terminal impedance ``1/Y(jω)`` [Ω] as measured; ``omega`` in rad/s."""
        return 1.0 / self.admittance(omega, theta)

    def impedance_s(self, s, theta):
        """The device's terminal impedance ``1/Y_device(s)`` [Ω] (instrument terms left out), at
        complex ``s``: what a shunt across the terminals sees (stability analysis)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return 1.0 / self._admittance(s, theta, device_only=True)

    def loop(self, s, theta) -> Loop:
        """The plant as the shunt sees it (:class:`Loop`), device terms only."""
        s = np.atleast_1d(np.asarray(s, dtype=complex)).ravel()
        flat, lead = self._prepare(theta)
        parts = self._parts(s, flat, device_only=True)
        _, v = parts["motional"]
        phi = v[:, 2]
        mech = self._mech(s, v, parts["kappa"])
        if parts["y_mot_extra"] is not None:
            mech = mech + (phi[:, None] ** 2) * s * parts["y_mot_extra"]
        mech = np.broadcast_to(mech, (flat.shape[0], s.size))
        zero = np.zeros((flat.shape[0], s.size), complex)
        zs = parts["series"] if parts["series"] is not None else zero
        yp = parts["parallel"] if parts["parallel"] is not None else zero

        def shape(a):
            return a.reshape(lead + (s.size,))

        return Loop(shape(mech), phi.reshape(lead), shape(zs), shape(yp))

    @property
    def plain_mechanics(self) -> bool:
        """Whether the mechanical branch is the plain ``s² + 2ζω0 s + ω0²`` (no stiffness modifier,
        no motional load) and nothing sits across the terminals: the closed forms of the shunt
        design (open-terminal peak) hold."""
        return not any(t.device and t.stage in ("stiffness", "motional_parallel", "parallel")
                       for t in self.terms)

    def electrical_impedance_s(self, s, theta):
        """Blocked (non-motional) series impedance ``Zc + R0`` (+ any other series device term) [Ω]."""
        return self.loop(s, theta).z_series

    def coil_impedance(self, omega, theta):
        """The coil's own impedance ``Zc(jω)`` [Ω] (coil terms only, without R0); ``omega`` in rad/s."""
        s = 1j * np.atleast_1d(np.asarray(omega, float))
        flat, lead = self._prepare(theta)
        out = np.zeros((flat.shape[0], s.size), complex)
        for t, sl in zip(self.terms, self._slices, strict=True):
            if t.coil:
                out = out + t.evaluate(s, flat[:, sl], {})
        return out.reshape(lead + s.shape)

    def mechanics(self, theta):
        """``(zeta, omega0, phi)`` arrays of shape ``theta.shape[:-1]``."""
        theta = np.asarray(theta, dtype=float)
        return tuple(theta[..., self.params.index(n)] for n in ("zeta", "omega0", "phi"))
