"""Physical parameters from an added-mass pair of recordings (SPEC §3.4, the paper's Appendix B).

The terminals alone give ``ω0``, ``ζ`` and the mass-normalised coupling ``φ̄ = φ/√m``; a second
recording with a known mass change ``Δm`` separates ``m``:

    m = Δm ω0'² / (ω0² − ω0'²),  k = m ω0²,  c = 2 ζ √(m k),  φ = φ̄ √m.

Two ways are offered. :func:`physical_from_two_fits` applies these formulas to two separate fits
(the paper's way), propagating their covariances. :func:`fit_added_mass` fits both recordings
*jointly* with shared physical parameters ``(m, c, k, φ)`` plus shared ``R0`` and coil parameters,
so every constraint is used once and consistently. A joint fit also exposes inconsistencies the
paper's tables hide: with ``φ = 2.51 N/A`` and ``m − 0.645 kg`` the loaded run would have
``φ̄' ≈ 2.41``, not the reported 2.26 (SPEC §5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .data import Measurement
from .errors import FitError
from .fitting import batched_least_squares, central_jacobian, covariance_z, fit_admittance
from .models import Model
from .results import FitResult

__all__ = ["physical_from_two_fits", "fit_added_mass", "AddedMassResult", "PHYSICAL_UNITS"]

PHYSICAL_UNITS = {"m": "kg", "c": "N s/m", "k": "N/m", "phi_raw": "N/A"}


def _physical(zeta, omega0, phi, zeta2, omega02, phi2, delta_m):
    del zeta2, phi2  # the loaded run's damping and coupling are not needed by the formulas
    m = delta_m * omega02**2 / (omega0**2 - omega02**2)
    k = m * omega0**2
    return np.array([m, 2 * zeta * np.sqrt(m * k), k, phi * np.sqrt(m)])


def physical_from_two_fits(base: Mapping[str, float], loaded: Mapping[str, float], delta_m: float,
                           *, base_cov: np.ndarray | None = None,
                           loaded_cov: np.ndarray | None = None) -> dict:
    """``m, c, k, phi_raw`` [SI] from the (ζ, ω0, φ̄) of two fits and the added mass ``delta_m`` [kg].

    ``base_cov``/``loaded_cov``: optional 3×3 covariances of ``(ζ, ω0, φ̄)`` (physical units) for
    first-order error propagation; the result then has a ``stderr`` entry.
    """
    x = np.array([base["zeta"], base["omega0"], base["phi"], loaded["zeta"], loaded["omega0"], loaded["phi"]],
                 float)
    if not math.isfinite(delta_m) or delta_m == 0:
        raise ValueError(f"delta_m must be a non-zero mass in kg, got {delta_m!r}")
    vals = _physical(*x, delta_m)
    if not vals[0] > 0:
        raise FitError(f"the two recordings imply a non-positive mass (m = {vals[0]:.4g} kg): the "
                       f"resonance should {'fall' if delta_m > 0 else 'rise'} when {delta_m:+g} kg is added "
                       f"(ω0 = {x[1]:.5g} → {x[4]:.5g} rad/s)")
    out = dict(zip(("m", "c", "k", "phi_raw"), (float(v) for v in vals), strict=True))
    if base_cov is not None and loaded_cov is not None:
        C = np.zeros((6, 6))
        C[:3, :3], C[3:, 3:] = base_cov, loaded_cov
        J = np.zeros((4, 6))
        for j in range(6):
            h = 1e-7 * abs(x[j])
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            J[:, j] = (_physical(*xp, delta_m) - _physical(*xm, delta_m)) / (2 * h)
        se = np.sqrt(np.diag(J @ C @ J.T))
        out["stderr"] = dict(zip(("m", "c", "k", "phi_raw"), (float(v) for v in se), strict=True))
    return out


@dataclass(frozen=True)
class AddedMassResult:
    """Joint fit of an added-mass pair.

    ``values``: ``m, c, k, phi_raw`` and the shared electrical parameters [SI]; ``stderr`` alike;
    ``base``/``loaded``: each recording's implied model parameters (ζ, ω0, φ̄, ...);
    ``two_fit``: the separate-fit formula result for comparison; rms relative residuals per run.
    """

    model: Model
    delta_m: float
    values: dict
    stderr: dict
    base: dict
    loaded: dict
    two_fit: dict
    rms_rel_residual: tuple[float, float]
    success: bool

    def to_json_dict(self) -> dict:
        return {"method": "joint", "model": self.model.name, "rings": self.model.rings,
                "delta_m": self.delta_m, **{k: self.values[k] for k in PHYSICAL_UNITS},
                "stderr": self.stderr, "shared": {k: v for k, v in self.values.items()
                                                  if k not in PHYSICAL_UNITS},
                "units": PHYSICAL_UNITS, "base_parameters": self.base, "loaded_parameters": self.loaded,
                "two_fit": self.two_fit, "rms_rel_residual": list(self.rms_rel_residual),
                "success": self.success}


class _JointModel:
    """Maps the joint vector ``(m, c, k, phi_raw, R0, coil...)`` to both recordings' model vectors."""

    def __init__(self, model: Model, delta_m: float):
        self.model, self.delta_m = model, delta_m
        self.shared = [n for n in model.names if n not in ("zeta", "omega0", "phi")]
        self.names = list(PHYSICAL_UNITS) + self.shared

    def thetas(self, x):
        x = np.asarray(x, float)
        m, c, k, phi = (x[..., i] for i in range(4))
        out = []
        for mass in (m, m + self.delta_m):
            with np.errstate(invalid="ignore", divide="ignore"):
                mech = {"zeta": c / (2 * np.sqrt(mass * k)), "omega0": np.sqrt(k / mass),
                        "phi": phi / np.sqrt(mass)}
            cols = [mech[n] if n in mech else x[..., 4 + self.shared.index(n)] for n in self.model.names]
            out.append(np.stack(cols, axis=-1))
        return out


