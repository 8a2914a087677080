"""The physics-term protocol: a term owns everything the rest of the package needs to know about it.

A :class:`Term` is a frozen record of its parameter specs (with priors) and its configuration
(e.g. a ring count), plus class-level behaviour:

* **its parameters** (:attr:`Term.parameters`): every spec it declares, name (as documented), SI unit,
  label and proper prior, the same for a name in every term that declares it (evidences of models
  sharing a parameter stay comparable); :func:`~bayes_emt.models.registry.param_spec` looks a name
  up among the registered terms;
* **for an augmentation, its band class** (:attr:`Term.band`, one of :data:`BANDS`): where its
  signature acts relative to the mechanical resonance, which is how discrepancy discovery proposes
  it (:mod:`bayes_emt.discovery.candidates`), beside the signature said in words
  (:attr:`Term.signature`) and what rules a fitted value out (:meth:`Term.implausible`);

* **where it enters the plant** (:attr:`Term.stage`, see below) and how it evaluates
  (:meth:`Term.evaluate`, vectorised over parameter sets);
* **whether it is device physics** (:attr:`Term.device`): the shunt design and stability analysis
  use device terms only, never instrument effects (a range-switch step, a drifting coil
  temperature during the sweep);
* **how to start it**: coil terms give the linear coil stage of the initial estimate their columns
  and their one nonlinear scan parameter (:meth:`Term.coil_start`), a term with a coarser surrogate
  (NL's ring ladder starts from uniform rings) says so (:meth:`Term.surrogate`), and an
  augmentation proposes starting values from the base fit's residual in the band where it acts
  (:meth:`Term.start`);
* **its rational (Foster) form** where it has one (:meth:`Term.foster`);
* **its fast kernel on** ``s = jω`` where it has one (optional): :meth:`Term.jw_rational`, what
  :meth:`Term.evaluate` returns as a polynomial pair in ``s``, or :meth:`Term.jw_bessel`, the
  parameters of model III's Bessel kernel; a model all of whose terms offer one is evaluated by
  the likelihood's fast path (:meth:`~bayes_emt.models.model.Model.jw_form`), any other by
  :meth:`Term.evaluate`;
* **its serialised form** (:meth:`Term.to_dict`, :func:`~bayes_emt.models.registry.term_from_dict`),
  once registered (:func:`~bayes_emt.models.registry.register_term`, which also makes an augmentation
  available to model specs ``"UD+my_term"`` and to discovery);
* for reports: a one-line physical description, its typical signature in the data, and the
  discrepancy-physics id it belongs to (``eddy_current`` for the coil terms).

Stages (see Physics and conventions; ``s = jω``; ``Y_mot`` the motional branch's admittance):

``stiffness``          multiplies the mechanical stiffness: ``ω0² → ω0² κ(s)`` (suspension creep)
``motional``           the primary mechanical branch itself: ``Y_mot = (s² + 2ζω0 s + ω0² κ)/(φ̄² s)``
``motional_parallel``  an admittance added to ``Y_mot`` (a vented box's port/box branch)
``series``             an impedance in series at the terminals (R0, coil, another mode, leads)
``parallel``           an admittance across the terminals (winding capacitance)
``measurement``        a factor on the measured admittance (an instrument artefact)

so that ``Y = factor · (1/(1/Y_mot + Σ series) + Σ parallel)`` (eq. 47 and its augmentations).
"""

from __future__ import annotations

import re
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import ClassVar, Literal

import numpy as np

from ..params import ParamSet, ParamSpec

__all__ = ["Term", "Stage", "BandClass", "BANDS", "CoilStart", "FosterPart", "StartContext", "indexed",
           "resolve_spec"]

Stage = Literal["stiffness", "motional", "motional_parallel", "series", "parallel", "measurement"]

#: an augmentation's band class: where its signature acts relative to the mechanical resonance
#: ``ω_r`` the data show. ``coil``: where the coil dominates (a band reaching above ``3 ω_r``);
#: ``mechanical``: around and below the resonance (a band reaching below ``3 ω_r``); ``anywhere``:
#: a mode or an instrument effect at any frequency, or a drift along the sweep order
BandClass = Literal["coil", "mechanical", "anywhere"]
BANDS: tuple[str, ...] = typing.get_args(BandClass)

#: the index placeholder of an indexed parameter spec (``P{j}``: the permeance of core ring j)
INDEX = "{j}"
_POSITIVE = re.compile(r"[1-9]\d*")


