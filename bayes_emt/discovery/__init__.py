"""Discrepancy discovery: where a model and a recording differ, what physics is missing.

:mod:`.locate` finds bands of significant, structured mismatch (a scan calibrated by simulation
from the fitted model, family-wise false-alarm rate controlled); :mod:`.candidates` says which
catalogue physics could act there, including the eddy-current escalation of the coil
model; :mod:`.name` fits them, ranks them by evidence and by how much they whiten the band;
:mod:`.shape` describes what nothing explains; :mod:`.diagnose` repeats until no significant
mismatch remains and returns a frozen :class:`Diagnosis`.
"""

from .candidates import candidate_physics, escalations
from .diagnose import Diagnosis, Finding, diagnose, preferred_base_model
from .locate import Band, Location, locate_mismatch
from .name import Candidate, rank_candidates
from .shape import residual_shape

__all__ = [
    "candidate_physics",
    "escalations",
    "Diagnosis",
    "Finding",
    "diagnose",
    "preferred_base_model",
    "Band",
    "Location",
    "locate_mismatch",
    "Candidate",
    "rank_candidates",
    "residual_shape",
]
