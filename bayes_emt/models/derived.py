"""Quantities derived from a model's parameters, defined once: the mechanical resonance in Hz, the
mechanical quality factor, the coil's low-frequency inductance.

Each entry of :data:`DERIVED` is ``name → (unit, description, f(model, theta (..., k)) → (...))``,
vectorised over parameter sets; :func:`derived_values` evaluates them for one vector.
``fs = ω0/(2π)`` [Hz] and ``Qms = 1/(2ζ)`` [1] are the plant's own resonance and damping (SPEC §1);
under a frequency-dependent compliance (suspension creep) they are the model's ω0 and ζ, not the
Thiele–Small definitions at the impedance maximum.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .model import Model

__all__ = ["DERIVED", "derived_values", "coil_inductance_lf"]


def coil_inductance_lf(model: Model, theta: np.ndarray) -> np.ndarray:
    """``lim_{ω→0} Im Zc(jω)/ω`` [H], evaluated at ω = 1e-6 rad/s (Zc = jωL + O(ω²) there)."""
    w = 1e-6
    return model.coil_impedance(np.array([w]), theta)[..., 0].imag / w


def _column(name: str, fn: Callable[[np.ndarray], np.ndarray]):
    def f(model: Model, theta: np.ndarray) -> np.ndarray:
        if name not in model.names:
            return np.full(np.shape(theta)[:-1], np.nan)
        return fn(np.asarray(theta, float)[..., model.names.index(name)])

    return f


#: name → (unit, description, f(model, theta (..., k_model)) → (...)); NaN where the model lacks
#: the parameter the quantity needs
DERIVED: dict[str, tuple[str, str, Callable[[Model, np.ndarray], np.ndarray]]] = {
    "fs": ("Hz", "mechanical resonance frequency omega0/(2 pi)",
           _column("omega0", lambda w: w / (2 * math.pi))),
    "Qms": ("1", "mechanical quality factor 1/(2 zeta)", _column("zeta", lambda z: 1.0 / (2.0 * z))),
    "L_lf": ("H", "low-frequency coil inductance, lim Im Zc(jw)/w as w -> 0", coil_inductance_lf),
}


def derived_values(model: Model, theta) -> dict[str, float]:
    """:data:`DERIVED` for one parameter vector ``theta (k,)`` [SI, units in :data:`DERIVED`]."""
    th = np.asarray(theta, float)[None, :]
    return {k: float(np.asarray(fn(model, th)).reshape(-1)[0]) for k, (_, _, fn) in DERIVED.items()}
