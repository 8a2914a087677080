"""The registry of terms by id, and of the paper's base models by the coil terms they use.

Everything that turns a name into behaviour lives here (and in :mod:`bayes_emt.models.spec`), so
that no other layer dispatches on a model's name: adding a term or a coil model touches
``models/`` alone.
"""

from __future__ import annotations

from collections.abc import Mapping

from .augmentations import (
    LR2,
    EnclosurePort,
    LeadImpedance,
    MeasurementArtifact,
    SecondResonance,
    SemiInductance,
    SuspensionCreep,
    ThermalDrift,
    WindingCapacitance,
)
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
from .term import Term

__all__ = ["TERMS", "AUGMENTATIONS", "BASE_MODELS", "MODEL_NAMES", "make_term", "term_from_dict",
           "catalogue_entries"]

#: every term class by its serialised id
TERMS: dict[str, type[Term]] = {cls.id: cls for cls in (
    Motional, Resistance, Inductance, GapInductance, LossyInductance, BesselEddy, RingLadder, UniformRings,
    WindingCapacitance, SecondResonance, EnclosurePort, SuspensionCreep, ThermalDrift, SemiInductance, LR2,
    LeadImpedance, MeasurementArtifact)}

#: the catalogue of SPEC §7 that a model spec may add to a base model (``UD+winding_capacitance``)
AUGMENTATIONS: tuple[str, ...] = tuple(i for i, c in TERMS.items() if c.augmentation)

#: the paper's six models (SPEC §2) by their coil terms; every model starts with motional + R0
BASE_MODELS: dict[str, tuple[str, ...]] = {
    "I": ("inductance",),
    "II": ("lossy_inductance",),
    "III": ("bessel_eddy",),
    "UD": ("gap_inductance", "bessel_eddy"),
    "NL": ("ring_ladder",),
    "UL": ("uniform_rings",),
}
MODEL_NAMES: tuple[str, ...] = tuple(BASE_MODELS)


def make_term(term_id: str, **config) -> Term:
    """The term ``term_id`` with its catalogue priors; unknown ids raise naming the catalogue."""
    try:
        cls = TERMS[term_id]
    except KeyError:
        base = ", ".join(sorted(set(TERMS) - set(AUGMENTATIONS)))
        raise ValueError(f"unknown physics term {term_id!r}; the catalogue has "
                         f"{', '.join(AUGMENTATIONS)} (and the base terms {base})") from None
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
