"""Parameter specifications: the one description every stage reuses.

A :class:`ParamSpec` names a parameter, its SI unit, a label and a proper prior. A
:class:`ParamSet` (ordered specs of one model) derives from them everything the later stages
need, so no other module re-declares names, bounds or units:

* least-squares bounds and starting values (in *sampling space*),
* the log-prior density in sampling space, including the log-Jacobian of the transform,
* the unit-cube transform for nested sampling,
* prior draws, report labels and JSON.

Sampling space ("z") is ``log x`` for positive, decade-spanning parameters (log-uniform or
log-normal priors) and ``x`` itself otherwise. All arrays are vectorised over leading axes:
``(..., k)`` in, ``(...)`` or ``(..., k)`` out.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from scipy import special

__all__ = [
    "LogUniform",
    "Uniform",
    "Normal",
    "LogNormal",
    "ParamSpec",
    "ParamSet",
    "prior_from_dict",
    "default_spec",
]

Transform = Literal["log", "identity"]


# --------------------------------------------------------------------------------------------
# Priors (densities on the physical value x)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Specs
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name (SPEC §6), SI unit, plot label, proper prior, description."""

    name: str
    unit: str
    label: str
    prior: Prior
    description: str = ""

    @property
    def transform(self) -> Transform:
        return self.prior.transform

    def to_z(self, x):
        x = np.asarray(x, dtype=float)
        if self.transform == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.log(x)
        return x

    def from_z(self, z):
        z = np.asarray(z, dtype=float)
        return np.exp(z) if self.transform == "log" else z

    def log_jacobian(self, z):
        """``log |dx/dz|`` at sampling-space point(s) ``z``."""
        z = np.asarray(z, dtype=float)
        return z if self.transform == "log" else np.zeros_like(z)

    def log_prior_z(self, z):
        """Log density of the prior expressed in sampling space (prior logpdf + log-Jacobian)."""
        return self.prior.logpdf(self.from_z(z)) + self.log_jacobian(z)

    def bounds_z(self) -> tuple[float, float]:
        lo, hi = self.prior.lower, self.prior.upper
        if self.transform == "log":
            return (math.log(lo) if lo > 0 else -np.inf, math.log(hi) if np.isfinite(hi) else np.inf)
        return (lo, hi)

    def to_dict(self) -> dict:
        return {"name": self.name, "unit": self.unit, "label": self.label,
                "description": self.description, "prior": self.prior.to_dict()}


class ParamSet(Sequence[ParamSpec]):
    """An ordered, immutable collection of :class:`ParamSpec` (one model's parameter vector)."""

    def __init__(self, specs: Iterable[ParamSpec]):
        self._specs = tuple(specs)
        names = [s.name for s in self._specs]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"duplicate parameter names: {sorted(dup)}")
        self._index = {n: i for i, n in enumerate(names)}

    # Sequence protocol
    def __getitem__(self, i):
        if isinstance(i, str):
            return self._specs[self._index[i]]
        return self._specs[i]

    def __len__(self):
        return len(self._specs)

    def __repr__(self):
        return f"ParamSet({list(self.names)})"

    def __eq__(self, other):
        return isinstance(other, ParamSet) and self._specs == other._specs

    def __hash__(self):
        return hash(self._specs)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self._specs)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(s.unit for s in self._specs)

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; this model has {list(self.names)}") from None

    def __add__(self, other: ParamSet) -> ParamSet:
        return ParamSet(tuple(self) + tuple(other))

    # ---- vectors <-> dicts ------------------------------------------------------------------
    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """Parameter dict → vector in this set's order; a missing or unknown name raises."""
        missing = [n for n in self.names if n not in values]
        extra = [n for n in values if n not in self._index]
        if missing or extra:
            msg = []
            if missing:
                msg.append(f"missing {missing}")
            if extra:
                msg.append(f"unknown {extra}")
            raise KeyError(f"parameters do not match {list(self.names)}: " + "; ".join(msg))
        return np.array([float(values[n]) for n in self.names])

    def as_dict(self, theta) -> dict[str, float]:
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (len(self),):
            raise ValueError(f"expected a vector of {len(self)} values, got shape {theta.shape}")
        return {n: float(v) for n, v in zip(self.names, theta, strict=True)}

    # ---- transforms ----------------------------------------------------------------------------
    def to_z(self, x):
        x = np.asarray(x, dtype=float)
        return np.stack([s.to_z(x[..., i]) for i, s in enumerate(self._specs)], axis=-1)

    def from_z(self, z):
        z = np.asarray(z, dtype=float)
        return np.stack([s.from_z(z[..., i]) for i, s in enumerate(self._specs)], axis=-1)

    def log_jacobian(self, z):
        z = np.asarray(z, dtype=float)
        return sum(s.log_jacobian(z[..., i]) for i, s in enumerate(self._specs))

    def log_prior_z(self, z):
        """Joint log prior in sampling space, vectorised over leading axes; ``-inf`` outside support."""
        z = np.asarray(z, dtype=float)
        with np.errstate(invalid="ignore", over="ignore"):
            out = sum(s.log_prior_z(z[..., i]) for i, s in enumerate(self._specs))
        return np.where(np.isnan(out), -np.inf, out)

    def log_prior(self, x):
        """Joint log prior density of the physical values ``x``."""
        x = np.asarray(x, dtype=float)
        return sum(s.prior.logpdf(x[..., i]) for i, s in enumerate(self._specs))

    def bounds_z(self) -> tuple[np.ndarray, np.ndarray]:
        """Least-squares bounds in sampling space (the prior support)."""
        b = np.array([s.bounds_z() for s in self._specs], dtype=float)
        return b[:, 0], b[:, 1]

    def in_support(self, x) -> np.ndarray:
        return np.isfinite(self.log_prior(x))

    def prior_transform(self, u):
        """Unit cube → physical values (nested sampling's ``prior_transform``)."""
        u = np.asarray(u, dtype=float)
        return np.stack([s.prior.ppf(u[..., i]) for i, s in enumerate(self._specs)], axis=-1)

    def prior_transform_z(self, u):
        """Unit cube → sampling-space values."""
        return self.to_z(self.prior_transform(u))

    def sample_prior(self, rng: np.random.Generator, size: int) -> np.ndarray:
        return self.prior_transform(rng.uniform(size=(size, len(self))))

    # ---- overrides -----------------------------------------------------------------------------
    def with_priors(self, overrides: Mapping[str, Prior | Mapping], *, where: str = "priors") -> ParamSet:
        """A copy with some priors replaced; unknown names raise (naming ``where``)."""
        unknown = [n for n in overrides if n not in self._index]
        if unknown:
            raise KeyError(f"{where}: unknown parameter(s) {unknown}; this model has {list(self.names)}")
        specs = list(self._specs)
        for name, pr in overrides.items():
            if isinstance(pr, Mapping):
                pr = prior_from_dict(pr, where=f"{where}: {name}")
            specs[self._index[name]] = replace(specs[self._index[name]], prior=pr)
        return ParamSet(specs)

    def to_dict(self) -> list[dict]:
        return [s.to_dict() for s in self._specs]


