"""Quantities derived from a model's parameters, defined once: the mechanical resonance in Hz, the
mechanical quality factor, the coil's low-frequency inductance.

Each entry of :data:`DERIVED` is ``name → (unit, description, f(model, theta (..., k)) → (...))``,
vectorised over parameter sets; :func:`derived_values` evaluates them for one vector.
``fs`` [Hz] and ``Qms`` [1] follow the Thiele–Small convention everywhere they are named so
(tables, JSON, the report): :func:`mechanical_resonance`'s resonance of the mechanical impedance
with every stiffness term (``Im Zm(jωs) = 0``) and all its loss at ωs (the creep's as well as the
viscous), the convention of the tools that fit LOG creep (:mod:`bayes_emt.thiele_small.relations`
says whose). Without a frequency-dependent stiffness they equal ``ω0/(2π)`` and ``1/(2ζ)``
exactly; with one, ``ω0`` and ``ζ`` are only the model's parameters and are shown under those
names, never as fs or Qms.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .model import Model

__all__ = ["DERIVED", "derived_values", "coil_inductance_lf", "mechanical_resonance"]


def coil_inductance_lf(model: Model, theta: np.ndarray) -> np.ndarray:
    """``lim_{ω→0} Im Zc(jω)/ω`` [H], evaluated at ω = 1e-6 rad/s (Zc = jωL + O(ω²) there)."""
    w = 1e-6
    return model.coil_impedance(np.array([w]), theta)[..., 0].imag / w


#: name → (unit, description, f(model, theta (..., k_model)) → (...)); NaN where the model lacks
#: the parameter the quantity needs
DERIVED: dict[str, tuple[str, str, Callable[[Model, np.ndarray], np.ndarray]]] = {
    "fs": ("Hz", "mechanical resonance: where the mechanical reactance vanishes (Thiele-Small fs)",
           lambda model, theta: _resonance(model, theta, 0)),
    "Qms": ("1", "mechanical quality factor at fs, all mechanical loss included (Thiele-Small Qms)",
            lambda model, theta: _resonance(model, theta, 1)),
    "L_lf": ("H", "low-frequency coil inductance, lim Im Zc(jw)/w as w -> 0", coil_inductance_lf),
}


def _resonance(model: Model, theta: np.ndarray, which: int) -> np.ndarray:
    """fs [Hz] (``which`` 0) or Qms (1) of :func:`mechanical_resonance` for ``theta (..., k)``; NaN
    when the model has no mechanical resonance (no ζ, ω0)."""
    theta = np.asarray(theta, float)
    if not {"zeta", "omega0"} <= set(model.names):
        return np.full(theta.shape[:-1], np.nan)
    flat = theta.reshape(-1, theta.shape[-1])
    out = mechanical_resonance(model, flat)
    val = out[0] / (2 * math.pi) if which == 0 else out[1]
    return np.asarray(val, float).reshape(theta.shape[:-1])


def derived_values(model: Model, theta) -> dict[str, float]:
    """:data:`DERIVED` for one parameter vector ``theta (k,)`` [SI, units in :data:`DERIVED`]."""
    th = np.asarray(theta, float)[None, :]
    return {k: float(np.asarray(fn(model, th)).reshape(-1)[0]) for k, (_, _, fn) in DERIVED.items()}


def _stiffness_factor(model: Model, theta: np.ndarray, omega: np.ndarray) -> np.ndarray | None:
    """``κ(jω)`` (P,) of the model's stiffness terms at one ``ω`` per row (None: no such term)."""
    terms = [(t, sl) for t, sl in zip(model.terms, model._slices, strict=True)
             if t.device and t.stage == "stiffness"]
    if not terms:
        return None
    other = {}
    for t, _ in terms:
        for n in t.needs:
            i = model.params.index(n)
            other[n] = theta[:, i : i + 1]
    s = (1j * omega)[:, None]
    kappa = np.ones((theta.shape[0], 1), complex)
    for t, sl in terms:
        kappa = kappa * t.evaluate(s, theta[:, sl], other)
    return kappa[:, 0]


def mechanical_resonance(model: Model, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(ωs [rad/s], Qms, Qms_viscous)`` per row of ``theta (n, k)`` (module docstring)."""
    theta = np.atleast_2d(np.asarray(theta, float))
    zeta, w0 = (theta[:, model.params.index(n)] for n in ("zeta", "omega0"))
    if _stiffness_factor(model, theta, w0) is None:
        q = 1.0 / (2.0 * zeta)
        return w0.copy(), q, q

    def g(w):
        return w * w - w0 * w0 * _stiffness_factor(model, theta, w).real

    w = w0.copy()
    for _ in range(60):  # Newton with a relative central-difference slope
        h = 1e-6 * w
        d = (g(w + h) - g(w - h)) / (2 * h)
        step = np.where(d > 0, g(w) / np.where(d > 0, d, 1.0), 0.0)
        w_new = np.clip(w - step, 0.3 * w0, 3.0 * w0)
        if np.all(np.abs(w_new - w) <= 1e-13 * w0):
            w = w_new
            break
        w = w_new
    kap = _stiffness_factor(model, theta, w)
    re_zm = 2 * zeta * w0 + w0 * w0 * kap.imag / w  # Re(Zm/Mms) [1/s]
    return w, w / re_zm, w / (2 * zeta * w0)
