"""Sanity of a final model: a fit that is broken physics is not an answer.

A search that adds terms while the evidence rises can end on a fit whose values are not a driver: a
damping ratio pressed against its prior's edge (ζ = 10⁻⁵, Qms = 50 000), the driver's resonance
collapsed onto another mode's (ω0 190.64 against a port tuning ωb 190.90 rad/s), Thiele–Small values
no moving-coil transducer has. The likelihood rises because the pieces trade places, not because
the physics is right. :func:`defects` names each such defect of a fit:

* **at a prior edge**: a plant parameter (``R0``, ``zeta``, ``omega0``, ``phi``) or a parameter a
  finding added within :data:`AT_EDGE` of its prior's range (sampling space) from a bound;
* **merged resonance**: two resonance frequencies of the model (``omega0`` and any mode or port
  term's ``omega…``) within a factor :data:`MERGE_RATIO` of each other: two modes that close cannot be
  told apart by an impedance curve, one of them has taken the other's place;
* **outside physical ranges**: the Thiele–Small mechanical and electrical quality factors outside
  :data:`QMS_RANGE` and :data:`QES_RANGE` (moving-coil drivers and shakers span Qms 0.5–30 and Qes
  0.1–10 in the published data sheets; the ranges are a factor 4-10 wider).

:func:`back_off` then takes the best of the search's accepted models (in the order they were reached)
without a defect, and says in one line what it refused and why.

**Structures beyond one driver** (:func:`structure_note`): two drivers wired in parallel (or in
series) or a driver with a passive radiator put two mechanical resonances where a lumped driver has
one. When the refused model's defect is the driver's resonance merged with another mode or its
damping at the prior's edge, or when the final fit still leaves a broadband mismatch of more than
:data:`BROAD_RMS` rms (the real recordings of single drivers end at 0.6-2.2 %), the diagnosis names
that possibility and what tells it apart (each driver measured alone). The diagnosis then also tries
the structural terms of the catalogue (a second driver in parallel, ``parallel_driver``) on the model it
kept, and the evidence decides (:func:`structure_reason` is the trigger).
"""

from __future__ import annotations

import math

import numpy as np

from ..estimation.results import FitResult
from ..models.derived import mechanical_resonance

__all__ = ["defects", "back_off", "structure_note", "structure_reason", "BROAD_RMS", "AT_EDGE",
           "MERGE_RATIO", "QMS_RANGE", "QES_RANGE", "PLANT"]

#: within this fraction of its prior's range (sampling space) of a bound, a parameter sits at the edge
AT_EDGE = 1e-3
#: two resonance frequencies closer than this factor are merged
MERGE_RATIO = 1.02
#: physical ranges of the Thiele–Small quality factors (module docstring)
QMS_RANGE = (0.1, 200.0)
QES_RANGE = (0.02, 100.0)
#: the plant's own parameters, checked in every model
PLANT = ("R0", "zeta", "omega0", "phi")


def _at_edge(fit: FitResult, names) -> list[str]:
    m = fit.model
    z = m.params.to_z(np.asarray(fit.theta, float))
    lo, hi = m.params.bounds_z()
    out = []
    for n in names:
        if n not in m.names:
            continue
        i = m.names.index(n)
        if not (math.isfinite(lo[i]) and math.isfinite(hi[i])):
            continue
        tol = AT_EDGE * (hi[i] - lo[i])
        if z[i] - lo[i] < tol or hi[i] - z[i] < tol:
            out.append(f"{n} = {fit.theta[i]:.4g} at the edge of its prior")
    return out


def _merged(fit: FitResult) -> list[str]:
    v = fit.model.as_dict(fit.theta)
    steps = {t.step_at for t in fit.model.augmentations if t.step_at}  # a step's frequency is no mode
    res = [(n, x) for n, x in v.items() if n.startswith("omega") and n not in steps and x > 0]
    out = []
    for i, (a, wa) in enumerate(res):
        for b, wb in res[i + 1:]:
            if max(wa, wb) / min(wa, wb) < MERGE_RATIO:
                fa, fb = wa / (2 * math.pi), wb / (2 * math.pi)
                out.append(f"the resonances {a} {fa:.4g} Hz and {b} {fb:.4g} Hz merged")
    return out


def _ranges(fit: FitResult) -> list[str]:
    m = fit.model
    if not all(n in m.names for n in PLANT):
        return []
    v = m.as_dict(fit.theta)
    ws, qms, _ = mechanical_resonance(m, np.asarray(fit.theta, float)[None, :])
    qms = float(qms[0])
    qes = float(ws[0]) * v["R0"] / v["phi"] ** 2
    out = []
    if not QMS_RANGE[0] <= qms <= QMS_RANGE[1]:
        out.append(f"Qms {qms:.4g} outside {QMS_RANGE[0]:g}-{QMS_RANGE[1]:g}")
    if not QES_RANGE[0] <= qes <= QES_RANGE[1]:
        out.append(f"Qes {qes:.4g} outside {QES_RANGE[0]:g}-{QES_RANGE[1]:g}")
    return out


def defects(fit: FitResult, added=()) -> list[str]:
    """The defects of ``fit`` (module docstring) in words; ``added`` the parameters the findings added
    (checked for the prior edge beside :data:`PLANT`)."""
    return _at_edge(fit, [*PLANT, *added]) + _merged(fit) + _ranges(fit)


def back_off(history) -> tuple[int | None, list[str]]:
    """``history``: ``[(fit, added parameter names), ...]`` of the start and each accepted model in the
    order reached. Returns the index of the last one without a defect (``None`` when every one has a
    defect) and the defects of the last (``[]`` when it has none: no back-off)."""
    last = defects(*history[-1])
    if not last:
        return len(history) - 1, []
    for i in range(len(history) - 2, -1, -1):
        if not defects(*history[i]):
            return i, last
    return None, last


#: a final rms relative residual above this, with a broadband unexplained band, names the structures
#: beyond one driver as a possibility
BROAD_RMS = 0.05


def structure_reason(refused: str | bool, unexplained, fit: FitResult) -> str:
    """Why the fit points to more than one driver (module docstring), ``""`` when nothing does:
    ``refused`` the refusal line of the final model (or ``False``), ``unexplained`` the records of the
    bands left (their ``description``), ``fit`` the final fit."""
    if isinstance(refused, str) and ("merged" in refused or "zeta =" in refused):
        return "the refused model put the driver's resonance onto another mode"
    if fit.rms_rel_residual > BROAD_RMS and any("broadband" in u.get("description", "")
                                                for u in unexplained):
        return f"a broadband mismatch of {100 * fit.rms_rel_residual:.2g} % rms remains"
    return ""


def structure_note(refused: str | bool, unexplained, fit: FitResult) -> str:
    """The possibility of more than one driver (module docstring), ``""`` when nothing points to it."""
    why = structure_reason(refused, unexplained, fit)
    if not why:
        return ""
    return (f"two drivers wired in parallel (or in series), or a driver with a passive radiator, are a "
            f"possibility: {why}, and one lumped driver has a single mechanical resonance; measure each "
            "driver alone (the other disconnected) and diagnose each recording")
