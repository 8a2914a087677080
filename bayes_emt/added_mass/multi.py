"""Several added-mass recordings in one joint fit and one joint posterior ("dual added mass").

Generalises :class:`~bayes_emt.added_mass.JointModel` from one loaded run to any number: one
vector ``(m, c, k, phi_raw, R0, coil..., λ...)`` explains the free-air run (moving mass ``m``)
and every loaded run ``i`` (mass ``m + Δm_i``). Speakerbench asks for two added masses (the
second about double the first, ideally of the order of Mms; https://speakerbench.com/manual/),
REW's T/S tool and the classic added-mass method for one; any number works here.

Creep. With the LOG creep term (``suspension_creep``, Knudsen & Jensen 1993) the model's
stiffness is referred to the run's own ``ω0``: ``C(jω) = (1/k)[1 + λ ln(ω0/jω)]``. One physical
suspension seen at different resonances needs, for a run whose resonance is ``ω_i``, the
``(k_i, λ_i)`` that give the *same* compliance function: ``λ_i/k_i = λ/k`` and
``1/k_i = 1/k + (λ/k) ln(ω_b/ω_i)`` with ``ω_b = √(k/m)`` (the free-air reference) and
``ω_i = √(k_i/(m + Δm_i))``, solved by a fixed-point iteration (λ ≤ 0.5: contraction).
Without this, a joint fit of a creeping driver would give each run a different suspension.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..errors import FitError
from ..estimation.results import FitResult
from ..inference.likelihood import (
    Likelihood,
    SamplingSpaceDensity,
    _sha256,
    measurement_sha256,
    noise_param_set,
)
from ..measurement import Measurement
from ..models import Model
from ..params import ParamSet
from .fit import (
    PHYSICAL_NAMES,
    PHYSICAL_PARAMS,
    _rel_residuals,
    mechanics_from_physical,
    physical_from_two_fits,
    solve_joint,
)
from .posterior import _run_noise

__all__ = ["MultiMassModel", "MultiMassFit", "MultiMassLikelihood", "fit_multi_mass", "sample_multi_mass"]

_MECH = ("zeta", "omega0", "phi")
_CREEP = "lambda_creep"


@dataclass(frozen=True)
class MultiMassModel:
    """Runs of one transducer differing by known masses ``deltas`` [kg] (the first run is the
    reference, Δm = 0, and is not listed). Joint vector: ``m, c, k, phi_raw`` then the model's
    other parameters (``R0``, coil, ``lambda_creep``...) shared by all runs."""

    model: Model
    deltas: tuple[float, ...]
    params: ParamSet = field(init=False)
    shared: tuple[str, ...] = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "deltas", tuple(float(d) for d in self.deltas))
        if not self.deltas or not all(math.isfinite(d) and d != 0 for d in self.deltas):
            raise ValueError(f"added masses must be non-zero finite masses in kg, got {list(self.deltas)}")
        missing = [n for n in _MECH if n not in self.model.names]
        if missing:
            raise ValueError(f"model {self.model.label} lacks {missing}; an added-mass fit needs {_MECH}")
        shared = tuple(n for n in self.model.names if n not in _MECH)
        object.__setattr__(self, "shared", shared)
        phys = ParamSet([PHYSICAL_PARAMS[n] for n in PHYSICAL_NAMES])
        object.__setattr__(self, "params", phys + ParamSet([self.model.params[n] for n in shared]))

    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    @property
    def n_runs(self) -> int:
        return 1 + len(self.deltas)

    def thetas(self, x) -> list[np.ndarray]:
        """Each run's model vector ``(..., model.ndim)`` from the joint ``x (..., p)``."""
        x = np.asarray(x, float)
        m, c, k, phi = (x[..., i] for i in range(4))
        lam = x[..., 4 + self.shared.index(_CREEP)] if _CREEP in self.shared else None
        out = []
        for dm in (0.0, *self.deltas):
            mass = m + dm
            k_i, lam_i = k, lam
            if lam is not None and dm != 0.0:
                w_b = np.sqrt(k / m)
                k_i = k
                for _ in range(30):  # fixed point of 1/k_i = 1/k + (λ/k) ln(ω_b/ω_i)
                    w_i = np.sqrt(np.clip(k_i, 1e-300, None) / mass)
                    k_i = 1.0 / (1.0 / k + lam / k * np.log(w_b / w_i))
                lam_i = lam * k_i / k
            z, w, p = mechanics_from_physical(mass, c, k_i, phi)
            mech = {"zeta": z, "omega0": w, "phi": p}
            cols = []
            for n in self.model.names:
                if n in mech:
                    cols.append(mech[n])
                elif n == _CREEP and lam_i is not None:
                    cols.append(np.broadcast_to(lam_i, m.shape))
                else:
                    cols.append(x[..., 4 + self.shared.index(n)])
            out.append(np.stack(cols, axis=-1))
        return out

    def start(self, fits: Sequence[FitResult]) -> np.ndarray:
        """A joint vector from separate fits: ``m`` from the base run and each loaded run by the
        two-fit formula (median), ``c, k, phi_raw`` from it, the shared parameters averaged in
        sampling space."""
        ms = []
        for f, dm in zip(fits[1:], self.deltas, strict=True):
            try:
                ms.append(physical_from_two_fits(fits[0], f, dm)["m"])
            except FitError:
                continue
        if not ms:
            raise FitError("no loaded run moves the resonance the way its added mass says: cannot "
                           "estimate the moving mass")
        m = float(np.median(ms))
        b = fits[0].parameters
        k = m * b["omega0"] ** 2
        phys = {"m": m, "c": 2 * b["zeta"] * m * b["omega0"], "k": k, "phi_raw": b["phi"] * math.sqrt(m)}
        zs = np.mean([self.model.params.to_z(f.theta) for f in fits], axis=0)
        idx = [self.model.params.index(n) for n in self.shared]
        shared = self.model.params.from_z(zs)[idx]
        if _CREEP in self.shared:  # the reference run's creep, not the average
            shared[self.shared.index(_CREEP)] = b[_CREEP]
        return np.concatenate([[phys[n] for n in PHYSICAL_NAMES], shared])


