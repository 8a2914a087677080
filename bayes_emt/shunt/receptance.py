"""Shunted receptance (eq. 50) and its H∞ norm.

``G(s) = (1/m) / (s² + 2ζω0 s + ω0² + φ̄² s / (Zc(s) + R0 + Zs(s)))``. The mass ``m`` is not
identifiable from the terminals; it cancels in the attenuation ratio, so everything here is the
*mass-normalised* receptance ``m·G`` [s²] (units of 1/ω²).

A :class:`Plant` caches the blocked electrical impedance ``Ze = Zc + R0`` and the mechanical
polynomial on a dense frequency grid around ω0, so a candidate shunt is evaluated with a few
array operations; peaks are then refined off the grid against a cubic spline of ``Ze`` (smooth
in log ω) and finally against the exact model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import interpolate, optimize

from ..models import Model
from ..models.terms import mechanical_polynomial

__all__ = ["Plant", "rc_impedance", "peak"]


def rc_impedance(s, Rs, Cs):
    """Series RC shunt ``Zs = Rs + 1/(Cs s)`` [Ω]."""
    return Rs + 1.0 / (Cs * s)


@dataclass(frozen=True)
class Peak:
    """The H∞ norm of a receptance: ``value`` [s²] at ``omega`` [rad/s]."""

    value: float
    omega: float


class Plant:
    """One parameter vector of one model, prepared for shunt evaluation.

    Parameters
    ----------
    model, theta : the transducer model and its physical parameter vector.
    span : the grid covers ``ω0/span .. ω0·span`` [rad/s] (the shunted peaks stay near ω0).
    points : grid points (log-spaced).
    """

    def __init__(self, model: Model, theta, *, span: float = 8.0, points: int = 1600):
        self.model = model
        self.theta = np.asarray(theta, float)
        self.zeta, self.omega0, self.phi = (float(v) for v in model.mechanics(self.theta))
        self.R0 = float(self.theta[model.params.index("R0")])
        self.omega = np.geomspace(self.omega0 / span, self.omega0 * span, points)
        self.s = 1j * self.omega
        self.Ze = model.electrical_impedance_s(self.s, self.theta)
        self.mech = mechanical_polynomial(self.s, self.zeta, self.omega0)
        lw = np.log(self.omega)
        self._re = interpolate.CubicSpline(lw, self.Ze.real)
        self._im = interpolate.CubicSpline(lw, self.Ze.imag)

    # ---- evaluation --------------------------------------------------------------------------
    def ze(self, omega, exact: bool = False):
        """Blocked impedance ``Zc + R0`` at ``omega`` [rad/s] (spline inside the grid, or exact)."""
        omega = np.asarray(omega, float)
        if exact or np.any(omega < self.omega[0]) or np.any(omega > self.omega[-1]):
            return self.model.electrical_impedance_s(1j * omega, self.theta)
        lw = np.log(omega)
        return self._re(lw) + 1j * self._im(lw)

    def receptance(self, omega, Zs: Callable | None = None, *, exact: bool = True):
        """Mass-normalised receptance ``m·G(jω)`` [s²]; ``Zs(s)`` the shunt (None: open circuit)."""
        omega = np.asarray(omega, float)
        s = 1j * omega
        mech = mechanical_polynomial(s, self.zeta, self.omega0)
        if Zs is None:
            return 1.0 / mech
        return 1.0 / (mech + self.phi**2 * s / (self.ze(omega, exact) + Zs(s)))

    def _grid_receptance(self, Zs_grid):
        return 1.0 / (self.mech + self.phi**2 * self.s / (self.Ze + Zs_grid))

    def open_peak(self) -> Peak:
        """H∞ norm of the open-circuit receptance ``1/(s² + 2ζω0 s + ω0²)`` (closed form)."""
        z = self.zeta
        if z < 1 / np.sqrt(2):
            return Peak(1.0 / (2 * z * np.sqrt(1 - z * z) * self.omega0**2),
                        self.omega0 * np.sqrt(1 - 2 * z * z))
        return Peak(1.0 / self.omega0**2, 0.0)

    def rc_peak_fast(self, Rs: float, Cs: float) -> float:
        """Peak of ``|m·G_RC|`` [s²] from the grid with parabolic interpolation (for optimisers)."""
        g = np.abs(self._grid_receptance(rc_impedance(self.s, Rs, Cs)))
        i = int(np.argmax(g))
        if 0 < i < g.size - 1:
            y0, y1, y2 = np.log(g[i - 1 : i + 2])
            den = y0 - 2 * y1 + y2
            if den < 0:
                d = 0.5 * (y0 - y2) / den
                return float(np.exp(y1 - 0.25 * (y0 - y2) * d))
        return float(g[i])

    def peak(self, Zs: Callable | None, *, exact: bool = True) -> Peak:
        """Accurate H∞ norm: every local maximum on the grid refined by a bounded scalar search
        in log ω (relative accuracy ~1e-10), the largest returned."""
        if Zs is None:
            return self.open_peak()
        g = np.abs(self._grid_receptance(Zs(self.s)))
        idx = [i for i in range(1, g.size - 1) if g[i] >= g[i - 1] and g[i] >= g[i + 1]]
        if g[0] > g[1]:
            idx.append(0)
        if g[-1] > g[-2]:
            idx.append(g.size - 1)
        best = Peak(0.0, float("nan"))
        lw = np.log(self.omega)

        def neg(x):
            return -float(np.abs(self.receptance(np.array([np.exp(x)]), Zs, exact=exact))[0])

        for i in sorted(idx, key=lambda j: -g[j])[:4]:
            lo, hi = lw[max(i - 1, 0)], lw[min(i + 1, g.size - 1)]
            r = optimize.minimize_scalar(neg, bounds=(lo, hi), method="bounded",
                                         options={"xatol": 1e-12})
            if -r.fun > best.value:
                best = Peak(-float(r.fun), float(np.exp(r.x)))
        return best


def peak(model: Model, theta, Zs: Callable | None = None) -> Peak:
    """H∞ norm of ``m·G`` for one model and parameter vector (``Zs=None``: open terminals)."""
    return Plant(model, theta).peak(Zs)
