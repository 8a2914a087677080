"""Risk measures over posterior draws, summaries that allow +inf (an unstable loop's H∞ norm),
the Clopper–Pearson interval for a probability of instability, and rank correlations.

Attenuations are in dB and *negative is good*, so the risky side of a distribution is its upper
tail: ``q95`` is the worst 5 %, ``CVaR_α`` the mean of the worst ``1 − α`` fraction (Rockafellar &
Uryasev 2000, discrete form with a fractional last atom), ``worst`` the largest value.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from scipy import stats

__all__ = ["RiskKind", "RISKS", "risk_value", "cvar", "quantiles", "summary", "clopper_pearson",
           "spearman"]

RiskKind = Literal["cvar", "mean", "worst"]
RISKS: tuple[str, ...] = ("cvar", "mean", "worst")
_BIG = 1e300


def cvar(a, alpha: float) -> float:
    """Mean of the worst ``1 − alpha`` fraction of ``a`` (largest values; RU discrete form:
    ``min_t t + Σ (a_i − t)₊ / ((1 − α) n)``)."""
    a = np.sort(np.asarray(a, float))[::-1]
    if not 0 <= alpha < 1:
        raise ValueError(f"the CVaR level must be in [0, 1), got {alpha!r}")
    k = (1 - alpha) * a.size
    whole = int(math.floor(k + 1e-12))
    tail = a[:whole].sum() if whole else 0.0
    frac = k - whole
    if frac > 1e-12 and whole < a.size:
        tail = tail + frac * a[whole]
    return float(tail / k)


def risk_value(a, kind: RiskKind, alpha: float = 0.9) -> float:
    """The risk measure ``kind`` of the attenuations ``a`` [dB] (module docstring)."""
    a = np.asarray(a, float)
    if a.size == 0:
        return math.nan
    if kind == "cvar":
        return cvar(a, alpha)
    if kind == "mean":
        return float(np.mean(a))
    if kind == "worst":
        return float(np.max(a))
    raise ValueError(f"unknown risk measure {kind!r}; choose one of {', '.join(RISKS)}")


def quantiles(a, qs) -> np.ndarray:
    """Linear-interpolation quantiles that keep +inf (a quantile reaching an infinite value is
    +inf rather than NaN)."""
    a = np.asarray(a, float)
    out = np.quantile(np.where(np.isposinf(a), _BIG, a), qs)
    return np.where(out >= _BIG / 2, np.inf, out)


def summary(a, prob: float = 0.9) -> dict:
    """``{"median", "q05", "q95"}`` (central ``prob`` interval) of ``a``; +inf becomes None in JSON."""
    lo, hi = (1 - prob) / 2, (1 + prob) / 2
    q = quantiles(a, [0.5, lo, hi])
    return {"median": float(q[0]), "q05": float(q[1]), "q95": float(q[2])}


def clopper_pearson(k: float, n: float, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper–Pearson 1934) two-sided ``confidence`` interval for a binomial probability
    after ``k`` events in ``n`` independent trials. ``k``, ``n`` may be non-integer (effective
    counts): the Beta-quantile form is used as is."""
    if not (n > 0 and 0 <= k <= n):
        raise ValueError(f"need 0 <= k <= n and n > 0, got k={k!r}, n={n!r}")
    a = 1 - confidence
    lo = 0.0 if k <= 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k >= n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def spearman(X, y) -> np.ndarray:
    """Spearman rank correlation of each column of ``X (n, p)`` with ``y (n,)``; NaN for a
    constant column (or a constant ``y``)."""
    X = np.asarray(X, float)
    rx = stats.rankdata(X, axis=0)
    ry = stats.rankdata(np.asarray(y, float))
    rx = rx - rx.mean(axis=0)
    ry = ry - ry.mean()
    den = np.sqrt((rx**2).sum(axis=0) * (ry**2).sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, (rx * ry[:, None]).sum(axis=0) / np.where(den > 0, den, 1.0), np.nan)