@dataclass(frozen=True)
class MultiMassFit:
    """Joint least-squares fit of several added-mass runs (:func:`fit_multi_mass`).

    ``values``/``stderr``: the joint vector [SI]; ``cov_z``: its sampling-space covariance;
    ``runs``: each run's implied model parameters; ``noise_rel``: each run's relative residual
    scale (from its separate fit); ``consistency``: F-test of the joint fit against separate
    fits of every run; ``rms_rel_residual`` per run."""

    joint: MultiMassModel
    values: dict
    stderr: dict
    cov_z: np.ndarray | None
    runs: tuple[dict, ...]
    noise_rel: tuple[float, ...]
    consistency: dict
    rms_rel_residual: tuple[float, ...]
    success: bool
    message: str = ""
    re: dict | None = None

    @property
    def theta(self) -> np.ndarray:
        return self.joint.params.vector(self.values)


def run_scales(models: Sequence[Model], runs: Sequence[Measurement], fits: Sequence[FitResult]
               ) -> tuple[list[float], list[float]]:
    """``(chi2, scale)`` of each run's separate fit: its relative residuals' sum of squares and
    rms per degree of freedom (all 1 when any is 0), the weights of a joint least-squares fit."""
    chi2, noise = [], []
    for m, meas, f in zip(models, runs, fits, strict=True):
        r = _rel_residuals(m, meas, f.theta)
        chi2.append(float(r @ r))
        noise.append(math.sqrt(chi2[-1] / max(r.size - m.ndim, 1)))
    if not all(s > 0 for s in noise):
        noise = [1.0] * len(runs)
    return chi2, noise