def indexed(spec: ParamSpec, j: int) -> ParamSpec:
    """Parameter ``j`` of an indexed spec: ``{j}`` replaced by ``j`` in its name and description
    (``P{j}`` → ``P3``, ``ring {j}`` → ``ring 3``) and by ``{j}`` in its TeX label (``$P_{3}$``)."""
    return ParamSpec(spec.name.replace(INDEX, str(j)), spec.unit, spec.label.replace(INDEX, f"{{{j}}}"),
                     spec.prior, spec.description.replace(INDEX, str(j)))


def resolve_spec(specs, name: str) -> ParamSpec | None:
    """The spec of ``name`` among ``specs``: an exact name, or an indexed spec's name with a positive
    index (``R3`` from ``R{j}``; ``R0`` is not ring 0); ``None`` when none declares it."""
    for spec in specs:
        if spec.name == name:
            return spec
    for spec in specs:
        if INDEX in spec.name:
            head, tail = spec.name.split(INDEX, 1)
            mid = name[len(head) : len(name) - len(tail)]
            if name.startswith(head) and name.endswith(tail) and _POSITIVE.fullmatch(mid):
                return indexed(spec, int(mid))
    return None


@dataclass(frozen=True)
class FosterPart:
    """A term's share of the Foster form ``Ze(s) = R + G s + Σ_k L_k s/(1 + τ_k s)`` [Ω].

    ``R`` [Ω], ``G`` [H], ``L`` [H] and ``tau`` [s] per section; ``error_coeff`` ``E`` [Ω s²] bounds
    the truncation error ``|e(s)| ≤ E |s|²`` for ``Re s ≥ 0`` (0 when exact)."""

    R: float = 0.0
    G: float = 0.0
    L: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tau: np.ndarray = field(default_factory=lambda: np.zeros(0))
    error_coeff: float = 0.0
    note: str = ""


@dataclass(frozen=True)
class CoilStart:
    """How a coil term enters the linear coil stage of the initial estimate.

    With the plant's motional term removed, the blocked impedance ``Ze = R0 + Σ coil terms`` is
    linear in ``R0`` and in scale coefficients once at most one nonlinear parameter ``p`` is fixed.

    Attributes
    ----------
    linear : ``{param: column(s)}``: parameters that are themselves coefficients of a column
        (``L0`` and ``Lg`` multiply ``s``).
    scan : name of the one nonlinear parameter ``p`` (``"tau"`` for model II's ``L0/Rμ``, ``"alpha"``
        for the eddy-current diffusion time), or ``None``.
    scan_range : ``(lo, hi)`` bounds of ``p`` (the prior support, or a physical range).
    basis : ``basis(s (F,), p (A,)) -> (A, F)``, the term at unit scale for each ``p``.
    to_params : ``to_params(p, c) -> {param: value}``, the term's parameters from ``p`` and the
        fitted scale coefficient ``c`` of ``basis``.
    linear_with_basis : further ``{param: column(s)}`` the term contributes beside its basis (UL's
        gap inductance), fitted jointly with it.
    seeds : ``seeds(s, Ze, w, has_inductance) -> [(label, p)]``: values of ``p`` from a closed-form
        approximation (the paper's rational Bessel start), refined on the scan's fine grid.
    direct : ``direct(s, Ze, w, R0_levy, L_lf) -> [(label, {param: value})]``: complete candidates
        from the paper's own linearisation (model II), used as they are.
    fallback : value for a linear parameter whose non-negative fit came out 0, as a function of the
        plant's low-frequency inductance ``L_lf`` [H].
    """

    linear: Mapping[str, Callable] = None
    scan: str | None = None
    scan_range: tuple[float, float] = (0.0, 0.0)
    basis: Callable | None = None
    to_params: Callable | None = None
    linear_with_basis: Mapping[str, Callable] = None
    seeds: Callable | None = None
    direct: Callable | None = None
    fallback: Mapping[str, Callable] = None


@dataclass(frozen=True)
class StartContext:
    """What an augmentation's start sees: the data and the base model's fit at those frequencies.

    ``omega`` [rad/s] (F,); ``Y`` the measured admittance [S]; ``Y_base`` the base fit's admittance
    [S]; ``base`` its parameters ``{name: value}`` [SI]; ``resonance`` ``(omega, lo, hi)`` [rad/s] of
    the located impedance peak or ``None``; ``band`` ``(lo, hi)`` [rad/s] where the caller located a
    mismatch, or ``None`` (the whole band)."""

    omega: np.ndarray
    Y: np.ndarray
    Y_base: np.ndarray
    base: Mapping[str, float]
    resonance: tuple[float, float, float] | None = None
    band: tuple[float, float] | None = None

    @property
    def s(self) -> np.ndarray:
        return 1j * self.omega

    @property
    def Z(self) -> np.ndarray:
        return 1.0 / self.Y

    @property
    def Z_base(self) -> np.ndarray:
        return 1.0 / self.Y_base

    def in_band(self) -> np.ndarray:
        """Mask of the frequencies inside :attr:`band` (all when no band is given)."""
        if self.band is None:
            return np.ones(self.omega.size, bool)
        return (self.omega >= self.band[0]) & (self.omega <= self.band[1])