# --------------------------------------------------------------------------------------------
# The default catalogue of parameters (SPEC §6 names; SI units)
# --------------------------------------------------------------------------------------------
# Priors are proper, log-uniform over wide decade ranges that bracket every transducer from a
# 1 cm tweeter to the paper's 2 kg shaker, and identical for a name whatever the model, so that
# evidences of different models are comparable (shared parameters' prior volumes cancel).
_DEFAULTS: dict[str, tuple[str, str, Prior, str]] = {
    "zeta": ("1", r"$\zeta$", LogUniform(1e-5, 2.0), "mechanical damping ratio"),
    "omega0": ("rad/s", r"$\omega_0$", LogUniform(1e-1, 1e6), "mechanical natural angular frequency"),
    "phi": ("N/(A kg^0.5)", r"$\bar\varphi$", LogUniform(1e-3, 1e4),
            "mass-normalised electromechanical coupling phi/sqrt(m)"),
    "R0": ("ohm", r"$R_0$", LogUniform(1e-3, 1e4), "coil DC resistance"),
    "L0": ("H", r"$L_0$", LogUniform(1e-8, 1e1), "coil self-inductance"),
    "Rmu": ("ohm", r"$R_\mu$", LogUniform(1e-3, 1e5), "lumped eddy-current loss resistance"),
    "alpha": ("s", r"$\alpha$", LogUniform(1e-10, 1e2), "eddy-current diffusion time constant"),
    "beta": ("H s^-0.5", r"$\beta$", LogUniform(1e-6, 1e4), "semi-inductance scale"),
    "Lg": ("H", r"$L_g$", LogUniform(1e-9, 1e1), "air-gap inductance"),
    "Pg": ("H", r"$P_g$", LogUniform(1e-16, 1e-2), "air-gap permeance (per turn squared)"),
    "P": ("H", r"$P_{j}$", LogUniform(1e-16, 1e-2), "permeance of core ring j"),
    "R": ("ohm", r"$R_{j}$", LogUniform(1e-12, 1e2), "eddy-current resistance of core ring j"),
    # physical parameters separated by an added-mass pair (SPEC §3.4)
    "m": ("kg", r"$m$", LogUniform(1e-6, 1e4), "moving mass"),
    "c": ("N s/m", r"$c$", LogUniform(1e-9, 1e6), "mechanical viscous damping"),
    "k": ("N/m", r"$k$", LogUniform(1e-6, 1e10), "mechanical stiffness"),
    "phi_raw": ("N/A", r"$\varphi$", LogUniform(1e-6, 1e4), "electromechanical coupling (force factor Bl)"),
}
_RING = re.compile(r"^([PR])([1-9]\d*)$")  # ring j = 1..n; "R0" is the coil, not a ring


def default_spec(name: str) -> ParamSpec:
    """The catalogue spec for ``name`` (``P3`` and ``R3`` resolve to the ring entries)."""
    key, j = name, None
    m = _RING.match(name)
    if m:
        key, j = m.group(1), int(m.group(2))
    if key not in _DEFAULTS:
        raise KeyError(f"no catalogue entry for parameter {name!r}")
    unit, label, prior, desc = _DEFAULTS[key]
    if j is not None:
        label = label.replace("{j}", f"{{{j}}}")
        desc = desc.replace("ring j", f"ring {j}")
    return ParamSpec(name, unit, label, prior, desc)
