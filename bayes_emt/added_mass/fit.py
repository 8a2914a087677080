"""Physical parameters from an added-mass pair of recordings (the source paper's Appendix B).

The terminals alone give ``ω0``, ``ζ`` and the mass-normalised coupling ``φ̄ = φ/√m``; a second
recording with a known mass change ``Δm`` [kg] (``m' = m + Δm``) separates ``m``:

    m = Δm ω0'² / (ω0² − ω0'²),   k = m ω0²,   c = 2 ζ √(m k) = 2 ζ m ω0,   φ = φ̄ √m.

Two ways are offered.

* :func:`physical_from_two_fits` applies these formulas to two separate fits (the paper's way),
  with first-order error propagation from the fits' covariances. It uses ``ζ`` and ``φ̄`` of the
  base run only; what the loaded run's ``ζ'`` and ``φ̄'`` *should* be is returned beside it.
* :func:`fit_added_mass` fits both recordings *jointly*: one parameter vector
  ``(m, c, k, phi_raw, R0, coil...)`` shared by both runs, the base run seeing ``m`` and the loaded
  run ``m + Δm``, so every datum constrains every physical parameter once and consistently
  (:class:`JointModel` maps it to each run's model vector). An F-test of the joint fit against the
  two separate fits says whether the pair is consistent with shared physics at all.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .._json import strict_json
from ..errors import FitError
from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import Model
from ..models.residual import relative_residual, rms_relative_residual
from ..params import LogUniform, ParamSet, ParamSpec

__all__ = ["physical_from_two_fits", "mechanics_from_physical", "fit_added_mass", "JointModel",
           "AddedMassResult", "PHYSICAL_NAMES", "PHYSICAL_UNITS", "PHYSICAL_PARAMS"]

#: the physical parameters an added-mass pair separates, with their default priors:
#: log-uniform over ten decades or more, bracketing a 1 cm tweeter to the paper's 2 kg shaker
PHYSICAL_PARAMS = ParamSet([
    ParamSpec("m", "kg", r"$m$", LogUniform(1e-6, 1e4), "moving mass"),
    ParamSpec("c", "N s/m", r"$c$", LogUniform(1e-9, 1e6), "mechanical viscous damping"),
    ParamSpec("k", "N/m", r"$k$", LogUniform(1e-6, 1e10), "mechanical stiffness"),
    ParamSpec("phi_raw", "N/A", r"$\varphi$", LogUniform(1e-6, 1e4),
              "electromechanical coupling (force factor Bl)"),
])
PHYSICAL_NAMES = PHYSICAL_PARAMS.names
PHYSICAL_UNITS = dict(zip(PHYSICAL_NAMES, PHYSICAL_PARAMS.units, strict=True))
_MECH = ("zeta", "omega0", "phi")


def mechanics_from_physical(m, c, k, phi_raw):
    """``(ζ, ω0 [rad/s], φ̄ [N/(A kg^½)])`` of a run with moving mass ``m`` [kg] (vectorised)."""
    m, c, k, phi_raw = (np.asarray(a, float) for a in (m, c, k, phi_raw))
    with np.errstate(invalid="ignore", divide="ignore"):
        return c / (2 * np.sqrt(m * k)), np.sqrt(k / m), phi_raw / np.sqrt(m)


def _physical_and_jacobian(x, delta_m):
    """``[m, c, k, φ]`` and its exact Jacobian w.r.t. ``x = (ζ, ω0, φ̄, ζ', ω0', φ̄')``."""
    zeta, w, phib, _, v, _ = x
    D = w * w - v * v
    m = delta_m * v * v / D
    dm = np.zeros(6)
    dm[1] = -2 * delta_m * v * v * w / D**2
    dm[4] = 2 * delta_m * v * w * w / D**2
    vals = np.array([m, 2 * zeta * m * w, m * w * w, phib * math.sqrt(m)])
    J = np.zeros((4, 6))
    J[0] = dm
    J[1] = 2 * zeta * w * dm
    J[1, 0] += 2 * m * w
    J[1, 1] += 2 * zeta * m
    J[2] = w * w * dm
    J[2, 1] += 2 * m * w
    J[3] = phib / (2 * math.sqrt(m)) * dm
    J[3, 2] += math.sqrt(m)
    return vals, J


def _mech_cov(fit: FitResult) -> np.ndarray | None:
    """3×3 covariance of ``(ζ, ω0, φ̄)`` in physical units from a fit's sampling-space covariance."""
    if fit.cov_z is None:
        return None
    idx = [fit.model.params.index(n) for n in _MECH]
    d = np.array([abs(fit.theta[i]) if fit.model.params[i].transform == "log" else 1.0 for i in idx])
    return fit.cov_z[np.ix_(idx, idx)] * np.outer(d, d)


def physical_from_two_fits(base: Mapping[str, float] | FitResult, loaded: Mapping[str, float] | FitResult,
                           delta_m: float, *, base_cov: np.ndarray | None = None,
                           loaded_cov: np.ndarray | None = None) -> dict:
    """``m, c, k, phi_raw`` [kg, N s/m, N/m, N/A] from two separate fits (module docstring formulas).

    Parameters
    ----------
    base, loaded : the fitted ``zeta, omega0, phi`` of the run without and with the added mass
        (dicts, or :class:`~bayes_emt.estimation.results.FitResult`, whose covariances are then used).
    delta_m : mass added for the loaded run [kg] (negative: removed; the paper: −0.645).
    base_cov, loaded_cov : optional 3×3 covariances of ``(ζ, ω0, φ̄)`` [physical units]; the two
        runs are independent, so the joint covariance is block-diagonal.

    Returns
    -------
    dict with ``m, c, k, phi_raw``; ``stderr`` (first-order propagation, exact Jacobian) when both
    covariances are known; ``predicted_loaded``: the ``zeta`` and ``phi`` the loaded run should
    show with these physical values, ``ζ' = c/(2√(m'k))``, ``φ̄' = φ/√m'``, ``m' = m + Δm``.

    Raises
    ------
    FitError if the implied mass (or the loaded mass) is not positive: the resonance moved the
    wrong way for the sign of ``delta_m``.
    """
    if isinstance(base, FitResult):
        base_cov = _mech_cov(base) if base_cov is None else base_cov
        base = base.parameters
    if isinstance(loaded, FitResult):
        loaded_cov = _mech_cov(loaded) if loaded_cov is None else loaded_cov
        loaded = loaded.parameters
    if not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"delta_m must be a non-zero mass in kg, got {delta_m!r}")
    x = np.array([base[n] for n in _MECH] + [loaded[n] for n in _MECH], float)
    with np.errstate(divide="ignore", invalid="ignore"):
        m = delta_m * x[4] ** 2 / (x[1] ** 2 - x[4] ** 2)
    if not (np.isfinite(m) and m > 0 and m + delta_m > 0):
        raise FitError(f"the two recordings imply a non-positive mass (m = {m:.4g} kg, m + Δm = "
                       f"{m + delta_m:.4g} kg): the resonance should {'fall' if delta_m > 0 else 'rise'} "
                       f"when {delta_m:+g} kg is added (ω0 = {x[1]:.5g} → {x[4]:.5g} rad/s)")
    vals, J = _physical_and_jacobian(x, delta_m)
    out: dict = dict(zip(PHYSICAL_NAMES, map(float, vals), strict=True))
    if base_cov is not None and loaded_cov is not None:
        C = np.zeros((6, 6))
        C[:3, :3], C[3:, 3:] = base_cov, loaded_cov
        se = np.sqrt(np.clip(np.diag(J @ C @ J.T), 0, None))
        out["stderr"] = dict(zip(PHYSICAL_NAMES, map(float, se), strict=True))
    z2, _, p2 = mechanics_from_physical(m + delta_m, vals[1], vals[2], vals[3])
    out["predicted_loaded"] = {"zeta": float(z2), "phi": float(p2)}
    return out