def scaled_residuals(joint, models: Sequence[Model], runs: Sequence[Measurement], noise: Sequence[float]):
    """The joint fit's residual function of sampling-space ``z``: each run's relative residuals under
    its model at the run vector ``joint`` implies, divided by its ``noise`` scale (1e10 where not finite)."""
    def batch(z):
        ths = joint.thetas(joint.params.from_z(z))
        out = np.concatenate([_rel_residuals(m, meas, th) / s
                              for m, meas, th, s in zip(models, runs, ths, noise, strict=True)], axis=-1)
        return np.where(np.isfinite(out), out, 1e10)
    return batch


def joint_bounds_z(joint) -> tuple[np.ndarray, np.ndarray]:
    """The joint vector's bounds in sampling space, the first (the moving mass ``m``) raised so that
    every loaded mass ``m + Δm`` stays positive when a ``Δm`` is negative."""
    lo, hi = joint.params.bounds_z()
    neg = [d for d in joint.deltas if d < 0]
    if neg:
        lo[0] = max(lo[0], float(joint.params[0].to_z(-min(neg) * (1 + 1e-9))))
    return lo, hi


def rms_rel(models: Sequence[Model], runs: Sequence[Measurement], thetas) -> tuple[float, ...]:
    """Each run's rms relative residual ``|Y_model − Y|/|Y|`` under its model and vector."""
    return tuple(float(np.sqrt(np.mean(np.abs(m.admittance(ms.omega, t) - ms.Y) ** 2 / np.abs(ms.Y) ** 2)))
                 for m, ms, t in zip(models, runs, thetas, strict=True))


def fit_multi_mass(runs: Sequence[Measurement], deltas: Sequence[float], model: Model, *,
                   fits: Sequence[FitResult] | None = None, re: tuple[float, float] | None = None,
                   max_nfev: int | None = None) -> MultiMassFit:
    """Joint fit of a free-air run ``runs[0]`` and loaded runs ``runs[1:]`` (added ``deltas`` [kg]).

    Minimises ``Σ_runs Σ_ω |Y_model − Y|²/(|Y|² s_run²)`` (each run scaled by its own separate-fit
    residual scale ``s_run``) plus, with an ohmmeter reading ``re``
    (:func:`~bayes_emt.estimation.meter.as_meter`), the penalty ``((R0 − R_meter)/sd_held)²``:
    mode ``"prior"`` a Gaussian constraint of the reading's sd; mode ``"cut"`` (default) ``R0``
    held at the reading, the covariance the data's given ``R0`` plus the reading's variance
    through each parameter's regression on ``R0`` (``re`` on the result records it).
    """
    from ..estimation.fitting import central_jacobian, covariance_z, fit_admittance
    from ..estimation.meter import as_meter, cut_covariance, per_ohm

    meter = as_meter(re)

    if len(runs) != len(deltas) + 1:
        raise ValueError(f"{len(runs)} recordings need {len(runs) - 1} added masses, got {len(deltas)}")
    jm = MultiMassModel(model, tuple(deltas))
    if fits is None:
        fits = [fit_admittance(meas, model, re=meter) for meas in runs]
    models = (model,) * len(runs)
    chi2_sep, noise = run_scales(models, runs, fits)
    i_r0 = jm.names.index("R0") if "R0" in jm.names else None
    batch_data = scaled_residuals(jm, models, runs, noise)

    def batch(z):
        if meter is None or i_r0 is None:
            return batch_data(z)
        x = jm.params.from_z(z)
        pen = ((x[..., i_r0] - meter.value) / meter.held_sd)[..., None]
        return np.concatenate([batch_data(z), np.where(np.isfinite(pen), pen, 1e10)], axis=-1)

    x0 = jm.start(fits)
    lo, hi = joint_bounds_z(jm)
    p = x0.size
    sol, r, cov, x, se = solve_joint(batch, jm.params, x0, lo, hi, max_nfev)
    re_info = None if meter is None else meter.to_dict()
    if meter is not None:  # what the free-air recording alone says of R0
        re_info.update({k: v for k, v in (fits[0].info.get("re") or {}).items()
                        if k in ("R0_data", "R0_data_sd", "conflict_sd")})
    if meter is not None and meter.cut and i_r0 is not None:
        r_d = batch_data(sol.x[None, :])[0]
        cov_d = covariance_z(central_jacobian(batch_data, sol.x), r_d, p)
        if cov_d is not None:
            sd_z = meter.sd_z(jm.params[i_r0])
            cov, v, _ = cut_covariance(cov_d, i_r0, sd_z)
            sez = np.sqrt(np.clip(np.diag(cov), 0, None))
            se = np.array([abs(xv) * s if spec.transform == "log" else s
                           for spec, xv, s in zip(jm.params, x, sez, strict=True)])
            re_info.update({"sd_z": sd_z, "sensitivity_per_ohm": [float(t) for t in per_ohm(v, sd_z, meter)]})
    thetas = jm.thetas(x)
    chi2_joint = float(r @ r)
    chi2_s = sum(c / s**2 for c, s in zip(chi2_sep, noise, strict=True))
    q, dof = len(runs) * model.ndim - p, r.size - len(runs) * model.ndim
    F = max(chi2_joint - chi2_s, 0.0) / max(q, 1) / (chi2_s / dof) if chi2_s > 0 and dof > 0 else float("nan")
    pval = float(stats.f.sf(F, max(q, 1), max(dof, 1))) if math.isfinite(F) else float("nan")
    rms = rms_rel(models, runs, thetas)
    return MultiMassFit(joint=jm, values=dict(zip(jm.names, map(float, x), strict=True)),
                        stderr=dict(zip(jm.names, map(float, se), strict=True)), cov_z=cov,
                        runs=tuple(model.as_dict(t) for t in thetas), noise_rel=tuple(noise),
                        consistency={"F": float(F), "dof": [q, dof], "p_value": pval},
                        rms_rel_residual=rms, success=bool(sol.status > 0), message=str(sol.message),
                        re=re_info)


