"""Which catalogue physics could explain a located band, and the eddy-current escalation.

A term is a candidate for a band when its signature acts there (relative to the mechanical
resonance ``ω_r`` the data shows), by the band class every registered augmentation declares
(:data:`~bayes_emt.models.BANDS`, :func:`~bayes_emt.models.augmentations_in_band`):

* ``coil``: terms of the coil and the terminals act where the coil dominates: a band reaching
  above ``3 ω_r``;
* ``mechanical``: terms of the mechanics act around and below the resonance: a band reaching below
  ``3 ω_r``;
* ``anywhere``: a second mechanical mode or an instrument step can sit anywhere; a drift along the
  sweep order shows in the real part wherever the base fit cannot absorb it.

A term already in the model is not proposed again. A structure beyond one driver (a term that
declares :attr:`~bayes_emt.models.term.Term.structural`, a second driver in parallel) is proposed only
when the caller says the fit shows its signature (:func:`.sanity.structure_signature`): it is the
costliest fit of a round and no single driver needs it. The eddy-current escalation
(:data:`~bayes_emt.models.EDDY_PHYSICS`, band class :data:`~bayes_emt.models.EDDY_BAND`) is not a
term but a change of the coil model up the ladder ``I → II → III/UD → NL(n)`` (:func:`escalations`),
the ring count of NL chosen by evidence among the candidates. No physics is named here: a term
registered at run time (:func:`~bayes_emt.models.register_term`) is proposed like the catalogue's.
"""

from __future__ import annotations

from ..models import BANDS, EDDY_BAND, EDDY_PHYSICS, TERMS, Model, augmentations_in_band, eddy_escalations
from .locate import Band

__all__ = ["candidate_physics", "escalations", "RING_COUNTS", "physics_in_band"]

#: NL ring counts the escalation tries in order, stopping when one more ring loses evidence or after
#: two rungs in a row without a finite evidence (:data:`.name.NO_EVIDENCE_RUNGS`)
RING_COUNTS: tuple[int, ...] = (2, 3, 4, 5, 6, 7)


def escalations(model: Model) -> list[Model]:
    """The eddy-current escalations of ``model`` (:func:`~bayes_emt.models.eddy_escalations`) with
    NL at each of :data:`RING_COUNTS`."""
    return eddy_escalations(model, RING_COUNTS)


def physics_in_band(band_class: str) -> tuple[str, ...]:
    """The physics ids of band class ``band_class``: the registered augmentations declaring it, in
    registration order, then the eddy-current escalation when it is of that class."""
    return augmentations_in_band(band_class) + ((EDDY_PHYSICS,) if band_class == EDDY_BAND else ())


def candidate_physics(band: Band, model: Model, omega_r: float | None, *,
                      structure: bool = False) -> list[str]:
    """Physics ids of the catalogue whose signature can act in ``band``, for a model already holding
    ``model``'s terms (module docstring); ``omega_r`` [rad/s] the resonance (``None``: every id).
    The eddy-current escalation comes last (NL fits are the slowest: a time budget cuts it rather
    than the cheap catalogue terms), and only when ``model``'s coil model has a rung above it and
    ``model`` holds no lossy-coil augmentation (a ``coil`` term already models the coil's loss).
    ``structure``: the fit shows the signature of more than one driver, so the structural terms are
    proposed too (module docstring)."""
    present = {t.id for t in model.augmentations}
    high = omega_r is None or band.hi > 3.0 * omega_r
    low = omega_r is None or band.lo < 3.0 * omega_r
    acts = {"coil": high, "mechanical": low, "anywhere": True}
    out = [p for b in BANDS if acts[b] for p in physics_in_band(b)]
    # a lossy-coil augmentation (a ``coil`` term: the coil's own eddy-current loss, e.g. a
    # semi-inductance) already models what the escalation would: NL rings on top of it are flexible
    # capacity, not physics, and the slowest fits of a round
    lossy = any(t.coil for t in model.augmentations)
    out = [p for p in out if p != EDDY_PHYSICS] + [
        p for p in out if p == EDDY_PHYSICS and not lossy and escalations(model)]
    return [p for p in out if p not in present
            and (structure or not getattr(TERMS.get(p), "structural", False))]
