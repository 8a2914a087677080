"""The spread between two methods' values of one quantity ("dark uncertainty"), and draws widened by it.

Two competent procedures applied to the same recording (a full-band coil-model fit and Small's
impedance-peak method; a fit's R0 and a bench's low-frequency plateau reading of Re) give values
``a`` and ``b`` that differ by more than their own uncertainties ``u_a``, ``u_b`` account for. The
excess is the between-method standard deviation, the random-effects estimate for two methods
(DerSimonian & Laird 1986; Thompson & Ellison 2011, *Accred. Qual. Assur.* 16:483):

    τ² = max(0, (a − b)²/2 − (u_a² + u_b²)/2).

:func:`widen` multiplies draws of ``a`` by ``exp(τ/a·ε)``, ``ε ~ N(0, 1)``: the posterior convolved
with the between-method spread, log-normal so a positive quantity stays positive: the quantity with
its definitional uncertainty, centred on method ``a`` (the shunt's R0, :mod:`bayes_emt.shunt.r0_spread`).

:func:`another_method` is the value a *further* competent method would report, the random-effects
predictive for a new method from two (Higgins, Thompson & Spiegelhalter 2009, *J. R. Stat. Soc. A*
172:137, the prediction interval of a random-effects meta-analysis): with ``a = μ + δ_a + e_a``,
``b = μ + δ_b + e_b``, ``δ ~ N(0, τ²)``, a new method's ``c = μ + δ_c`` is centred on the
mean of the two and spread by ``τ² + var((a + b)/2) = 1.5 τ² + (u_a² + u_b²)/4``; draws of ``a``
and of ``b`` averaged, times ``exp(√1.5 τ/m · ε)``. τ is the plug-in estimate above (one degree of
freedom), so the interval is, if anything, short. The T/S intervals that a user compares with
another bench use it (:mod:`bayes_emt.thiele_small.definitional`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Z90", "half_width_sd", "between_method_sd", "widen", "another_method"]

Z90 = 1.6448536269514722  # the standard normal's 95th percentile: a 90 % interval is ±Z90 sd


def half_width_sd(ci) -> float:
    """The standard uncertainty ``(hi − lo)/(2·Z90)`` of a 90 % interval (0 when there is none)."""
    if ci is None:
        return 0.0
    lo, hi = float(ci[0]), float(ci[1])
    return (hi - lo) / (2 * Z90) if math.isfinite(lo) and math.isfinite(hi) else 0.0


def between_method_sd(a: float, b: float, u_a: float = 0.0, u_b: float = 0.0) -> float:
    """τ of two methods' values (module docstring); 0 for a non-finite input."""
    if not all(math.isfinite(x) for x in (a, b, u_a, u_b)):
        return 0.0
    return math.sqrt(max(0.0, 0.5 * (a - b) ** 2 - 0.5 * (u_a**2 + u_b**2)))


def widen(values: np.ndarray, center: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """``values · exp((τ/center)·ε)``: the draws with the between-method spread (log-normal, so a
    positive quantity stays positive). ``τ = 0`` returns ``values`` unchanged."""
    values = np.asarray(values, float)
    if not (tau > 0 and math.isfinite(center) and center != 0):
        return values
    return values * np.exp(abs(tau / center) * rng.standard_normal(values.shape))


def another_method(values: np.ndarray, b: float, u_b: float, tau: float,
                   rng: np.random.Generator) -> np.ndarray:
    """Draws of the value a further method reports (module docstring): ``values`` are draws of
    method ``a`` (its posterior), ``b ± u_b`` the second method's value and standard uncertainty,
    ``τ`` their between-method spread (:func:`between_method_sd`). The mean of a draw of each,
    log-normally spread by ``√1.5 τ`` about the two methods' mid-point. ``τ = 0`` returns ``values``
    unchanged (the methods agree within their own uncertainties: no spread to predict from)."""
    values = np.asarray(values, float)
    if not (tau > 0 and math.isfinite(b) and b != 0):
        return values
    vb = b * np.exp(abs(u_b / b) * rng.standard_normal(values.shape)) if u_b > 0 else np.full(values.shape, b)
    mid = 0.5 * (values + vb)
    center = float(np.nanmedian(mid))
    return widen(mid, center, math.sqrt(1.5) * tau, rng)
