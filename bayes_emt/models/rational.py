"""Rational forms of the rational coil models (I, II, NL, UL) for pole, state-space and Hankel
analyses: the Foster (modal) form and numerator/denominator polynomials of ``Ze = Zc + R0``."""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as P

from .model import Model
from .terms import ring_ladder_modes, uniform_rings

__all__ = ["foster_form", "rational_form"]


def foster_form(model: Model, theta):
    """``Ze = R0 + G s + Σ_k L_k s / (1 + τ_k s)`` for a rational model: ``(R0, G, L, tau)``.

    I: ``G = L0``, no sections; II: one section (``L0`` in parallel with ``Rμ``: ``τ = L0/Rμ``);
    NL/UL: the modal form of the ring ladder (:func:`~bayes_emt.models.terms.ring_ladder_modes`).
    """
    p = model.as_dict(theta)
    if model.name == "I":
        return p["R0"], p["L0"], np.zeros(0), np.zeros(0)
    if model.name == "II":
        return p["R0"], 0.0, np.array([p["L0"]]), np.array([p["L0"] / p["Rmu"]])
    n = model.rings
    if model.name == "UL":
        Pg, Pv, Rv = uniform_rings(p["Lg"], p["alpha"], p["beta"], n, model.n_turns)
    elif model.name == "NL":
        Pg = p["Pg"]
        Pv = np.array([p[f"P{j}"] for j in range(1, n + 1)])
        Rv = np.array([p[f"R{j}"] for j in range(1, n + 1)])
    else:
        raise ValueError(f"model {model.name} is not rational")
    gap, Lk, tau = ring_ladder_modes(np.asarray(Pg), Pv, Rv, model.n_turns)
    return p["R0"], float(gap), Lk, tau


def rational_form(model: Model, theta):
    """``Ze = Zc + R0`` as (numerator, denominator) coefficient arrays, lowest power first."""
    R0, G, Lk, tau = foster_form(model, theta)
    den = np.array([1.0])
    for t in tau:
        den = P.polymul(den, [1.0, t])
    num = P.polymul([R0, G], den)
    for k in range(tau.size):
        others = np.array([1.0])
        for j in range(tau.size):
            if j != k:
                others = P.polymul(others, [1.0, tau[j]])
        num = P.polyadd(num, P.polymul([0.0, Lk[k]], others))
    return num, den
