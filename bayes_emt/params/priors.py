"""Proper prior distributions on a parameter's physical value ``x``: log-density, the quantile
function (nested sampling's unit-cube transform) and the sampling-space transform they imply
(``log`` for positive, decade-spanning priors, ``identity`` otherwise)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy import special

__all__ = ["LogUniform", "Uniform", "Normal", "LogNormal", "Prior", "prior_from_dict", "Transform"]

Transform = Literal["log", "identity"]



@dataclass(frozen=True)
class LogUniform:
    """Log-uniform (Jeffreys-like, proper) prior on ``[lower, upper]``, ``0 < lower < upper``."""

    lower: float
    upper: float
    transform: Transform = field(default="log", init=False)

    def __post_init__(self):
        if not (0 < self.lower < self.upper and math.isfinite(self.upper)):
            raise ValueError(f"LogUniform needs 0 < lower < upper < inf, got {self.lower}, {self.upper}")

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        with np.errstate(divide="ignore", invalid="ignore"):
            val = -np.log(x) - math.log(math.log(self.upper / self.lower))
        return np.where(inside, val, -np.inf)

    def ppf(self, u):
        u = np.asarray(u, dtype=float)
        return self.lower * (self.upper / self.lower) ** u

    def to_dict(self):
        return {"dist": "loguniform", "lower": self.lower, "upper": self.upper}


@dataclass(frozen=True)
class Uniform:
    """Uniform prior on ``[lower, upper]``."""

    lower: float
    upper: float
    transform: Transform = field(default="identity", init=False)

    def __post_init__(self):
        if not (self.lower < self.upper and math.isfinite(self.lower) and math.isfinite(self.upper)):
            raise ValueError(f"Uniform needs finite lower < upper, got {self.lower}, {self.upper}")

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        return np.where(inside, -math.log(self.upper - self.lower), -np.inf)

    def ppf(self, u):
        return self.lower + (self.upper - self.lower) * np.asarray(u, dtype=float)

    def to_dict(self):
        return {"dist": "uniform", "lower": self.lower, "upper": self.upper}


@dataclass(frozen=True)
class Normal:
    """Normal prior ``N(mu, sigma)`` (e.g. a datasheet value with its tolerance)."""

    mu: float
    sigma: float
    transform: Transform = field(default="identity", init=False)

    def __post_init__(self):
        if not self.sigma > 0:
            raise ValueError(f"Normal needs sigma > 0, got {self.sigma}")

    @property
    def lower(self):
        return -np.inf

    @property
    def upper(self):
        return np.inf

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        return -0.5 * ((x - self.mu) / self.sigma) ** 2 - math.log(self.sigma * math.sqrt(2 * math.pi))

    def ppf(self, u):
        return self.mu + self.sigma * math.sqrt(2) * special.erfinv(2 * np.asarray(u, float) - 1)

    def to_dict(self):
        return {"dist": "normal", "mu": self.mu, "sigma": self.sigma}


@dataclass(frozen=True)
class LogNormal:
    """Log-normal prior: ``log x ~ N(log(median), sigma_log)``."""

    median: float
    sigma_log: float
    transform: Transform = field(default="log", init=False)

    def __post_init__(self):
        if not (self.median > 0 and self.sigma_log > 0):
            raise ValueError(f"LogNormal needs median > 0 and sigma_log > 0, "
                             f"got {self.median}, {self.sigma_log}")

    @property
    def lower(self):
        return 0.0

    @property
    def upper(self):
        return np.inf

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            lx = np.log(x)
            val = (-0.5 * ((lx - math.log(self.median)) / self.sigma_log) ** 2 - lx
                   - math.log(self.sigma_log * math.sqrt(2 * math.pi)))
        return np.where(x > 0, val, -np.inf)

    def ppf(self, u):
        z = math.sqrt(2) * special.erfinv(2 * np.asarray(u, float) - 1)
        return self.median * np.exp(self.sigma_log * z)

    def to_dict(self):
        return {"dist": "lognormal", "median": self.median, "sigma_log": self.sigma_log}


Prior = LogUniform | Uniform | Normal | LogNormal

_PRIOR_TYPES = {"loguniform": LogUniform, "uniform": Uniform, "normal": Normal, "lognormal": LogNormal}


def prior_from_dict(d: Mapping, *, where: str = "prior") -> Prior:
    """Build a prior from ``{"dist": "loguniform", "lower": .., "upper": ..}`` (JSON/TOML form)."""
    d = dict(d)
    kind = str(d.pop("dist", "")).lower()
    if kind not in _PRIOR_TYPES:
        raise ValueError(f"{where}: unknown prior dist {kind!r}; choose one of {sorted(_PRIOR_TYPES)}")
    try:
        return _PRIOR_TYPES[kind](**{k: float(v) for k, v in d.items()})
    except TypeError as exc:
        raise ValueError(f"{where}: bad fields for a {kind} prior: {sorted(d)} ({exc})") from None


