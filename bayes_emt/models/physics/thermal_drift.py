"""Thermal drift during the sweep: the coil resistance changing along the sweep order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import ParamSpec, Uniform
from ..term import Term, col

__all__ = ["ThermalDrift"]


@dataclass(frozen=True)
class ThermalDrift(Term):
    """``R0 → R0 (1 + δ t_k)`` with ``t_k ∈ [0, 1]`` the position of point k in the sweep order:
    the coil warming (or the room) during the measurement. ``t`` is computed from the frequency,
    the sweep's first and last frequencies and its spacing (log or linear), bound to the data
    (:meth:`bind`). Not device physics: the shunt design ignores it."""

    omega_first: float | None = None
    omega_last: float | None = None
    spacing: str = "log"
    id = "thermal_drift"
    augmentation = True
    band = "anywhere"
    device = False
    physics = "thermal_drift"
    needs = ("R0",)
    description = "coil resistance changing during the sweep (warming, room temperature)"
    signature = "a real-part residual that trends along the sweep order, not with frequency physics"
    parameters = (ParamSpec("drift", "1", r"$\delta_T$", Uniform(-0.1, 0.1),
                            "relative change of R0 from the first to the last point of the sweep"),)

    def __post_init__(self):
        if self.spacing not in ("log", "linear"):
            raise ValueError(f"thermal_drift spacing must be 'log' or 'linear', got {self.spacing!r}")

    def bind(self, omega):
        if self.omega_first is not None:
            return self
        omega = np.asarray(omega, float)

        def spread(x):  # coefficient of variation of the steps
            return float(np.std(x) / abs(np.mean(x)))

        # a linear sweep has equal steps in omega, a log sweep in log omega
        spacing = "linear" if spread(np.diff(omega)) < spread(np.diff(np.log(omega))) else "log"
        return type(self)(self.params, float(omega[0]), float(omega[-1]), spacing)

    def position(self, omega):
        """``t`` of each angular frequency [rad/s] in the sweep order (0 first, 1 last)."""
        if self.omega_first is None:
            raise ValueError("thermal_drift is not bound to a sweep: call Model.bind(omega) first")
        a, b = self.omega_first, self.omega_last
        if self.spacing == "log":
            t = (np.log(omega) - np.log(a)) / (np.log(b) - np.log(a))
        else:
            t = (omega - a) / (b - a)
        return np.clip(t, 0.0, 1.0)

    def evaluate(self, s, v, other):
        return other["R0"] * col(v, 0) * self.position(np.abs(s))

    def start(self, ctx):
        t = self.bind(ctx.omega).position(ctx.omega)
        dz = (ctx.Z - ctx.Z_base).real
        est = float(np.sum(dz * t) / np.sum(t * t)) / ctx.base["R0"]
        drift = self.params["drift"]
        return [{"drift": drift.clip_inside(d)} for d in (est, 0.01, -0.01)]