def fit_added_mass(base: Measurement, loaded: Measurement, delta_m: float, model: Model, *,
                   base_fit: FitResult | None = None, loaded_fit: FitResult | None = None) -> AddedMassResult:
    """Joint least-squares fit of an added-mass pair (module docstring), started from two fits.

    All joint parameters are positive and fitted in log space; residuals are relative, as in the
    single-recording polish, so the covariance is comparable.
    """
    bf = base_fit or fit_admittance(base, model)
    lf = loaded_fit or fit_admittance(loaded, model)
    two = physical_from_two_fits(bf.parameters, lf.parameters, delta_m)
    jm = _JointModel(model, delta_m)
    idx = [model.params.index(n) for n in jm.shared]
    shared0 = np.sqrt(bf.theta[idx] * lf.theta[idx])  # geometric mean of the two fits
    x0 = np.concatenate([[two[k] for k in PHYSICAL_UNITS], shared0])
    w_b, w_l = 1 / np.abs(base.Y), 1 / np.abs(loaded.Y)
    loaded_mass_ok = two["m"] + delta_m > 0
    if not loaded_mass_ok:
        raise FitError(f"added mass {delta_m} kg makes the loaded mass negative (m = {two['m']:.4g} kg)")

    def batch(z):
        tb, tl = jm.thetas(np.exp(z))
        with np.errstate(all="ignore"):
            db = (model.admittance(base.omega, tb) - base.Y) * w_b
            dl = (model.admittance(loaded.omega, tl) - loaded.Y) * w_l
        return np.concatenate([db.real, db.imag, dl.real, dl.imag], axis=-1)

    lo = np.log(np.r_[1e-6, 1e-9, 1e-6, 1e-6, [model.params[n].prior.lower for n in jm.shared]])
    hi = np.log(np.r_[1e4, 1e6, 1e10, 1e4, [model.params[n].prior.upper for n in jm.shared]])
    if delta_m < 0:
        lo[0] = math.log(-delta_m * (1 + 1e-9))  # the loaded mass m + Δm must stay positive
    sol = batched_least_squares(batch, np.log(x0), lo, hi, max_nfev=40 * x0.size)
    r = sol.fun
    cov = covariance_z(central_jacobian(batch, sol.x), r, x0.size)
    x = np.exp(sol.x)
    se = (x * np.sqrt(np.diag(cov))) if cov is not None else np.full(x.size, np.nan)
    tb, tl = jm.thetas(x)
    rel = [float(np.sqrt(np.mean(np.abs(model.admittance(ms.omega, t) - ms.Y) ** 2 / np.abs(ms.Y) ** 2)))
           for ms, t in ((base, tb), (loaded, tl))]
    return AddedMassResult(model, float(delta_m), dict(zip(jm.names, map(float, x), strict=True)),
                           dict(zip(jm.names, map(float, se), strict=True)), model.as_dict(tb),
                           model.as_dict(tl), two, (rel[0], rel[1]), bool(sol.status > 0))