class JointRuns:
    """What a density over several recordings' joint vector does with it (``joint.params`` first,
    then ``n_noise`` noise scales per run; ``liks`` one likelihood per run): shared by
    :class:`MultiMassLikelihood` and :class:`~bayes_emt.added_mass.pair.PairLikelihood`."""

    def _set_runs(self, models: Sequence[Model], noise: str) -> None:
        """``liks`` (run ``i`` under ``models[i]``, Gaussian with the ``noise`` kind's scales),
        ``n_noise`` and ``params``: the joint parameters, then each run's noise scales."""
        spec = noise_param_set("gaussian", None, noise)
        object.__setattr__(self, "n_noise", len(spec))
        object.__setattr__(self, "liks", tuple(Likelihood(m, meas, "gaussian", None, spec, noise)
                                               for m, meas in zip(models, self.runs, strict=True)))
        params = self.joint.params
        for i in range(len(self.runs)):
            params = params + _run_noise(spec, f"run{i}")
        object.__setattr__(self, "params", params)

    @property
    def ndim(self) -> int:
        return len(self.params)

    def run_thetas(self, x) -> list[np.ndarray]:
        """Each run's full vector (model parameters, then its noise scales) from ``x (..., ndim)``."""
        x = np.asarray(x, float)
        p, n = len(self.joint.params), self.n_noise
        return [np.concatenate([th, x[..., p + n * i : p + n * i + n]], axis=-1)
                for i, th in enumerate(self.joint.thetas(x[..., :p]))]

    def __call__(self, x) -> np.ndarray:
        return sum(lik(th) for lik, th in zip(self.liks, self.run_thetas(x), strict=True))


