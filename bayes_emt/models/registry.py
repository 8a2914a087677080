"""The registry of terms by id, and of the paper's base models by the coil terms they use.

Everything that turns a name into behaviour lives here (and in :mod:`bayes_emt.models.spec`), so
that no other layer dispatches on a model's name: adding a term touches ``models/`` alone (one
module in :mod:`bayes_emt.models.physics`), or nothing in the package at all: a term class passed
to :func:`register_term` at run time is, from then on, available to model specs
(``"UD+my_term"``), to serialisation (:func:`term_from_dict`), to the parameter lookup
(:func:`param_spec`) and to discrepancy discovery (:func:`augmentations_in_band`).
"""

from __future__ import annotations

import inspect
import json
import re
import typing
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import is_dataclass

from ..params import ParamSpec, Prior, noise_param_set
from .catalogue import (
    BesselEddy,
    GapInductance,
    Inductance,
    LossyInductance,
    Motional,
    Resistance,
    RingLadder,
    UniformRings,
)
from .physics import BUILTIN
from .term import BANDS, INDEX, Stage, Term, resolve_spec

__all__ = ["TERMS", "AUGMENTATIONS", "BASE_MODELS", "MODEL_NAMES", "make_term", "term_from_dict",
           "catalogue_entries", "register_term", "unregister_term", "param_spec", "augmentations_in_band"]

#: every term class by its serialised id, in registration order (:func:`register_term`)
TERMS: dict[str, type[Term]] = {}

#: the paper's six models by their coil terms; every model starts with motional + R0
BASE_MODELS: dict[str, tuple[str, ...]] = {
    "I": ("inductance",),
    "II": ("lossy_inductance",),
    "III": ("bessel_eddy",),
    "UD": ("gap_inductance", "bessel_eddy"),
    "NL": ("ring_ladder",),
    "UL": ("uniform_rings",),
}
MODEL_NAMES: tuple[str, ...] = tuple(BASE_MODELS)

_ID = re.compile(r"^[a-z][a-z0-9_]*$")
_PRIORS = typing.get_args(Prior)
_NOISE = noise_param_set("student", None, "correlated").names
_BUILTIN_IDS: set[str] = set()


class _Augmentations(Sequence[str]):
    """The ids of the registered augmentations (the catalogue and any registered at run time), in
    registration order; a live view, so that a term registered later is seen by every importer."""

    def __getitem__(self, i):
        return self._ids()[i]

    def __len__(self) -> int:
        return len(self._ids())

    def __iter__(self) -> Iterator[str]:
        return iter(self._ids())

    def __contains__(self, term_id) -> bool:
        cls = TERMS.get(term_id)
        return cls is not None and cls.augmentation

    def __repr__(self) -> str:
        return repr(self._ids())

    @staticmethod
    def _ids() -> tuple[str, ...]:
        return tuple(i for i, c in TERMS.items() if c.augmentation)


#: the physics catalogue that a model spec may add to a base model (``UD+winding_capacitance``)
AUGMENTATIONS: Sequence[str] = _Augmentations()


def _problems(cls) -> list[str]:
    """What keeps ``cls`` from being a term the package can use (empty when nothing)."""
    if not (inspect.isclass(cls) and issubclass(cls, Term)):
        return [f"{cls!r} is not a subclass of bayes_emt.models.Term"]
    if not (is_dataclass(cls) and cls.__dataclass_params__.frozen):
        return ["it must be a frozen dataclass (@dataclass(frozen=True))"]
    out = []
    if not (isinstance(cls.id, str) and _ID.match(cls.id)):
        out.append(f"its id {cls.id!r} must be lower-case letters, digits and '_' (typed in model specs)")
    elif cls.id in TERMS and TERMS[cls.id] is not cls:
        out.append(f"its id {cls.id!r} is taken by {TERMS[cls.id].__module__}.{TERMS[cls.id].__qualname__}")
    if cls.stage not in typing.get_args(Stage):
        out.append(f"its stage {cls.stage!r} is not one of {typing.get_args(Stage)}")
    if cls.evaluate is Term.evaluate:
        out.append("it does not define evaluate(s, v, other)")
    if not isinstance(cls.needs, tuple) or not all(isinstance(n, str) for n in cls.needs):
        out.append(f"its needs {cls.needs!r} must be a tuple of parameter names")
    if not cls.parameters or not all(isinstance(p, ParamSpec) for p in cls.parameters):
        out.append("it declares no parameters: set parameters = (ParamSpec(...), ...)")
        return out
    names = [p.name for p in cls.parameters]
    if len(set(names)) != len(names):
        out.append(f"it declares a parameter twice: {names}")
    for p in cls.parameters:
        if not isinstance(p.prior, _PRIORS):
            out.append(f"parameter {p.name!r}: its prior {p.prior!r} is not a proper prior of "
                       f"bayes_emt.params ({', '.join(t.__name__ for t in _PRIORS)})")
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*(\{j\}[A-Za-z0-9_]*)?", p.name):
            out.append(f"parameter {p.name!r}: a name is a letter, then letters, digits, '_' (and {INDEX} "
                       "for an indexed one)")
        if p.name in _NOISE:
            out.append(f"parameter {p.name!r} is a noise parameter's name")
        if not p.unit:
            out.append(f"parameter {p.name!r} has no unit (SI; '1' when dimensionless)")
    for other_id, other in TERMS.items():
        if other is cls:
            continue
        for p in cls.parameters:
            theirs = resolve_spec(other.parameters, p.name)
            if theirs is not None and theirs != p:
                out.append(f"parameter {p.name!r} is declared differently by term {other_id!r}: a name has "
                           "one spec and prior in every model (evidences stay comparable)")
    if cls.augmentation:
        if cls.stage == "motional":
            out.append("an augmentation cannot be the motional branch (a model has exactly one)")
        if cls.band not in BANDS:
            out.append(f"its band class {cls.band!r} is not one of {BANDS} (discovery never proposes it)")
        if cls.start is Term.start:
            out.append("it does not define start(ctx) (the augmented fit's multi-start)")
        for what in ("description", "signature", "physics"):
            if not (isinstance(getattr(cls, what), str) and getattr(cls, what)):
                out.append(f"it has no {what} (reports and discovery say it)")
    elif cls.band:
        out.append(f"a base term has no band class (got {cls.band!r}); band is for augmentations")
    if out:
        return out
    try:
        term = cls.make()
        record = json.loads(json.dumps(term.to_dict()))
        again = cls.make(**{k: v for k, v in record.items() if k != "id"})
    except Exception as exc:  # noqa: BLE001 - any failure here is the class's, said in one line
        return [f"make() and its serialised form do not round-trip: {type(exc).__name__}: {exc}"]
    if again != term:
        out.append("make(**to_dict()) does not rebuild the term")
    for p in term.params:
        if resolve_spec(cls.parameters, p.name) != p:
            out.append(f"default_params() gives {p.name!r} a spec other than the declared one")
    return out


