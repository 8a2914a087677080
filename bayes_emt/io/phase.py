"""Magnitude-only recordings: dropping the phase of a recording, and what |Z| alone identifies.

A magnitude-only :class:`~bayes_emt.measurement.Measurement` has ``meta["phase"] == "absent"``
(:attr:`~bayes_emt.measurement.Measurement.phase_absent`); its ``Y`` carries the minimum-phase
estimate of the phase from |Z| (:mod:`.minphase`) so that it stays complex for the start of a
fit, and every fit, residual and likelihood uses the magnitude alone
(:mod:`bayes_emt.inference.magnitude`).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..measurement import Measurement
from .minphase import minimum_phase_deg

__all__ = ["PHASE_ABSENT_NOTE", "drop_phase"]

#: what the outputs say of a |Z|-only recording
PHASE_ABSENT_NOTE = (
    "no phase: fitted on log|Z| alone. The coil models are minimum-phase one-ports, so |Z| fixes fs "
    "and Qms much as the phase does; Re, and Qes with it, trade off against the coil-loss terms (a "
    "lossy inductance with a small exponent acts as a resistance, which only the phase tells apart), "
    "Le and the coil-loss terms rest on the band's edges, and a delay or other non-minimum-phase "
    "effect of the setup cannot be seen; a measured Re (--re) restores Re and Qes")


def drop_phase(meas: Measurement, *, why: str = "--magnitude-only") -> Measurement:
    """``meas`` with its phase dropped: |Z| kept, the phase replaced by the minimum-phase estimate,
    ``meta["phase"] = "absent"``, and one note (also a warning) saying so and why. The rows a reader
    kept below the analyser's resolution (``meta["low_band"]``) lose their phase too, so that nothing
    downstream (the plateau's Re reading) reads a phase the magnitude-only result says it lacks."""
    if meas.phase_absent:
        return meas
    absz = np.abs(meas.Z)
    ph = np.deg2rad(minimum_phase_deg(meas.f_hz, absz))
    note = f"{meas.source}: {PHASE_ABSENT_NOTE} ({why})"
    warnings.warn(note, UserWarning, stacklevel=3)
    meta = {**dict(meas.meta), "phase": "absent", "representation": "magnitude",
            "notices": (*meas.meta.get("notices", ()), note)}
    low = meta.get("low_band")
    if isinstance(low, dict) and low.get("phase_deg") is not None:
        meta["low_band"] = {**low, "phase_deg": None}
    return Measurement(meas.omega, 1.0 / (absz * np.exp(1j * ph)), weights=meas.weights, meta=meta)
