"""emcee driver: walkers seeded by the least-squares fit, τ-based stopping, HDF5 checkpoints.

Stopping rule (checked every ``check_every`` steps, at fixed multiples of it so that an
interrupted and resumed run checks at the same iterations as an uninterrupted one): the
integrated autocorrelation time τ of every parameter is estimated on the whole chain, and the run
stops when

* the chain is at least ``min_tau_multiple`` (50) times τ_max long (STACK.md: trust τ then),
* every τ changed by less than ``tau_rtol`` (5 %) since the previous check, and
* the effective sample size ``ESS_i = n_walkers (n − burn) / τ_i`` of every parameter reaches
  ``ess_target`` (1000), with burn-in ``2 τ_max``.

A run that reaches ``max_steps`` first is returned with ``converged = False`` and a
:class:`~bayes_emt.errors.ConvergenceWarning`: never a quiet number.

Reproducibility: emcee draws from a legacy ``RandomState``; it is seeded from ``seed``, and the
HDF5 backend stores its state after every step, so a resumed run continues the very same stream:
killed and resumed, it ends with the same chain as an uninterrupted run.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import emcee
import h5py
import numpy as np

from .data import Measurement
from .errors import ConvergenceWarning, FitError
from .likelihood import Likelihood
from .models import Model
from .posterior import Posterior
from .results import FitResult

__all__ = ["SamplerSettings", "sample_posterior", "initial_walkers", "default_moves"]

_GROUP = "mcmc"


@dataclass(frozen=True)
class SamplerSettings:
    """Knobs of :func:`sample_posterior` (defaults are the documented ones)."""

    walkers_per_dim: int = 4
    max_steps: int = 20000
    check_every: int = 500
    min_tau_multiple: float = 50.0
    tau_rtol: float = 0.05
    ess_target: float = 1000.0
    max_draws: int = 2000


def default_moves():
    """Differential evolution (80 %) with the affine-invariant stretch move (20 %).

    Not ``DESnookerMove``: on a correlated 7-D Gaussian, emcee 3.1.6's snooker move alone gave
    marginal standard deviations 15 % too small, and DE + 20 % snooker 2 % too small (which showed
    as 3 % under-coverage in the calibration script); DE and stretch reproduce the target
    (tests/test_posterior.py::test_default_moves_sample_a_gaussian_exactly)."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.StretchMove(), 0.2)]


def initial_walkers(lik: Likelihood, fit: FitResult, nwalkers: int, rng: np.random.Generator) -> np.ndarray:
    """Walkers around the fit: model parameters from ``N(z_fit, cov_z)``, noise scales around the
    fit's residual level; all inside the prior support with a finite posterior."""
    k = lik.model.ndim
    z0 = fit.z
    cov = fit.cov_z if fit.cov_z is not None else np.diag((1e-3 * np.maximum(np.abs(z0), 1)) ** 2)
    cov = 0.5 * (cov + cov.T) + np.eye(k) * 1e-12 * np.max(np.abs(np.diag(cov)))
    sig0 = max(fit.rms_rel_residual / math.sqrt(2), 1e-5)
    lo, hi = lik.params.bounds_z()
    out = np.empty((nwalkers, lik.ndim))
    filled = 0
    for _ in range(50):
        n = nwalkers - filled
        zm = rng.multivariate_normal(z0, cov, size=n, method="eigh")
        zn = np.column_stack([math.log(sig0) + 0.05 * rng.standard_normal(n),
                              math.log(1e-3 * sig0) + 1.0 * rng.standard_normal(n)])
        cand = np.clip(np.hstack([zm, zn]), lo + 1e-9, hi - 1e-9)
        good = cand[np.isfinite(lik.log_posterior_z(cand))]
        take = good[:n]
        out[filled : filled + take.shape[0]] = take
        filled += take.shape[0]
        if filled == nwalkers:
            return out
        cov = cov * 0.25  # shrink the ball if points fall where the posterior is zero
    raise FitError("could not start the walkers: the posterior is zero around the least-squares fit")


def _stopping_rule(backend, n: int, nwalkers: int, settings: SamplerSettings) -> dict:
    """The stopping rule at step ``n``, a pure function of the stored chain (so a resumed run
    decides exactly as an uninterrupted one would)."""
    chain = backend.get_chain()[:n]
    tau = emcee.autocorr.integrated_time(chain, tol=0)
    prev = n - settings.check_every
    stable = prev >= settings.check_every and bool(
        np.all(np.abs(tau - emcee.autocorr.integrated_time(chain[:prev], tol=0)) / tau < settings.tau_rtol))
    burn = int(math.ceil(2 * np.max(tau)))
    ess = nwalkers * max(n - burn, 0) / tau
    long_enough = bool(n >= settings.min_tau_multiple * np.max(tau))
    return {"step": int(n), "tau_max": float(np.max(tau)), "ess_min": float(np.min(ess)),
            "tau_stable": stable, "long_enough": long_enough,
            "converged": long_enough and stable and bool(np.min(ess) >= settings.ess_target)}


def _meta(lik: Likelihood, seed: int, nwalkers: int) -> dict:
    return {"model": lik.model.label, "names": list(lik.params.names), "likelihood": lik.kind,
            "nu": lik.nu, "seed": int(seed), "nwalkers": int(nwalkers), "source": lik.meas.source,
            "n_points": lik.meas.n_points,
            "data_sha256": hashlib.sha256(lik.meas.omega.tobytes() + lik.meas.Y.tobytes()).hexdigest()}