def col(values: np.ndarray, i: int) -> np.ndarray:
    """Column ``i`` of a ``(P, k)`` parameter block as ``(P, 1)`` (broadcasts against ``(F,)``)."""
    return values[:, i : i + 1]


@dataclass(frozen=True)
class Term:
    """Base class of every physics term (module docstring). Subclasses are frozen dataclasses whose
    fields besides ``params`` are their configuration; they set the class attributes below."""

    params: ParamSet

    id: ClassVar[str] = ""
    stage: ClassVar[Stage] = "series"
    physics: ClassVar[str] = ""
    description: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    #: part of the coil's own impedance Zc (what the shunt's closed form and L_lf look at)
    coil: ClassVar[bool] = False
    #: device physics (False for instrument and measurement-session effects)
    device: ClassVar[bool] = True
    #: an augmentation from the physics catalogue (False for the paper's base terms)
    augmentation: ClassVar[bool] = False
    #: other terms' parameters :meth:`evaluate` reads (passed in ``other``)
    needs: ClassVar[tuple[str, ...]] = ()
    #: what the data can and cannot determine, said in reports (e.g. lead resistance vs R0)
    identifiability: ClassVar[str] = ""
    #: every parameter spec the term declares, with its proper prior (module docstring); a name
    #: holding :data:`INDEX` is indexed (one per ring)
    parameters: ClassVar[tuple[ParamSpec, ...]] = ()
    #: an augmentation's band class (:data:`BANDS`): where discovery looks for its signature
    band: ClassVar[str] = ""
    #: a generic, flexible patch: discovery names it only with a margin of evidence over
    #: the physical terms for the same band, identifiable parameters and, with :attr:`step_at`, a
    #: discontinuity between adjacent measured points
    generic: ClassVar[bool] = False
    #: the parameter holding the frequency [rad/s] of a step the term puts between two points
    step_at: ClassVar[str] = ""
    #: ``(damping parameter, limit)``: a fitted damping ratio below the limit makes a generic mode a
    #: narrow, physical one (a broad one is a patch)
    narrow_when: ClassVar[tuple] = ()
    #: setups (``free-air``, ``sealed``, ``vented``, ``shaker``, ``unknown``) in which the term can
    #: exist; empty: every setup
    requires_setup: ClassVar[tuple[str, ...]] = ()
    #: the data signature the term needs before it is tried when the setup is ``unknown`` (a name of
    #: discovery's signature checks, e.g. ``"two_impedance_maxima"``); empty: none
    unknown_setup_needs: ClassVar[str] = ""
    #: the term re-places the driver's own resonance (a vented box splits it into two peaks), so
    #: discovery lets it move fs beyond :data:`~bayes_emt.discovery.name.FS_FACTOR_MAX`
    moves_resonance: ClassVar[bool] = False
    #: :meth:`evaluate` reads the model's own driver: ``other["coil"]``, the driver's series impedance
    #: besides R0 ``(P, F)`` [Ω] (its coil terms and every series device augmentation: a lossy coil,
    #: another mode, its leads), and ``other["y_mot_extra"]``, the admittance the
    #: motional-parallel terms add to the motional branch ``(P, F)`` [S] or ``None`` (a second driver
    #: of the same type in the same box); such a term is evaluated after every other
    sees_driver: ClassVar[bool] = False
    #: a structure beyond one driver (a second driver in parallel): discovery proposes it only when
    #: the fit shows that structure's signature (:func:`~bayes_emt.discovery.sanity.structure_signature`)
    structural: ClassVar[bool] = False

    # ---- construction and serialisation ---------------------------------------------------------
    @classmethod
    def make(cls, **config) -> Term:
        """The term with its catalogue priors (:meth:`default_params`) and ``config``."""
        return cls(cls.default_params(**config), **config)

    @classmethod
    def default_params(cls, **config) -> ParamSet:
        """The parameters with their declared priors (:attr:`parameters`, in order); a term with
        indexed parameters or configuration-dependent ones overrides this."""
        return ParamSet(cls.parameters)

    @classmethod
    def spec(cls, name: str) -> ParamSpec:
        """The declared spec of parameter ``name`` (an indexed one resolved, ``P3`` from ``P{j}``)."""
        found = resolve_spec(cls.parameters, name)
        if found is None:
            raise KeyError(f"term {cls.id!r} declares no parameter {name!r}; it has "
                           f"{[p.name for p in cls.parameters]}")
        return found

    @classmethod
    def specs(cls, *names: str) -> ParamSet:
        """The declared specs of ``names``, in order (:meth:`spec`)."""
        return ParamSet(cls.spec(n) for n in names)

    def config(self) -> dict:
        """The configuration fields (everything but ``params``), JSON-serialisable."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "params"}

    def to_dict(self) -> dict:
        """``{"id": ..., **config}``; priors are serialised with the model's parameter list."""
        return {"id": self.id, **self.config()}

    def with_params(self, params: ParamSet) -> Term:
        return replace(self, params=params)

    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    def describe(self) -> dict:
        """Catalogue entry for reports: id, stage, band class, physics, description, signature,
        parameters."""
        return {"id": self.id, "stage": self.stage, "band": self.band, "physics": self.physics,
                "description": self.description,
                "signature": self.signature, "device": self.device, "identifiability": self.identifiability,
                "parameters": [{"name": p.name, "unit": p.unit, "description": p.description,
                                "prior": p.prior.to_dict()} for p in self.params]}

    # ---- physics ---------------------------------------------------------------------------------
    def evaluate(self, s: np.ndarray, v: np.ndarray, other: Mapping[str, np.ndarray]) -> np.ndarray:
        """The term's contribution at ``s`` (F,) for parameter blocks ``v`` (P, k_term): an impedance
        [Ω] (``series``), admittance [S] (``parallel``, ``motional_parallel``), or a dimensionless
        factor (``stiffness``, ``measurement``); shape ``(P, F)``. ``other`` holds the ``(P, 1)``
        columns of the parameters named in :attr:`needs`."""
        raise NotImplementedError

    def bind(self, omega: np.ndarray) -> Term:
        """The term configured for data at ``omega`` [rad/s] (a sweep-order term needs the sweep's
        ends); most terms need nothing and return themselves."""
        return self

    # ---- fast kernels on s = jω (optional) ---------------------------------------------------------
    def jw_rational(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """What :meth:`evaluate` returns, as a polynomial pair ``(num, den)`` in ``s`` (coefficients
        lowest power first, each ``(P, d + 1)``, value ``num(s)/den(s)`` in the unit of
        :meth:`evaluate`) for parameter blocks ``v (P, k_term)``; ``None`` when the term has no such
        form (then a model holding it is evaluated through :meth:`evaluate`). A non-physical
        parameter set may give NaN coefficients, never raise."""
        return None

    def jw_bessel(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """``(alpha (P,) [s], beta (P,) [Ω s^½])`` when :meth:`evaluate` is model III's kernel
        ``β sqrt(s) I1(sqrt(α s))/I0(sqrt(α s))`` [Ω] for parameter blocks ``v (P, k_term)``
        (evaluated on ``s = jω`` from the table of :func:`~bayes_emt.models.terms.bessel_eddy_jw`);
        ``None`` otherwise."""
        return None

    # ---- realisation and starts -----------------------------------------------------------------
    def foster(self, v: np.ndarray, sections: int) -> FosterPart | None:
        """This term's share of the Foster form for one parameter vector ``v`` (k_term,), or ``None``
        when it has no finite RL form (then the model has none)."""
        return None

    def coil_start(self) -> CoilStart | None:
        """How the linear coil stage starts this term (coil terms only)."""
        return None

    def surrogate(self) -> tuple[Term, Callable[[Mapping[str, float]], dict]] | None:
        """``(coarser term, convert)``: fit the model with the coarser term first, then map its
        values to this term's (``convert(values) -> {name: value}``); ``None`` when not needed."""
        return None

    def implausible(self, values: Mapping[str, float]) -> str | None:
        """Why fitted ``values`` ``{name: value}`` [SI] (the whole model's) are not this physics,
        or ``None``: a term whose form can mimic another's (a vented box's branch far above the
        driver's resonance is a second mode, not a port) says so, and discrepancy discovery then
        does not name it."""
        return None

    def start(self, ctx: StartContext) -> list[dict[str, float]]:
        """Starting values ``[{param: value}]`` (several: a multi-start) of an augmentation, from the
        base fit's misfit in the band where it acts; best guesses first."""
        return []
