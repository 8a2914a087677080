"""The measurement record: frequencies, complex admittance, optional weights, metadata."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from .errors import DataFormatError

__all__ = ["Measurement", "validate_arrays"]


def validate_arrays(omega, Y, *, source: str = "<array>", weights=None, sort: bool = True):
    """Check and normalise measurement arrays; raise :class:`DataFormatError` naming ``source``.

    Rules: 1-D, same length, finite, ``omega > 0``, ``Y != 0``, no duplicate frequencies;
    unsorted input is sorted with a notice (a ``UserWarning``) when ``sort`` is true.
    Returns ``(omega, Y, weights)`` as new arrays.
    """
    omega = np.asarray(omega, dtype=float)
    Y = np.asarray(Y, dtype=complex)
    if omega.ndim != 1 or Y.ndim != 1:
        raise DataFormatError(f"{source}: frequencies and admittance must be 1-D arrays")
    if omega.size != Y.size:
        raise DataFormatError(f"{source}: {omega.size} frequencies but {Y.size} admittance values")
    if omega.size == 0:
        raise DataFormatError(f"{source}: no data points")
    bad = ~np.isfinite(omega)
    if bad.any():
        raise DataFormatError(f"{source}: non-finite frequency at point {int(np.argmax(bad)) + 1}")
    bad = ~np.isfinite(Y)
    if bad.any():
        raise DataFormatError(f"{source}: non-finite value at point {int(np.argmax(bad)) + 1}")
    bad = omega <= 0
    if bad.any():
        i = int(np.argmax(bad))
        raise DataFormatError(f"{source}: non-positive frequency {omega[i]:g} at point {i + 1}")
    bad = Y == 0
    if bad.any():
        raise DataFormatError(f"{source}: zero admittance/impedance at point {int(np.argmax(bad)) + 1}")
    if weights is not None:
        weights = np.asarray(weights, dtype=float)
        if weights.shape != omega.shape or not np.all(np.isfinite(weights)) or np.any(weights <= 0):
            raise DataFormatError(f"{source}: weights must be positive, finite, one per point")
    order = np.argsort(omega, kind="stable")
    if np.any(np.diff(omega[order]) == 0):
        i = int(np.argmax(np.diff(omega[order]) == 0))
        raise DataFormatError(f"{source}: duplicate frequency {omega[order][i]:g} rad/s")
    if np.any(order != np.arange(omega.size)):
        if not sort:
            raise DataFormatError(f"{source}: frequencies are not in increasing order")
        warnings.warn(f"{source}: frequencies were not in increasing order; sorted them",
                      UserWarning, stacklevel=2)
        omega, Y = omega[order], Y[order]
        weights = None if weights is None else weights[order]
    return omega.copy(), Y.copy(), None if weights is None else weights.copy()


@dataclass(frozen=True)
class Measurement:
    """A measured (or simulated) admittance.

    Attributes
    ----------
    omega : (F,) angular frequencies [rad/s], strictly increasing.
    Y : (F,) complex admittance [S].
    weights : (F,) optional positive per-point weights (relative confidence), or None.
    meta : read-only metadata (source file, original units, simulation truth, ...).
    """

    omega: np.ndarray
    Y: np.ndarray
    weights: np.ndarray | None = None
    meta: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self):
        src = str(dict(self.meta).get("source", "<array>"))
        omega, Y, w = validate_arrays(self.omega, self.Y, source=src, weights=self.weights)
        for a in (omega, Y) + (() if w is None else (w,)):
            a.setflags(write=False)
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "Y", Y)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))

    @classmethod
    def from_impedance(cls, omega, Z, **kwargs) -> Measurement:
        return cls(np.asarray(omega, float), 1.0 / np.asarray(Z, complex), **kwargs)

    @classmethod
    def from_hz(cls, f_hz, Y, **kwargs) -> Measurement:
        return cls(2 * math.pi * np.asarray(f_hz, float), Y, **kwargs)

    @property
    def n_points(self) -> int:
        return int(self.omega.size)

    @property
    def f_hz(self) -> np.ndarray:
        """Frequencies [Hz]."""
        return self.omega / (2 * math.pi)

    @property
    def Z(self) -> np.ndarray:
        """Impedance [ohm]."""
        return 1.0 / self.Y

    @property
    def phase_absent(self) -> bool:
        """Whether the recording holds |Z| only (``meta["phase"] == "absent"``): ``Y`` then carries a
        minimum-phase estimate of the phase, for starting a fit, and every fit, likelihood and
        residual uses the magnitude alone."""
        return self.meta.get("phase") == "absent"

    @property
    def source(self) -> str:
        return str(self.meta.get("source", "<array>"))

    def select(self, omega_min: float | None = None, omega_max: float | None = None) -> Measurement:
        """The points with ``omega_min <= omega <= omega_max`` (rad/s)."""
        keep = np.ones(self.n_points, bool)
        if omega_min is not None:
            keep &= self.omega >= omega_min
        if omega_max is not None:
            keep &= self.omega <= omega_max
        if not keep.any():
            raise DataFormatError(
                f"{self.source}: no points between {omega_min} and {omega_max} rad/s "
                f"(data span {self.omega[0]:g}-{self.omega[-1]:g} rad/s)")
        w = None if self.weights is None else self.weights[keep]
        return replace(self, omega=self.omega[keep], Y=self.Y[keep], weights=w)

    def exclude_bands(self, bands_hz) -> Measurement:
        """The points outside every ``(f1_hz, f2_hz)`` of ``bands_hz`` (inclusive ends, Hz): a narrow
        feature no lumped model explains (cone break-up, a surround dip) left out of a fit. An empty
        ``bands_hz`` returns ``self``; a band with ``f1 >= f2`` or a non-finite end, or one that
        leaves fewer than 8 points, raises :class:`DataFormatError` naming it. An end may be a string
        with a unit (``("20Hz", "1kHz")``, :mod:`bayes_emt.units`)."""
        from .units import UnitError, as_si

        try:
            bands = [tuple(as_si(x, "frequency", "exclude band", bare="Hz") for x in b)
                     for b in (bands_hz or ())]
        except (UnitError, TypeError) as exc:
            raise DataFormatError(f"{self.source}: {exc}") from None
        if not bands:
            return self
        keep = np.ones(self.n_points, bool)
        f = self.f_hz
        for b in bands:
            if len(b) != 2 or not all(math.isfinite(float(x)) for x in b) or not float(b[0]) < float(b[1]):
                raise DataFormatError(
                    f"{self.source}: exclude band {b!r} must be (f1_hz, f2_hz) with f1 < f2")
            keep &= ~((f >= float(b[0])) & (f <= float(b[1])))
        if np.count_nonzero(keep) < 8:
            raise DataFormatError(
                f"{self.source}: excluding {bands} leaves {np.count_nonzero(keep)} points (need 8)")
        w = None if self.weights is None else self.weights[keep]
        excl = [list(map(float, b)) for b in bands]
        return replace(self, omega=self.omega[keep], Y=self.Y[keep], weights=w,
                       meta=MappingProxyType({**self.meta, "excluded_bands_hz": excl}))

    def thin(self, per_decade: float | None) -> Measurement:
        """At most ``per_decade`` points per decade of frequency: walking up from the first point, a
        point is kept when it lies at least ``1/per_decade`` decade above the last one kept; the last
        point is always kept. Where the recording is sparser than that (a log sweep of fewer points,
        the low end of a linear sweep) every point stays; ``None`` or ``0``: ``self``. Deterministic.
        ``meta["thinned_from"]`` records the number of points before when any was left out."""
        if not per_decade:
            return self
        if not (math.isfinite(per_decade) and per_decade > 0):
            raise ValueError(f"per_decade must be a positive number of points per decade, got {per_decade!r}")
        step = math.log(10.0) / float(per_decade) * (1 - 1e-9)
        lw = np.log(self.omega)
        keep = [0]
        for i in range(1, self.n_points - 1):
            if lw[i] - lw[keep[-1]] >= step:
                keep.append(i)
        if self.n_points > 1:
            keep.append(self.n_points - 1)
        if len(keep) == self.n_points:
            return self
        idx = np.asarray(keep)
        w = None if self.weights is None else self.weights[idx]
        return replace(self, omega=self.omega[idx], Y=self.Y[idx], weights=w,
                       meta=MappingProxyType({**self.meta, "thinned_from": self.n_points}))

    def with_meta(self, **meta: Any) -> Measurement:
        return replace(self, meta=MappingProxyType({**self.meta, **meta}))

    def meta_json(self) -> str:
        """Metadata as JSON text (non-serialisable values are stringified)."""
        return json.dumps(dict(self.meta), default=str, sort_keys=True)