@dataclass(frozen=True)
class JointModel:
    """Two runs of one transducer differing by a known mass ``delta_m`` [kg].

    The joint parameter vector is ``(m, c, k, phi_raw)`` (priors ``physical``, default
    :data:`PHYSICAL_PARAMS`) followed by the model's other parameters
    (``R0`` and the coil), in :attr:`params` order; :meth:`thetas` maps it (vectorised over
    leading axes) to each run's model vector ``(ζ, ω0, φ̄, R0, coil...)`` for
    :meth:`Model.admittance <bayes_emt.models.Model.admittance>`.
    """

    model: Model
    delta_m: float
    physical: ParamSet | None = None
    params: ParamSet = field(init=False)
    shared: tuple[str, ...] = field(init=False)

    def __post_init__(self):
        default = PHYSICAL_PARAMS
        if self.physical is None:
            object.__setattr__(self, "physical", default)
        elif self.physical.names != default.names:
            raise ValueError(f"physical parameters must be {list(PHYSICAL_NAMES)}, "
                             f"got {list(self.physical.names)}")
        missing = [n for n in _MECH if n not in self.model.names]
        if missing:
            raise ValueError(f"model {self.model.label} lacks {missing}; an added-mass fit needs {_MECH}")
        shared = tuple(n for n in self.model.names if n not in _MECH)
        object.__setattr__(self, "shared", shared)
        object.__setattr__(self, "params", self.physical + ParamSet([self.model.params[n] for n in shared]))

    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    def thetas(self, x) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_base, theta_loaded)``, each ``(..., model.ndim)``, from joint ``x (..., p)``."""
        x = np.asarray(x, float)
        m, c, k, phi = (x[..., i] for i in range(4))
        out = []
        for mass in (m, m + self.delta_m):
            mech = dict(zip(_MECH, mechanics_from_physical(mass, c, k, phi), strict=True))
            cols = [mech[n] if n in mech else x[..., 4 + self.shared.index(n)] for n in self.model.names]
            out.append(np.stack(cols, axis=-1))
        return out[0], out[1]

    def start(self, base_theta, loaded_theta, physical: Mapping[str, float]) -> np.ndarray:
        """A joint vector from two separate fits: ``physical`` (``m, c, k, phi_raw``) and the
        shared parameters averaged in sampling space (geometric mean of positive parameters)."""
        zb, zl = self.model.params.to_z(base_theta), self.model.params.to_z(loaded_theta)
        idx = [self.model.params.index(n) for n in self.shared]
        shared = self.model.params.from_z(0.5 * (zb + zl))[idx]
        return np.concatenate([[physical[n] for n in PHYSICAL_NAMES], shared])


@dataclass(frozen=True)
class AddedMassResult:
    """Joint fit of an added-mass pair (:func:`fit_added_mass`).

    Attributes
    ----------
    model : the transducer model both runs share.
    delta_m : mass added for the loaded run [kg].
    values : joint estimate, ``m, c, k, phi_raw`` then ``R0`` and the coil parameters [SI].
    stderr : standard errors of ``values`` [SI] (delta method through the log transform).
    cov_z : covariance of the joint vector in sampling space (``None`` if singular).
    base, loaded : each run's model parameters implied by ``values`` (``ζ, ω0, φ̄, R0, ...``).
    separate : the two separate fits' parameters, ``{"base": {...}, "loaded": {...}}``.
    two_fit : :func:`physical_from_two_fits` of the separate fits (with ``stderr`` and
        ``predicted_loaded``), for comparison.
    noise_rel : each run's relative residual scale from its separate fit; residuals are divided by
        it, so both runs count by their own scatter.
    consistency : F-test of the joint fit (``model.ndim + 1`` parameters) against the two separate
        fits (``2 model.ndim``): ``F``, ``dof`` (numerator, denominator), ``p_value``; a small
        p-value means the pair does not share one set of physical and coil parameters.
    rms_rel_residual : (base, loaded) rms of ``|Y_fit − Y|/|Y|``.
    success, message : the optimiser's report.
    """

    model: Model
    delta_m: float
    values: dict
    stderr: dict
    cov_z: np.ndarray | None
    base: dict
    loaded: dict
    separate: dict
    two_fit: dict
    noise_rel: tuple[float, float]
    consistency: dict
    rms_rel_residual: tuple[float, float]
    success: bool
    message: str = ""

    def to_json_dict(self) -> dict:
        """The ``bayes-emt added-mass --json`` record (SI units)."""
        units = {**PHYSICAL_UNITS, **{n: self.model.params[n].unit for n in self.values
                                      if n not in PHYSICAL_UNITS}}
        rec = {"method": "joint", "model": self.model.spec, "rings": self.model.rings,
                "n_turns": self.model.n_turns, "delta_m": self.delta_m,
                **{k: self.values[k] for k in PHYSICAL_NAMES},
                "stderr": self.stderr,
                "units": units, "shared": {k: v for k, v in self.values.items() if k not in PHYSICAL_UNITS},
                "base_parameters": self.base, "loaded_parameters": self.loaded,
                "separate_fits": self.separate, "two_fit": self.two_fit, "consistency": self.consistency,
                "noise_rel": list(self.noise_rel), "rms_rel_residual": list(self.rms_rel_residual),
                "success": self.success, "message": self.message}
        return strict_json(rec)


def _rel_residuals(model: Model, meas: Measurement, theta):
    """Relative residuals (:func:`~bayes_emt.models.residual.relative_residual`, times the
    measurement's weights), real and imaginary parts stacked."""
    with np.errstate(all="ignore"):
        d = relative_residual(model, theta, meas)
        if meas.weights is not None:
            d = d * meas.weights
    return np.concatenate([d.real, d.imag], axis=-1)


def solve_joint(batch, params, x0, lo, hi, max_nfev=None):
    """Bounded least squares of the stacked residuals ``batch`` from ``x0`` [SI], in sampling space
    (every added-mass joint fit): the optimiser's result, the residual vector, the covariance in
    sampling space (``None`` when singular), the solution [SI] and its standard errors [SI] (delta
    method through the transform)."""
    from ..estimation.fitting import batched_least_squares, central_jacobian, covariance_z

    p = np.asarray(x0).size
    sol = batched_least_squares(batch, params.to_z(x0), lo, hi, max_nfev=max_nfev or 50 * p)
    r = batch(sol.x[None, :])[0]
    cov = covariance_z(central_jacobian(batch, sol.x), r, p)
    x = params.from_z(sol.x)
    se = np.full(p, np.nan) if cov is None else np.sqrt(np.clip(np.diag(cov), 0, None))
    se = np.array([abs(v) * s if spec.transform == "log" else s
                   for spec, v, s in zip(params, x, se, strict=True)])
    return sol, r, cov, x, se


def fit_added_mass(base: Measurement, loaded: Measurement, delta_m: float, model: Model, *,
                   base_fit: FitResult | None = None, loaded_fit: FitResult | None = None,
                   max_nfev: int | None = None) -> AddedMassResult:
    """Joint least-squares fit of an added-mass pair with shared physical and coil parameters.

    Parameters
    ----------
    base, loaded : the recordings without and with the added mass (rad/s, S).
    delta_m : mass added for ``loaded`` [kg] (negative: removed).
    model : the coil model both runs share.
    base_fit, loaded_fit : separate fits of each run with ``model``; by default
        :func:`~bayes_emt.estimation.fitting.fit_admittance` from its automatic initial estimate. They
        should be optima of the relative residuals (as ``fit_admittance`` returns): they set
        each run's noise scale and the reference of the consistency F-test (a start that is not
        an optimum makes the test conservative).
    max_nfev : evaluation budget of the joint fit (default 50 per parameter).

    Notes
    -----
    Minimises ``Σ_runs Σ_ω |Y_model − Y|²/(|Y|² s_run²)`` over ``(m, c, k, phi_raw, R0, coil...)`` in
    sampling space (log of positive parameters, bounded by the priors' support and by
    ``m + Δm > 0``), where ``s_run`` is the run's relative residual scale from its separate fit.
    The start is the two-fit formula result and the shared parameters averaged. The covariance is
    ``s² (JᵀJ)⁻¹`` as for single fits (``s² ≈ 1`` for a consistent pair).

    A joint fit exposes what separate fits hide. The paper's Tables 5 and B.8 give
    ``m = 1.73 kg`` and ``φ = 2.51 N/A`` (Table B.9) from the base run's ``φ̄ = 1.91``, but then the
    loaded run (``m − 0.645 kg``) should show ``φ̄' = 2.51/√1.085 ≈ 2.41``, not the reported 2.26
    (its Table B.9), and ``ζ'`` should be ``c/(2√(m'k)) ≈ 0.0138``, not 0.00927: no single ``(m, c, k, φ)``
    explains both tables, which the joint fit's residuals and :attr:`AddedMassResult.consistency`
    show where the formulas silently return the base run's values.
    """
    from ..estimation.fitting import fit_admittance

    if not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"delta_m must be a non-zero mass in kg, got {delta_m!r}")
    jm = JointModel(model, float(delta_m))
    fits = []
    for meas, fit in ((base, base_fit), (loaded, loaded_fit)):
        if fit is None:
            fit = fit_admittance(meas, model)
        elif fit.model.names != model.names:
            raise ValueError(f"a separate fit of model {fit.model.label} cannot start a joint "
                             f"{model.label} fit")
        fits.append(fit)
    bf, lf = fits
    two = physical_from_two_fits(bf, lf, delta_m)
    chi2_sep, noise = [], []
    for meas, fit in zip((base, loaded), fits, strict=True):
        r = _rel_residuals(model, meas, fit.theta)
        chi2_sep.append(float(r @ r))
        noise.append(math.sqrt(chi2_sep[-1] / max(r.size - model.ndim, 1)))
    if not all(s > 0 for s in noise):
        noise = [1.0, 1.0]  # exact (noise-free) data: plain relative residuals

    def batch(z):
        tb, tl = jm.thetas(jm.params.from_z(z))
        out = np.concatenate([_rel_residuals(model, base, tb) / noise[0],
                              _rel_residuals(model, loaded, tl) / noise[1]], axis=-1)
        return np.where(np.isfinite(out), out, 1e10)

    x0 = jm.start(bf.theta, lf.theta, two)
    lo, hi = jm.params.bounds_z()
    if delta_m < 0:  # the loaded mass m + Δm must stay positive
        lo[0] = max(lo[0], float(jm.params[0].to_z(-delta_m * (1 + 1e-9))))
    p = x0.size
    sol, r, cov, x, se = solve_joint(batch, jm.params, x0, lo, hi, max_nfev)
    tb, tl = jm.thetas(x)
    # F-test: joint (p parameters) nested in the two separate fits (2 k parameters)
    chi2_joint, chi2_s = float(r @ r), chi2_sep[0] / noise[0] ** 2 + chi2_sep[1] / noise[1] ** 2
    q, dof = 2 * model.ndim - p, r.size - 2 * model.ndim
    F = max(chi2_joint - chi2_s, 0.0) / q / (chi2_s / dof) if chi2_s > 0 else float("nan")
    consistency = {"F": float(F), "dof": [q, dof], "p_value": float(stats.f.sf(F, q, dof)),
                   "chi2_joint": chi2_joint, "chi2_separate": chi2_s}
    rms = [rms_relative_residual(model, t, ms) for ms, t in ((base, tb), (loaded, tl))]
    return AddedMassResult(
        model=model, delta_m=float(delta_m), values=dict(zip(jm.names, map(float, x), strict=True)),
        stderr=dict(zip(jm.names, map(float, se), strict=True)), cov_z=cov,
        base=model.as_dict(tb), loaded=model.as_dict(tl),
        separate={"base": bf.parameters, "loaded": lf.parameters}, two_fit=two,
        noise_rel=(noise[0], noise[1]), consistency=consistency, rms_rel_residual=(rms[0], rms[1]),
        success=bool(sol.status > 0), message=str(sol.message))
