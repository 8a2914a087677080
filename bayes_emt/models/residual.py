"""The relative residual of a model against a measurement: the one definition every fit, check,
locator and plot uses.

``r(ω) = (Y_model(jω) − Y(jω)) / |Y(jω)|`` [1] (for a magnitude-only recording,
:attr:`Measurement.phase_absent`, ``r(ω) = ln(|Y_model| / |Y|)``, real: the relative error of
the magnitude to first order, the phase being unknown), with the model bound to the measurement's frequency
grid first (:meth:`~bayes_emt.models.model.Model.bind`: a term whose value depends on the sweep's
order, such as a thermal drift along it, needs the grid), for one parameter vector ``(k,)`` or a
stack ``(..., k)`` (then ``(..., F)``).
"""

from __future__ import annotations

import numpy as np

from ..measurement import Measurement
from .model import Model

__all__ = ["relative_residual", "rms_relative_residual"]


def relative_residual(model: Model, theta, meas: Measurement) -> np.ndarray:
    """``(Y_model − Y)/|Y|`` at the measurement's frequencies (module docstring)."""
    y = model.bind(meas.omega).admittance(meas.omega, np.asarray(theta, float))
    if meas.phase_absent:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(np.abs(y) / np.abs(meas.Y)).astype(complex)
    return (y - meas.Y) / np.abs(meas.Y)


def rms_relative_residual(model: Model, theta, meas: Measurement) -> np.ndarray | float:
    """``sqrt(mean |r|²)`` over the frequencies (per parameter set for a stack)."""
    r = relative_residual(model, theta, meas)
    out = np.sqrt(np.mean(np.abs(r) ** 2, axis=-1))
    return float(out) if np.ndim(out) == 0 else out