@dataclass(frozen=True, eq=False)
class MultiMassLikelihood(JointRuns, SamplingSpaceDensity):
    """``Σ_runs log p(Y_run | x)`` for the joint vector of :class:`MultiMassModel` plus each run's
    noise scales (``sigma_rel_run<i>``, ``sigma_abs_run<i>``; run 0 is the reference), Gaussian;
    with ``noise="correlated"`` each run also has its own model discrepancy (``sigma_disc_run<i>``,
    ``ell_run<i>``: :mod:`bayes_emt.inference.discrepancy`).
    The model's priors (e.g. a Normal prior on ``R0`` from an ohmmeter) apply to the shared
    parameters."""

    joint: MultiMassModel
    runs: tuple[Measurement, ...]
    noise: str = "white"

    def __post_init__(self):
        self._set_runs((self.joint.model,) * len(self.runs), self.noise)

    @property
    def model(self) -> Model:
        return self.joint.model

    @property
    def label(self) -> str:
        return f"{len(self.runs)} added-mass runs, model {self.model.label}"

    def identity(self) -> dict:
        data = "".join(measurement_sha256(m) for m in self.runs).encode()
        return {"model": f"{self.model.label} multi-mass", "names": list(self.params.names),
                **({"noise": self.noise} if self.noise != "white" else {}),
                "deltas": list(self.joint.deltas), "data_sha256": _sha256(data), "source": self.label}


def sample_multi_mass(runs: Sequence[Measurement], deltas: Sequence[float], model: Model, *,
                      fit: MultiMassFit | None = None, seed: int = 0, settings=None,
                      progress: bool | None = False, meter=None, noise: str = "white"):
    """Joint posterior of the runs (emcee, the stopping rule of :mod:`bayes_emt.inference.sampling`).

    ``meter``: an ohmmeter reading under the cut (:mod:`bayes_emt.estimation.meter`; ``model``'s
    prior then holds ``R0`` at it and ``fit`` is the cut fit): the sampler starts from the fit's
    covariance given ``R0`` and each draw is then moved to the cut posterior.

    Returns ``(draws (n, p_joint) [SI], info)`` with ``info``: ``converged``, ``message``,
    ``wall_time`` [s], ``n_draws``, ``tau_max``.
    """
    from ..estimation.meter import cut_rng, held_covariance, move_draws
    from ..inference.posterior import Posterior
    from ..inference.sampling import SamplerSettings, noise_start, run_ensemble, start_ball
    from ..inference.start import extra_noise_start

    settings = SamplerSettings() if settings is None else settings
    t0 = time.perf_counter()
    jm = MultiMassModel(model, tuple(deltas))
    lik = MultiMassLikelihood(jm, tuple(runs), noise)
    fit = fit_multi_mass(runs, deltas, model) if fit is None else fit

    cut = None
    if meter is not None and meter.cut:
        if not (fit.re or {}).get("sensitivity_per_ohm"):
            raise ValueError("sample_multi_mass: a cut needs the cut fit (fit_multi_mass(..., re=meter))")
        cut = (jm.names.index("R0"), np.asarray(fit.re["sensitivity_per_ohm"], float), float(fit.re["sd_z"]))

    def start(nwalkers):
        z0 = jm.params.to_z(fit.theta)
        cov = fit.cov_z if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)) else \
            np.diag((1e-3 * np.maximum(np.abs(z0), 1.0)) ** 2)
        if cut is not None and fit.cov_z is not None:  # given R0, R0 itself held sd·PIN wide
            cov = held_covariance(cov, *cut, meter)
        centre, spread = [], []
        for rl, th, meas, rms in zip(lik.liks, jm.thetas(fit.theta[None, :]), runs, fit.rms_rel_residual,
                                     strict=True):
            c, s = noise_start(rms, float(np.min(np.abs(meas.Y))))
            ce, se = extra_noise_start(rl, th[0])
            centre += c + ce
            spread += s + se
        return start_ball(lik, z0, cov, centre, spread, nwalkers, np.random.default_rng(seed))

    run = run_ensemble(lik, start, seed=seed, progress=progress, settings=settings)
    post = Posterior.from_chain(lik, **run)
    draws = post.flat()[:, : len(jm.params)]
    if cut is not None:
        draws = move_draws(draws, jm.params, cut[0], cut[1], meter, cut_rng(seed))
    return draws, {"converged": bool(run["converged"]), "message": run["message"],
                   "wall_time": time.perf_counter() - t0, "n_draws": int(draws.shape[0]),
                   "tau_max": float(np.max(run["tau"]))}
