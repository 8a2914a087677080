"""Parameter specifications: the one description every stage reuses.

A :class:`ParamSpec` names a parameter, its SI unit, a label and a proper prior. A
:class:`ParamSet` (ordered specs of one model) derives from them everything the later stages
need, so no other module re-declares names, bounds or units:

* least-squares bounds and starting values (in *sampling space*), and the one rule that moves a
  value strictly inside the prior's support (:func:`clip_inside`, margin :data:`CLIP_MARGIN`),
* the log-prior density in sampling space, including the log-Jacobian of the transform,
* the unit-cube transform for nested sampling,
* prior draws, report labels and JSON.

Sampling space ("z") is ``log x`` for positive, decade-spanning parameters (log-uniform or
log-normal priors) and ``x`` itself otherwise. All arrays are vectorised over leading axes:
``(..., k)`` in, ``(...)`` or ``(..., k)`` out.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from .priors import Prior, Transform, prior_from_dict

__all__ = ["ParamSpec", "ParamSet", "clip_inside", "CLIP_MARGIN"]

#: how far inside its prior's support :func:`clip_inside` puts a value: this fraction of the support's
#: width in sampling space (1 where the support is unbounded on a side), e.g. 1.8e-8 e-folds for a
#: log-uniform prior over eight decades; strictly inside, so the log prior is finite, and a
#: bounded least-squares start is feasible, yet far below any tolerance
CLIP_MARGIN = 1e-9


def clip_inside(z, lo, hi):
    """``z`` (sampling space, ``(..., k)``) moved strictly inside the bounds ``lo``, ``hi`` ``(k,)``
    by :data:`CLIP_MARGIN` of their width (of 1 where a bound is infinite); non-finite ``z`` stays so
    (NaN) or lands on the margin (±inf)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    with np.errstate(invalid="ignore"):
        width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    return np.clip(np.asarray(z, float), lo + CLIP_MARGIN * width, hi - CLIP_MARGIN * width)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name (as in Physics and conventions), SI unit, plot label, proper prior, description."""

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

    def clip_inside(self, x):
        """The physical value(s) ``x`` moved strictly inside the prior's support (:func:`clip_inside`
        in sampling space); a float for a scalar ``x``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            out = self.from_z(clip_inside(self.to_z(x), *self.bounds_z()))
        return float(out) if out.ndim == 0 else out

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

    def clip_inside(self, z):
        """Sampling-space values ``z (..., k)`` moved strictly inside the prior support
        (:func:`clip_inside`)."""
        return clip_inside(z, *self.bounds_z())

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


