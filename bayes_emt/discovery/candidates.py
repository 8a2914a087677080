"""Which catalogue physics (SPEC §7) could explain a located band, and the eddy-current escalation.

A term is a candidate for a band when its signature acts there (relative to the mechanical
resonance ``ω_r`` the data shows):

* terms of the coil and the terminals (``eddy_current``, ``semi_inductance``, ``lr2``,
  ``winding_capacitance``, ``lead_impedance``) act where the coil dominates: a band reaching above
  ``3 ω_r``;
* terms of the mechanics (``suspension_creep``, ``enclosure_port``) act around and below the
  resonance: a band reaching below ``3 ω_r``;
* a second mechanical mode and an instrument step can sit anywhere; a drift along the sweep order
  (``thermal_drift``) shows in the real part wherever the base fit cannot absorb it.

A term already in the model is not proposed again. ``eddy_current`` is not a term but a change of
the coil model up the ladder ``I → II → III/UD → NL(n)`` (:func:`escalations`), the ring count of
NL chosen by evidence among the candidates.
"""

from __future__ import annotations

from ..models import AUGMENTATIONS, Model, eddy_escalations
from .locate import Band

__all__ = ["candidate_physics", "escalations", "RING_COUNTS", "COIL_PHYSICS", "MECHANICAL_PHYSICS"]

#: NL ring counts the escalation tries in order, stopping when one more ring loses evidence
RING_COUNTS: tuple[int, ...] = (2, 3, 4, 5, 6, 7)

COIL_PHYSICS = ("eddy_current", "semi_inductance", "lr2", "winding_capacitance", "lead_impedance")
MECHANICAL_PHYSICS = ("suspension_creep", "enclosure_port")
ANYWHERE = ("second_resonance", "measurement_artifact", "thermal_drift")


def escalations(model: Model) -> list[Model]:
    """The eddy-current escalations of ``model`` (:func:`~bayes_emt.models.eddy_escalations`) with
    NL at each of :data:`RING_COUNTS`."""
    return eddy_escalations(model, RING_COUNTS)


def candidate_physics(band: Band, model: Model, omega_r: float | None) -> list[str]:
    """Physics ids (SPEC §7) whose signature can act in ``band``, for a model already holding
    ``model``'s terms (module docstring); ``omega_r`` [rad/s] the resonance (``None``: every id)."""
    present = {t.id for t in model.augmentations}
    out = []
    high = omega_r is None or band.hi > 3.0 * omega_r
    low = omega_r is None or band.lo < 3.0 * omega_r
    if high:
        out += [p for p in COIL_PHYSICS if p != "eddy_current" or escalations(model)]
    if low:
        out += list(MECHANICAL_PHYSICS)
    out += list(ANYWHERE)
    # the eddy-current escalation refits the coil model up the ladder (NL fits are the slowest):
    # last, so that a time budget cuts it rather than the cheap catalogue terms
    out = [p for p in out if p != "eddy_current"] + [p for p in out if p == "eddy_current"]
    return [p for p in out if p not in present and (p == "eddy_current" or p in AUGMENTATIONS)]
