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
and of ``b`` averaged, times ``exp(√1.5 τ/m · ε)``; with ``k`` methods (fs: the model, the phase
zero and the |Z| peak) the mean of the ``k`` and ``(1 + 1/k) τ²`` (:func:`between_methods_sd`). τ is
the plug-in estimate (``k − 1`` degrees of freedom), so the interval is, if anything, short. The T/S
intervals that a user compares with another bench use it (:mod:`bayes_emt.thiele_small.definitional`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Z90", "half_width_sd", "between_method_sd", "between_methods_sd", "widen", "another_method"]

Z90 = 1.6448536269514722  # the standard normal's 95th percentile: a 90 % interval is ±Z90 sd


def half_width_sd(ci) -> float:
    """The standard uncertainty ``(hi − lo)/(2·Z90)`` of a 90 % interval (0 when there is none)."""
    if ci is None:
        return 0.0
    lo, hi = float(ci[0]), float(ci[1])
    return (hi - lo) / (2 * Z90) if math.isfinite(lo) and math.isfinite(hi) else 0.0


def between_method_sd(a: float, b: float, u_a: float = 0.0, u_b: float = 0.0) -> float:
    """τ of two methods' values (module docstring); 0 for a non-finite input."""
    return between_methods_sd([a, b], [u_a, u_b])


def between_methods_sd(values, us) -> float:
    """τ of ``k >= 2`` methods' values, each with its own standard uncertainty: the method-of-moments
    (DerSimonian–Laird with equal weights) estimate ``τ² = max(0, s² − mean(u²))``, ``s²`` the values'
    sample variance; for two methods the formula of the module docstring. 0 for a non-finite input."""
    v, u = np.asarray(values, float), np.asarray(us, float)
    if v.size < 2 or not (np.all(np.isfinite(v)) and np.all(np.isfinite(u))):
        return 0.0
    return math.sqrt(max(0.0, float(np.var(v, ddof=1)) - float(np.mean(u * u))))


def widen(values: np.ndarray, center: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """``values · exp((τ/center)·ε)``: the draws with the between-method spread (log-normal, so a
    positive quantity stays positive). ``τ = 0`` returns ``values`` unchanged."""
    values = np.asarray(values, float)
    if not (tau > 0 and math.isfinite(center) and center != 0):
        return values
    return values * np.exp(abs(tau / center) * rng.standard_normal(values.shape))


def another_method(values: np.ndarray, others, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Draws of the value a further method reports (module docstring): ``values`` are draws of the
    first method (its posterior), ``others`` the other methods' ``(value, standard uncertainty)``,
    ``τ`` the spread between the ``k = 1 + len(others)`` methods (:func:`between_methods_sd`). The mean
    of a draw of each, log-normally spread by ``√(1 + 1/k) τ`` about the methods' mean: the new
    method's value ``μ + δ`` less the mean's, variance ``(1 + 1/k) τ² + Σu²/k²``. ``τ = 0`` returns
    ``values`` unchanged (the methods agree within their own uncertainties: no spread to predict from)."""
    values = np.asarray(values, float)
    others = [(float(b), float(u)) for b, u in others]
    if not (tau > 0 and others and all(math.isfinite(b) and b != 0 for b, _ in others)):
        return values
    total = values.copy()
    for b, u_b in others:
        total += b * np.exp(abs(u_b / b) * rng.standard_normal(values.shape)) if u_b > 0 else b
    k = 1 + len(others)
    mid = total / k
    return widen(mid, float(np.nanmedian(mid)), math.sqrt(1.0 + 1.0 / k) * tau, rng)