def register_term(cls: type[Term]) -> type[Term]:
    """Register a term class (usable as a decorator) after checking it: a unique lower-case id, a
    known stage, ``evaluate``, its parameters declared with proper priors (a name shared with another
    term must have the same spec), a JSON-serialisable configuration that rebuilds it, and for an
    augmentation its band class (:data:`~bayes_emt.models.term.BANDS`), ``start``, description and
    signature. Raises ``ValueError`` listing every problem. Registering the same class again is a
    no-op."""
    problems = _problems(cls)
    if problems:
        name = getattr(cls, "__qualname__", repr(cls))
        raise ValueError(f"cannot register term {name}: " + "; ".join(problems))
    TERMS[cls.id] = cls
    return cls


def unregister_term(term_id: str) -> None:
    """Remove a term registered at run time (the package's own terms stay); unknown ids raise."""
    if term_id in _BUILTIN_IDS:
        raise ValueError(f"term {term_id!r} is one of the package's own and cannot be unregistered")
    if term_id not in TERMS:
        raise KeyError(f"no registered term {term_id!r}")
    del TERMS[term_id]


for _cls in (Motional, Resistance, Inductance, GapInductance, LossyInductance, BesselEddy, RingLadder,
             UniformRings, *BUILTIN):
    register_term(_cls)
_BUILTIN_IDS.update(TERMS)


def augmentations_in_band(band: str) -> tuple[str, ...]:
    """The registered augmentations of band class ``band`` (one of
    :data:`~bayes_emt.models.term.BANDS`), in registration order."""
    if band not in BANDS:
        raise ValueError(f"unknown band class {band!r}; choose one of {BANDS}")
    return tuple(i for i, c in TERMS.items() if c.augmentation and c.band == band)


def param_spec(name: str) -> ParamSpec:
    """The spec (unit, label, proper prior, description) of parameter ``name`` as the registered term
    declaring it has it (``P3``, ``R3`` resolve to the ring entries; ``R0`` is the coil's DC
    resistance). Raises ``KeyError`` when no registered term declares ``name``."""
    for cls in TERMS.values():
        found = resolve_spec(cls.parameters, name)
        if found is not None:
            return found
    raise KeyError(f"no registered term declares parameter {name!r}")


def make_term(term_id: str, **config) -> Term:
    """The term ``term_id`` with its catalogue priors; unknown ids raise naming the catalogue."""
    try:
        cls = TERMS[term_id]
    except KeyError:
        base = ", ".join(sorted(set(TERMS) - set(AUGMENTATIONS)))
        raise ValueError(f"unknown physics term {term_id!r}; the catalogue has "
                         f"{', '.join(AUGMENTATIONS)} (and the base terms {base}); a term defined "
                         "outside the package is registered first (bayes_emt.models.register_term)") from None
    return cls.make(**config)


def term_from_dict(d: Mapping) -> Term:
    """Rebuild a term from :meth:`Term.to_dict` (priors default; the model restores stored ones)."""
    if not isinstance(d, Mapping) or "id" not in d:
        raise ValueError(f"a term record needs an 'id', got {d!r}")
    config = {k: v for k, v in d.items() if k != "id"}
    try:
        return make_term(str(d["id"]), **config)
    except TypeError as exc:
        raise ValueError(f"term {d['id']!r}: bad configuration {sorted(config)} ({exc})") from None


def catalogue_entries() -> list[dict]:
    """Every augmentation's catalogue entry (id, physics, description, signature, parameters)."""
    return [TERMS[i].make().describe() for i in AUGMENTATIONS]
