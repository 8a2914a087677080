"""Two-step weighted nonlinear least squares (SPEC §3.2), then an honest covariance.

Residuals are ``W(jω) (Y_model − Y_meas)`` stacked as real and imaginary parts, minimised with
``scipy.optimize.least_squares`` (trust-region reflective) in sampling space (log of positive
parameters, bounded by the prior support):

1. all parameters with ``W = 1/(jω)`` (emphasises the resonance); keep ``R0`` and ``ω0``;
2. the others with ``W = 1`` (the paper's procedure, MATLAB ``lsqnonlin`` there);
3. *polish*: all parameters with relative residuals ``(Y_model − Y_meas)/|Y_meas|`` (times the
   measurement's own weights, if any). This matches the noise of an LCR meter, whose accuracy is
   specified relative to the reading, and is the weighting under which the Jacobian covariance
   ``s² (JᵀJ)⁻¹`` is an honest standard error. Without it, ``R0`` and ``ω0`` would keep the step-1
   values and their errors would be those of a differently weighted problem.

The Jacobian is by central differences, all ``2k`` perturbed parameter sets evaluated in one
vectorised model call.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

import numpy as np
from scipy import optimize

from .checks import check_fit_inputs
from .data import Measurement
from .errors import FitError
from .guess import initial_estimate
from .models import Model, build_model
from .models.terms import uniform_rings
from .results import FitResult

__all__ = ["fit_admittance", "covariance_z", "relative_residuals", "central_jacobian",
           "batched_least_squares"]

_FD_STEP = 1e-6  # central-difference step in sampling space (relative for log parameters)


def relative_residuals(model: Model, meas: Measurement, theta) -> np.ndarray:
    """Complex ``(Y_model − Y_meas)/|Y_meas|`` per frequency."""
    return (model.admittance(meas.omega, theta) - meas.Y) / np.abs(meas.Y)


def central_jacobian(fun_batch, z, step: float = _FD_STEP):
    """Jacobian ``(m, k)`` of a batched residual ``fun_batch((B, k)) -> (B, m)`` at ``z`` by
    central differences, all ``2k`` perturbed points in one call."""
    k = z.size
    h = step * np.maximum(1.0, np.abs(z))
    stack = np.repeat(z[None, :], 2 * k, axis=0)
    idx = np.arange(k)
    stack[idx, idx] += h
    stack[k + idx, idx] -= h
    r = fun_batch(stack)
    J = (r[:k] - r[k:]) / (2 * h[:, None])
    return np.where(np.isfinite(J), J, 0.0).T


def batched_least_squares(fun_batch, z0, lo, hi, *, max_nfev: int, tol: float = 1e-14):
    """``scipy.optimize.least_squares`` (trust-region reflective, bounded) of a batched residual;
    non-finite residuals are replaced by a large value so the optimiser backs off."""

    def fun(z):
        r = fun_batch(z[None, :])[0]
        return np.where(np.isfinite(r), r, 1e10)

    z0 = np.clip(z0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
    return optimize.least_squares(fun, z0, jac=lambda z: central_jacobian(fun_batch, z), bounds=(lo, hi),
                                  method="trf", x_scale="jac", ftol=tol, xtol=tol, gtol=tol,
                                  max_nfev=max_nfev)


class _Problem:
    """Weighted residuals over a subset of free parameters (sampling space), batched."""

    def __init__(self, model: Model, meas: Measurement, weight: np.ndarray, free: np.ndarray, z_full):
        self.model, self.meas = model, meas
        self.w = weight
        self.free = free
        self.z_full = np.array(z_full, float)

    def batch(self, zf):
        z = np.broadcast_to(self.z_full, zf.shape[:-1] + self.z_full.shape).copy()
        z[..., self.free] = zf
        with np.errstate(all="ignore"):
            d = (self.model.admittance(self.meas.omega, self.model.params.from_z(z)) - self.meas.Y) * self.w
        return np.concatenate([d.real, d.imag], axis=-1)

    def residuals(self, zf):
        return self.batch(zf[None, :])[0]

    def jacobian(self, zf):
        return central_jacobian(self.batch, zf)

    def solve(self, zf0, lo, hi, max_nfev, tol=1e-14):
        return batched_least_squares(self.batch, zf0, lo, hi, max_nfev=max_nfev, tol=tol)


def covariance_z(J: np.ndarray, r: np.ndarray, n_params: int) -> np.ndarray | None:
    """``s² (JᵀJ)⁻¹`` with ``s² = Σr²/(m − k)``; pseudo-inverse via SVD, ``None`` if rank-deficient."""
    m = r.size
    if m <= n_params:
        return None
    s2 = float(r @ r) / (m - n_params)
    U, sv, Vt = np.linalg.svd(J, full_matrices=False)
    if sv[-1] <= sv[0] * 1e-13:
        return None
    return (Vt.T / sv**2) @ Vt * s2


def _as_theta(model: Model, initial) -> np.ndarray:
    if isinstance(initial, Mapping):
        return model.vector(initial)
    theta = np.asarray(initial, float)
    if theta.shape != (model.ndim,):
        raise ValueError(f"initial must have {model.ndim} values for model {model.label}")
    return theta


def fit_admittance(meas: Measurement, model: Model, *, initial=None,
                   omega_range: tuple[float | None, float | None] | None = None,
                   polish: bool = True, max_nfev: int | None = None) -> FitResult:
    """Fit ``model`` to ``meas`` from the automatic initial estimate (SPEC §3.1–3.2).

    Parameters
    ----------
    meas : measurement (angular frequencies in rad/s, admittance in S).
    model : the model to fit.
    initial : optional start (dict or vector of physical values); default: automatic.
    omega_range : optional (omega_min, omega_max) [rad/s] to restrict the data.
    polish : run step 3 (relative residuals, all parameters) after the paper's two steps.
    max_nfev : evaluation budget of the final polish (default 25 per parameter; the intermediate
        steps get at most 30 per parameter). A polish that runs out reports ``success=False``.

    Returns
    -------
    FitResult with physical values, sampling-space covariance, chi² and rms relative residual.
    """
    t0 = time.perf_counter()
    if omega_range is not None:
        meas = meas.select(*omega_range)
    check_fit_inputs(meas, model.ndim, label=model.label)
    info: dict = {}
    if initial is None and model.name == "NL":
        # SPEC §3.1: NL starts from the uniform-core estimate through the UL formulas; fitting
        # UL (3 coil parameters) first puts the 2n+1 ring parameters much closer
        ul = fit_admittance(meas, build_model("UL", rings=model.rings, n_turns=model.n_turns),
                            polish=True, max_nfev=max_nfev)
        p = ul.parameters
        Pg, P, R = uniform_rings(p["Lg"], p["alpha"], p["beta"], model.rings, model.n_turns)
        theta0 = np.concatenate([ul.theta[:4], [Pg], P, R])
        info["initial"] = {"path": "UL fit -> uniform rings", "UL": p,
                           "UL_initial": ul.info.get("initial")}
    elif initial is None:
        ie = initial_estimate(meas, model)
        theta0 = ie.theta
        info["initial"] = {"path": ie.path, "band_rad_s": list(ie.band),
                           "rms_rel_residual": ie.rms_rel_residual}
    else:
        theta0 = _as_theta(model, initial)
        info["initial"] = {"path": "user"}
    k = model.ndim
    max_nfev = max_nfev or 25 * k
    lo, hi = model.params.bounds_z()
    z = model.params.to_z(theta0)
    s = 1j * meas.omega
    all_free = np.ones(k, bool)
    steps = []

    def run(weight, free, label):
        nonlocal z
        w = weight / np.sqrt(np.mean(np.abs(weight * meas.Y) ** 2))  # residuals of order one
        prob = _Problem(model, meas, w, np.flatnonzero(free), z)
        # the intermediate steps only hand on a starting point (and R0, omega0): a looser
        # tolerance and budget; ill-conditioned valleys (NL with 1/s weighting) would otherwise
        # crawl for thousands of evaluations towards the same end point the polish reaches
        sol = prob.solve(z[free], lo[free], hi[free], min(max_nfev, 30 * k), tol=1e-10)
        z = z.copy()
        z[free] = sol.x
        steps.append({"step": label, "nfev": int(sol.nfev), "cost": float(sol.cost),
                      "status": int(sol.status), "message": sol.message})
        return sol, prob

    # start-up: the relative-residual problem converges fast and robustly from the linearised
    # estimate; the paper's steps then start close to their own optima
    run(1.0 / np.abs(meas.Y), all_free, "0: start-up, all parameters, relative residuals")
    run(1.0 / np.abs(s), all_free, "1: all parameters, W = 1/s")
    keep = np.isin(model.names, ("R0", "omega0"))
    sol, prob = run(np.ones(meas.n_points), ~keep, "2: R0, omega0 fixed, W = 1")
    if polish:
        wrel = 1.0 / np.abs(meas.Y)
        if meas.weights is not None:
            wrel = wrel * meas.weights
        # undo the order-one normalisation so residuals are the relative errors themselves
        prob = _Problem(model, meas, wrel, np.arange(k), z)
        sol = prob.solve(z, lo, hi, max_nfev)
        z = sol.x
        steps.append({"step": "3: polish, all parameters, relative residuals", "nfev": int(sol.nfev),
                      "cost": float(sol.cost), "status": int(sol.status), "message": sol.message})
    else:
        prob = _Problem(model, meas, 1.0 / np.abs(meas.Y), np.arange(k), z)
    r = prob.residuals(z)
    J = prob.jacobian(z)
    theta = model.params.from_z(z)
    if not np.all(np.isfinite(theta)):
        raise FitError(f"{meas.source}: the fit of model {model.label} diverged")
    rel = relative_residuals(model, meas, theta)
    info["steps"] = steps
    info["seconds"] = time.perf_counter() - t0
    at_bound = [n for n, zi, a, b in zip(model.names, z, lo, hi, strict=True)
                if np.isclose(zi, a, atol=1e-6) or np.isclose(zi, b, atol=1e-6)]
    if at_bound:
        info["at_prior_bound"] = at_bound
    return FitResult(model=model, theta=theta, cov_z=covariance_z(J, r, k),
                     chi2=float(r @ r), rms_rel_residual=float(np.sqrt(np.mean(np.abs(rel) ** 2))),
                     n_points=meas.n_points, success=bool(sol.status > 0), message=str(sol.message),
                     initial=theta0, info=info)
