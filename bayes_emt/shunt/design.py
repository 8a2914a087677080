"""H∞-optimal series RC shunt (SPEC §4): ``Zs = Rs + 1/(Cs s)`` minimising ``‖G_RC‖∞``.

Start: the fixed-point closed form of model I (Den Hartog type, ζ = 0): equal fixed-point heights
give ``Cs = 2 / (2 L ω0² − φ̄²)`` (SPEC §4), with ``L`` the coil's effective inductance at ω0
(``Im Zc(jω0)/ω0``; exactly ``L0`` for model I); Rs then minimises the peak at that Cs (1-D).

Optimum: the min-max problem is non-smooth at the equal-peak point, so a derivative-free
Nelder–Mead in ``(Rs, log Cs)`` on the log peak, with every point at or below the instability
threshold in Rs rejected (+inf), is followed by the exact peak refinement at the result.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import optimize

from ..models import Model
from .receptance import Plant, rc_impedance
from .stability import closed_loop_poles, instability_threshold, is_rational, wide_grid_impedance

__all__ = ["ShuntDesign", "ShuntEvaluation", "closed_form_rc", "design_rc_shunt", "evaluate_rc_shunt"]


@dataclass(frozen=True)
class ShuntEvaluation:
    """An RC shunt ``(Rs [Ω], Cs [F])`` evaluated on one model/parameter vector.

    ``attenuation_db = 20 log10(‖G_RC‖∞ / ‖G_open‖∞)``; ``peak``/``peak_open`` are mass-normalised
    H∞ norms [s²] at ``peak_omega``/``peak_open_omega`` [rad/s]; ``Rs_instability`` [Ω] the Rs
    below which the loop is unstable; ``stability_margin = Rs − Rs_instability`` [Ω];
    ``max_pole_real`` [1/s] the rightmost closed-loop pole (rational models only, else None).
    """

    model: str
    Rs: float
    Cs: float
    attenuation_db: float
    peak: float
    peak_omega: float
    peak_open: float
    peak_open_omega: float
    stable: bool
    Rs_instability: float
    stability_margin: float
    max_pole_real: float | None

    def to_json_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}


@dataclass(frozen=True)
class ShuntDesign(ShuntEvaluation):
    """The optimal RC shunt for one model; ``closed_form`` holds the fixed-point start
    ``{"Rs", "Cs", "attenuation_db"}`` and ``info`` the optimiser's record."""

    closed_form: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


def _effective_inductance(plant: Plant) -> float:
    zc = plant.ze(np.array([plant.omega0]), exact=True)[0] - plant.R0
    return float(zc.imag / plant.omega0)


def closed_form_rc(plant: Plant) -> tuple[float, float]:
    """Fixed-point start ``(Rs [Ω], Cs [F])`` (see module docstring)."""
    L = _effective_inductance(plant)
    den = 2 * L * plant.omega0**2 - plant.phi**2
    if den <= 0:
        raise ValueError("the fixed-point closed form needs 2 L ω0² > φ̄² "
                         f"(L = {L:.4g} H, ω0 = {plant.omega0:.4g} rad/s, φ̄ = {plant.phi:.4g})")
    Cs = 2.0 / den
    grid = wide_grid_impedance(plant.model, plant.theta)
    rs_crit = instability_threshold(plant.model, plant.theta, Cs, grid=grid, refine=False)
    zc0 = plant.ze(np.array([plant.omega0]), exact=True)[0]
    hi = -plant.R0 + 2.0 * abs(zc0)
    lo = rs_crit + 1e-6 * max(1.0, abs(rs_crit)) if np.isfinite(rs_crit) else -plant.R0 - abs(zc0)
    r = optimize.minimize_scalar(lambda rs: np.log(plant.rc_peak_fast(rs, Cs)), bounds=(lo, hi),
                                 method="bounded", options={"xatol": 1e-9})
    return float(r.x), Cs


def evaluate_rc_shunt(model: Model, theta, Rs: float, Cs: float, *, plant: Plant | None = None,
                      grid=None) -> ShuntEvaluation:
    """Attenuation and stability of the RC shunt ``(Rs, Cs)`` on ``model`` at ``theta``."""
    plant = plant or Plant(model, theta)
    pk = plant.peak(lambda s: rc_impedance(s, Rs, Cs))
    op = plant.open_peak()
    rs_crit = instability_threshold(model, theta, Cs, grid=grid)
    stable = bool(Rs > rs_crit)
    maxre = None
    if is_rational(model):
        maxre = float(np.max(closed_loop_poles(model, theta, Rs, Cs).real))
    att = 20 * math.log10(pk.value / op.value) if stable else float("nan")
    return ShuntEvaluation(model.label, float(Rs), float(Cs), att, pk.value, pk.omega, op.value,
                           op.omega, stable, float(rs_crit), float(Rs - rs_crit), maxre)


def design_rc_shunt(model: Model, theta, *, start: tuple[float, float] | None = None) -> ShuntDesign:
    """The H∞-optimal RC shunt for ``model`` at ``theta`` (SPEC §4, eq. 50).

    Parameters
    ----------
    model, theta : transducer model and physical parameter vector.
    start : optional ``(Rs, Cs)`` start; default the fixed-point closed form.
    """
    theta = np.asarray(theta, float)
    plant = Plant(model, theta)
    grid = wide_grid_impedance(model, theta)
    cf = closed_form_rc(plant)
    rs0, cs0 = start or cf

    def objective(x):
        rs, lcs = x
        cs = math.exp(lcs)
        if rs <= instability_threshold(model, theta, cs, grid=grid, refine=False):
            return np.inf
        return math.log(plant.rc_peak_fast(rs, cs))

    x0 = np.array([rs0, math.log(cs0)])
    simplex = np.array([x0, x0 + [0.02 * abs(plant.R0), 0.0], x0 + [0.0, 0.05]])
    res = optimize.minimize(objective, x0, method="Nelder-Mead",
                            options={"initial_simplex": simplex, "xatol": 1e-9, "fatol": 1e-13,
                                     "maxiter": 4000, "maxfev": 8000})
    # restart once from the result: Nelder–Mead can stall on the non-smooth ridge
    res2 = optimize.minimize(objective, res.x, method="Nelder-Mead",
                             options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 4000, "maxfev": 8000})
    best = res2 if res2.fun <= res.fun else res
    Rs, Cs = float(best.x[0]), float(math.exp(best.x[1]))
    ev = evaluate_rc_shunt(model, theta, Rs, Cs, plant=plant, grid=grid)
    cf_ev = evaluate_rc_shunt(model, theta, *cf, plant=plant, grid=grid)
    return ShuntDesign(**asdict(ev),
                       closed_form={"Rs": cf[0], "Cs": cf[1], "attenuation_db": cf_ev.attenuation_db},
                       info={"nfev": int(res.nfev + res2.nfev), "method": "Nelder-Mead (Rs, log Cs)",
                             "start": {"Rs": rs0, "Cs": cs0}})
