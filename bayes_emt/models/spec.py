"""Model specs: the paper's six models by name, augmented ones as ``BASE+term+term`` (the physics catalogue),
and models rebuilt from their serialised form.

``UD+second_resonance+suspension_creep`` is model UD with two catalogue terms; ``NL(7)`` or
``NL`` with ``rings=7`` is NL with seven rings. Every command and the Python API take a spec
wherever a model is named, and every saved result stores :meth:`Model.to_dict`, from which
:func:`model_from_dict` rebuilds the model (terms, configuration and priors), never from a name.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from ..params import ParamSet, ParamSpec, prior_from_dict
from .model import Model
from .registry import AUGMENTATIONS, BASE_MODELS, MODEL_NAMES, make_term, term_from_dict

__all__ = ["build_model", "parse_model_spec", "model_from_dict", "eddy_escalations", "EDDY_LADDER",
           "EDDY_PHYSICS", "EDDY_BAND", "DEFAULT_N_TURNS", "DEFAULT_RINGS"]

#: the eddy-current escalation of the coil model, lowest rung first
EDDY_LADDER: tuple[str, ...] = ("I", "II", "III", "UD", "NL")
#: the physics id of that escalation (not a term: a change of the coil model up :data:`EDDY_LADDER`)
#: and its band class (:data:`~bayes_emt.models.term.BANDS`): the coil's
EDDY_PHYSICS = "eddy_current"
EDDY_BAND = "coil"

DEFAULT_N_TURNS = 480.0  # the source paper's coil
DEFAULT_RINGS = 5  # the source paper's NL choice
_RINGED = ("ring_ladder", "uniform_rings")
_BASE = re.compile(r"^([A-Za-z]+)(?:\((\d+)\))?$")


def build_model(name: str, *, rings: int | None = None, n_turns: float = DEFAULT_N_TURNS) -> Model:
    """One of the paper's six models (see Physics and conventions), ``I, II, III, UD, NL, UL``, or a spec with
    augmentations (:func:`parse_model_spec`).

    ``rings`` applies to NL and UL only (default 5); ``n_turns`` is the coil's turn count N.
    """
    return parse_model_spec(name, rings=rings, n_turns=n_turns)


def _base_terms(key: str, rings, n_turns):
    if key not in BASE_MODELS:
        raise ValueError(f"unknown model {key!r}; choose one of {', '.join(MODEL_NAMES)} "
                         f"(optionally + terms of {', '.join(AUGMENTATIONS)})")
    ringed = any(t in _RINGED for t in BASE_MODELS[key])
    if ringed:
        rings = DEFAULT_RINGS if rings is None else rings
        if isinstance(rings, bool) or int(rings) != rings or rings < 1:
            raise ValueError(f"rings must be a positive integer, got {rings!r}")
    elif rings is not None:
        raise ValueError(f"--rings applies to NL and UL only, not to model {key}")
    terms = [make_term("motional"), make_term("resistance")]
    for tid in BASE_MODELS[key]:
        terms.append(make_term(tid, n_rings=int(rings), n_turns=float(n_turns)) if tid in _RINGED
                     else make_term(tid))
    return terms


def parse_model_spec(spec: str, *, rings: int | None = None, n_turns: float = DEFAULT_N_TURNS) -> Model:
    """The model a spec names: ``BASE[(n)][+term...]`` (module docstring).

    Raises ``ValueError`` naming the unknown part and what exists.
    """
    text = str(spec).strip()
    if not text:
        raise ValueError("empty model spec; choose one of " + ", ".join(MODEL_NAMES))
    parts = [p.strip() for p in text.split("+")]
    m = _BASE.match(parts[0])
    if not m:
        raise ValueError(f"model spec {spec!r}: {parts[0]!r} is not a base model "
                         f"({', '.join(MODEL_NAMES)}, e.g. NL(5))")
    key = m.group(1).upper()
    if m.group(2) is not None:
        if rings is not None and int(m.group(2)) != rings:
            raise ValueError(f"model spec {spec!r} says {m.group(2)} rings but rings={rings} was given")
        rings = int(m.group(2))
    if not (n_turns == n_turns and n_turns > 0 and n_turns != float("inf")):
        raise ValueError(f"n_turns must be positive, got {n_turns!r}")
    terms = _base_terms(key, rings, n_turns)
    seen = set()
    for p in parts[1:]:
        tid = p.lower()
        if tid not in AUGMENTATIONS:
            raise ValueError(f"model spec {spec!r}: unknown physics term {p!r}; the catalogue has "
                             f"{', '.join(AUGMENTATIONS)}")
        if tid in seen:
            raise ValueError(f"model spec {spec!r}: term {tid!r} appears twice")
        seen.add(tid)
        terms.append(make_term(tid))
    return Model(tuple(terms))


def model_from_dict(d: Mapping, *, where: str = "model") -> Model:
    """Rebuild a model from :meth:`Model.to_dict` (or an older record with only ``model``, ``rings``,
    ``n_turns``): its terms with their configuration, then the stored priors."""
    if not isinstance(d, Mapping):
        raise ValueError(f"{where}: expected a model record, got {type(d).__name__}")
    if d.get("terms") and isinstance(d["terms"][0], Mapping):
        try:
            model = Model(tuple(term_from_dict(t) for t in d["terms"]))
        except (ValueError, TypeError) as exc:
            raise ValueError(f"{where}: {exc}") from None
    else:
        spec = d.get("spec", d.get("model"))
        if spec is None:
            raise ValueError(f"{where}: a model record needs 'terms' or 'spec'")
        model = parse_model_spec(str(spec), rings=d.get("rings"),
                                 n_turns=float(d.get("n_turns") or DEFAULT_N_TURNS))
    stored = d.get("parameters")
    if isinstance(stored, list) and stored and isinstance(stored[0], Mapping):
        specs = ParamSet(ParamSpec(p["name"], p["unit"], p["label"], prior_from_dict(p["prior"]),
                                   p.get("description", "")) for p in stored)
        if specs.names != model.names:
            raise ValueError(f"{where}: stored parameters {list(specs.names)} do not match the terms' "
                             f"{list(model.names)}")
        model = model.with_priors({s.name: s.prior for s in specs}, where=where)
    return model


def eddy_escalations(model: Model, ring_counts=(2, 3, 4, 5, 6, 7)) -> list[Model]:
    """The models up the eddy-current ladder (:data:`EDDY_LADDER`) from ``model``'s coil model, its
    augmentations kept, in order; NL at each of ``ring_counts`` (above the current count when
    ``model`` is NL already). Empty when the coil model is not on the ladder."""
    if model.base not in EDDY_LADDER:
        return []
    extra = "".join("+" + t.id for t in model.augmentations)
    out = []
    for name in EDDY_LADDER[EDDY_LADDER.index(model.base) + 1:]:
        if name == "NL":
            out += [parse_model_spec(f"NL({n}){extra}") for n in ring_counts]
        else:
            out.append(parse_model_spec(name + extra))
    if model.base == "NL" and model.rings is not None:
        out += [parse_model_spec(f"NL({n}){extra}") for n in ring_counts if n > model.rings]
    return out