def _check_resume(path: Path, meta: dict) -> None:
    with h5py.File(path, "r") as f:
        stored = json.loads(f[_GROUP].attrs.get("bayes_emt", "{}"))
    for key in ("model", "names", "likelihood", "nu", "seed", "nwalkers", "n_points"):
        if stored.get(key) != meta[key]:
            raise ValueError(f"{path}: cannot resume: the checkpoint has {key} = {stored.get(key)!r}, "
                             f"this run {meta[key]!r}")
    if stored.get("data_sha256") != meta["data_sha256"]:
        raise ValueError(f"{path}: cannot resume: the checkpoint was made with different data")


def sample_posterior(meas: Measurement, model: Model, *, fit: FitResult | None = None, seed: int = 0,
                     max_steps: int | None = None, checkpoint: str | Path | None = None,
                     resume: bool = False, progress: bool | None = None, likelihood: str = "gaussian",
                     nu: float = 4.0, settings: SamplerSettings = SamplerSettings(),
                     overwrite: bool = False) -> Posterior:
    """Sample the posterior of ``model`` given ``meas`` with emcee (see module docstring).

    Parameters
    ----------
    meas, model : data and model (priors: ``model.params``, e.g. after ``Model.with_priors``).
    fit : the least-squares fit to start from (default: :func:`~bayes_emt.fitting.fit_admittance`).
    seed : seeds the walkers' start and emcee's random stream.
    max_steps : step budget (default ``settings.max_steps``).
    checkpoint : HDF5 file for emcee's backend (a temporary in-memory run if None).
    resume : continue the run stored in ``checkpoint`` (same model, data, seed).
    progress : tqdm progress bar (default: when stderr is a terminal).
    likelihood, nu : ``"gaussian"`` or ``"student"`` (with ``nu`` degrees of freedom).
    overwrite : replace an existing ``checkpoint`` (otherwise that raises: it may hold a long run).
    """
    t0 = time.perf_counter()
    max_steps = int(max_steps or settings.max_steps)
    if max_steps < 1:
        raise ValueError(f"max_steps must be positive, got {max_steps}")
    if resume and checkpoint is None:
        raise ValueError("resume needs the checkpoint file of the run to continue")
    lik = Likelihood(model, meas, likelihood, nu)
    ndim = lik.ndim
    nwalkers = max(settings.walkers_per_dim * ndim, 2 * ndim + 2)
    nwalkers += nwalkers % 2
    meta = _meta(lik, seed, nwalkers)
    progress = sys.stderr.isatty() if progress is None else progress
    backend = None
    if checkpoint is None:
        backend = emcee.backends.Backend()
        backend.reset(nwalkers, ndim)
    start = None
    if checkpoint is not None:
        path = Path(checkpoint)
        if resume:
            if not path.exists():
                raise FileNotFoundError(f"{path}: no checkpoint to resume")
            _check_resume(path, meta)
            backend = emcee.backends.HDFBackend(str(path), name=_GROUP)
        else:
            if path.exists():
                if not overwrite:
                    raise FileExistsError(f"{path}: a checkpoint exists; continue it with --resume, "
                                          "or start afresh with --overwrite (or another --checkpoint)")
                path.unlink()
            backend = emcee.backends.HDFBackend(str(path), name=_GROUP)
            backend.reset(nwalkers, ndim)
            with h5py.File(path, "a") as f:
                f[_GROUP].attrs["bayes_emt"] = json.dumps(meta)
    if backend.iteration == 0:
        if fit is None:
            from .fitting import fit_admittance

            fit = fit_admittance(meas, model)
        rng = np.random.default_rng(seed)
        start = initial_walkers(lik, fit, nwalkers, rng)
    moves = default_moves()
    sampler = emcee.EnsembleSampler(nwalkers, ndim, lik.log_posterior_z, moves=moves, vectorize=True,
                                    backend=backend)
    sampler.random_state = np.random.RandomState(seed).get_state()
    history = []
    converged = False
    while True:
        n = backend.iteration
        if n > 0 and (n % settings.check_every == 0 or n >= max_steps):
            verdict = _stopping_rule(backend, n, nwalkers, settings)
            history.append(verdict)
            if verdict["converged"]:
                converged = True
                break
        if n >= max_steps:
            break
        chunk = min(settings.check_every - n % settings.check_every, max_steps - n)
        sampler.run_mcmc(start if n == 0 else None, chunk, progress=progress)
    tau = backend.get_autocorr_time(tol=0)
    n = backend.iteration
    message = "converged" if converged else (
        f"not converged within {max_steps} steps: chain = {n / np.max(tau):.1f} tau_max "
        f"(need {settings.min_tau_multiple:g}), min ESS {np.min(nwalkers * (n - 2 * np.max(tau)) / tau):.0f} "
        f"(need {settings.ess_target:g})")
    if not converged:
        warnings.warn(f"{meas.source}, model {model.label}: {message}", ConvergenceWarning, stacklevel=2)
    return Posterior.from_backend(lik, backend, tau=tau, converged=converged, seed=seed, message=message,
                                  history=history, max_draws=settings.max_draws,
                                  wall_time=time.perf_counter() - t0)
