"""emcee driver: walkers seeded by the least-squares fit, τ-based stopping, HDF5 checkpoints.

Sampler
-------
``emcee.EnsembleSampler`` with ``vectorize=True`` (one model call per step for the whole
ensemble: on two cores that beats a process pool), ``4·ndim`` walkers, in sampling space (log of
positive parameters, :mod:`bayes_emt.params`), moves ``[(DEMove, 0.8), (SnookerMove, 0.2)]``.
:class:`SnookerMove` is a corrected DE-snooker (ter Braak & Vrugt 2008): emcee 3.1.6's
``DESnookerMove`` projects with ``delta/sqrt(|delta|)`` instead of the unit vector and uses half
the ``(d − 1)`` exponent of the acceptance factor, so its target is not the posterior (measured:
alone it gives 17 % too small standard deviations on a correlated 7-D Gaussian and 33 % on a
skewed 5-D target; 2 % too small when mixed 20 % with DE; tests/test_sampling.py).
Each step stores one blob per walker, its total log-likelihood (``log_prob − log_likelihood`` is
then the log prior in sampling space, for bridge sampling and prior-sensitivity checks).

Stopping rule
-------------
Checked every ``check_every`` (500) steps, at fixed multiples of it, as a pure function of the
stored chain (:func:`stopping_rule`): with τ the integrated autocorrelation time of each
parameter on the whole chain, stop when

* the chain is at least ``min_tau_multiple`` (50) τ_max long (STACK.md: trust τ then);
* every τ changed by less than ``tau_rtol`` (5 %) since the previous check — not STACK.md's 1 %:
  the largest change over all parameters keeps moving by 3–5 % per 500-step check long after
  the chain is stationary (NL(5) on the paper data: 4.9, 4.2, 3.6, 3.7 % at 41–52 τ; the
  estimator's downward bias on shorter chains shrinking, plus noise), so 1 % would buy many
  more steps for no change in the answer; the 50 τ and ESS conditions carry the weight;
* the effective sample size ``ESS_i = n_walkers (n − burn) / τ_i`` reaches ``ess_target``
  (1000) for every parameter, with burn-in ``⌈2 τ_max⌉``.

A run that reaches ``max_steps`` first returns with ``converged = False`` and warns
(:class:`~bayes_emt.errors.ConvergenceWarning`): never a quiet number.

Randomness, checkpoints, resume
-------------------------------
The run is a deterministic function of (data, model and priors, likelihood, seed, settings).
The walkers' start comes from ``numpy.random.default_rng(seed)``. emcee draws from a legacy
``RandomState``; this driver re-seeds it at every multiple of ``reseed_every`` (100) steps from
``SeedSequence([seed, block])``, so the random numbers of steps ``[100 b, 100 (b + 1))`` depend
on the seed and ``b`` only, not on how the run was cut into calls.

With a checkpoint, emcee's ``HDFBackend`` writes every step as it is made. ``resume`` truncates
the stored chain to its last multiple of ``reseed_every`` (steps after it are recomputed, bit for
bit the same) and continues to the same stopping rule. So a run killed at any moment (SIGKILL
included) and resumed ends with exactly the chain of an uninterrupted run: same number of steps,
same values; at most ``reseed_every − 1`` steps are computed twice. This does not rely on
emcee's stored random state, which a kill between its attribute writes could leave one step
ahead of the stored iteration count. A resume checks that the checkpoint belongs to the same
model, priors, likelihood, data (SHA-256), seed and walker count, and refuses otherwise.

Checkpoints are opened without HDF5 file locking, so a reader never kills the run; a run that
stores no step removes the checkpoint it created, and a checkpoint holding no step never blocks
the next run (:mod:`bayes_emt.inference.checkpoint`).
"""

from __future__ import annotations

import json
import math
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import emcee
import numpy as np
from emcee.moves.red_blue import RedBlueMove

from ..errors import ConvergenceWarning, FitError
from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import Model
from ..params import ParamSet
from .checkpoint import GROUP as _GROUP
from .checkpoint import CheckpointBackend, check_checkpoint, checkpoint_steps, h5_open
from .likelihood import Likelihood, LikelihoodKind
from .posterior import Posterior

__all__ = ["SamplerSettings", "SnookerMove", "default_moves", "initial_walkers", "stopping_rule",
           "sample_posterior", "sample_likelihood",
           "run_ensemble", "start_ball", "noise_start", "checkpoint_steps", "check_checkpoint"]


@dataclass(frozen=True)
class SamplerSettings:
    """Knobs of :func:`sample_posterior` (the defaults are the documented ones).

    Attributes
    ----------
    walkers_per_dim : walkers per sampled dimension (emcee: ≥ 2; 4 is comfortable).
    max_steps : step budget.
    check_every : steps between stopping-rule checks.
    reseed_every : block length [steps] of the random stream (divides ``check_every``).
    min_tau_multiple : required chain length in units of τ_max.
    tau_rtol : required relative stability of every τ between two checks.
    ess_target : required effective sample size of every parameter.
    max_draws : at most this many draws (all walkers) are kept after burn-in and thinning.
    """

    walkers_per_dim: int = 4
    max_steps: int = 20000
    check_every: int = 500
    reseed_every: int = 100
    min_tau_multiple: float = 50.0
    tau_rtol: float = 0.05
    ess_target: float = 1000.0
    max_draws: int = 2000

    def __post_init__(self):
        if self.walkers_per_dim < 2:
            raise ValueError(f"walkers_per_dim must be at least 2, got {self.walkers_per_dim}")
        if self.reseed_every < 1 or self.check_every % self.reseed_every:
            raise ValueError(f"reseed_every ({self.reseed_every}) must divide check_every "
                             f"({self.check_every})")


class SnookerMove(RedBlueMove):
    """Differential-evolution snooker update (ter Braak & Vrugt 2008), as it should be.

    For a walker ``x``, three points ``a, z1, z2`` of the complementary walkers: with
    ``e = (x − a)/|x − a|``, propose ``x' = x + γ e·(z1 − z2) e``, ``γ ~ U(1.2, 2.2)``, and accept
    with ``min(1, π(x')/π(x) · (|x' − a|/|x − a|)^(d − 1))``.

    emcee 3.1.6's ``DESnookerMove`` (the latest release) projects on ``delta/sqrt(|delta|)`` and
    halves the ``(d − 1)`` exponent. Upstream fixed both in emcee PR #531 (commit 946e664,
    "Update de_snooker.py", merged 27 January 2025: ``u = delta / norm`` and
    ``(ndim - 1.0) * metropolis``), not in a release yet. This class does not depend on
    which emcee is installed; tests/test_sampling.py checks emcee's own move either way.
    """

    def __init__(self, gamma_range: tuple[float, float] = (1.2, 2.2), **kwargs):
        self.gamma_range = gamma_range
        kwargs.setdefault("nsplits", 4)  # a, z1, z2 from three different splits: always distinct
        super().__init__(**kwargs)

    def get_proposal(self, s, c, random):
        ns, ndim = s.shape
        pick = np.stack([c[j][random.randint(len(c[j]), size=ns)] for j in range(3)], axis=1)
        order = np.argsort(random.random_sample((ns, 3)), axis=1)
        pick = np.take_along_axis(pick, order[:, :, None], axis=1)
        anchor, z1, z2 = pick[:, 0], pick[:, 1], pick[:, 2]
        delta = s - anchor
        r = np.linalg.norm(delta, axis=1)
        e = delta / r[:, None]
        gamma = random.uniform(*self.gamma_range, size=ns)
        q = s + (gamma * np.einsum("ij,ij->i", e, z1 - z2))[:, None] * e
        with np.errstate(divide="ignore"):
            factor = (ndim - 1.0) * (np.log(np.linalg.norm(q - anchor, axis=1)) - np.log(r))
        return q, factor


def default_moves():
    """Differential evolution (80 %) and the corrected snooker update (20 %)."""
    return [(emcee.moves.DEMove(), 0.8), (SnookerMove(), 0.2)]


def initial_walkers(lik: Likelihood, fit: FitResult, nwalkers: int, rng: np.random.Generator) -> np.ndarray:
    """Walkers in sampling space around the least-squares fit.

    Model parameters from ``N(z_fit, cov_z)`` (the fit's own covariance: a ball of the
    posterior's size, so burn-in is short); ``sigma_rel`` around the fit's rms relative residual
    per part, ``sigma_abs`` spread (one e-fold) a thousand times below that level times the
    smallest |Y|, where it does not matter; a sampled ``nu`` around 10. All clipped to the prior
    support and with a finite posterior; the ball shrinks if too many points fall outside.
    """
    z0 = lik.model.params.to_z(fit.theta)
    cov = fit.cov_z if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)) else None
    if cov is None:
        cov = np.diag((1e-3 * np.maximum(np.abs(z0), 1.0)) ** 2)
    centre, spread = noise_start(fit.rms_rel_residual, float(np.min(np.abs(lik.meas.Y))))
    centre = _noise_start_in_priors(lik, fit, centre)
    if lik.sample_nu:
        centre.append(math.log(10.0))
        spread.append(0.3)
    return start_ball(lik, z0, cov, centre, spread, nwalkers, rng)


def _noise_start_in_priors(lik: Likelihood, fit: FitResult, centre: list[float]) -> list[float]:
    """``centre`` moved inside the noise priors: when the prior of ``sigma_rel`` excludes the fit's
    relative residual level, the absolute floor ``sigma_abs`` starts at the level that explains the
    residuals instead; when neither prior reaches it, raise, naming both (walkers started far
    outside the posterior's mass never move, and the chain has no autocorrelation time)."""
    names = lik.noise_params.names
    if "sigma_rel" not in names or "sigma_abs" not in names:
        return centre
    lo, hi = lik.params.bounds_z()
    i_rel, i_abs = lik.params.index("sigma_rel"), lik.params.index("sigma_abs")
    if lo[i_rel] <= centre[0] <= hi[i_rel]:
        return centre
    r = lik.model.admittance(lik.meas.omega, fit.theta) - lik.meas.Y
    level = float(np.sqrt(np.mean(np.abs(r) ** 2) / 2))  # absolute residual per part [S]
    rel_ok = float(np.clip(centre[0], lo[i_rel] + 1e-6, hi[i_rel] - 1e-6))
    z_abs = math.log(level) if level > 0 else centre[1]
    if not (lo[i_abs] < z_abs < hi[i_abs]):
        def show(i):
            d = dict(lik.params[i].prior.to_dict())
            return f"{d.pop('dist', '?')}(" + ", ".join(f"{k}={v:g}" for k, v in d.items()) + ")"

        raise ValueError(
            f"the noise priors exclude the data: the least-squares residuals are "
            f"{100 * math.exp(centre[0]):.3g} % of |Y| per real/imaginary part ({level:.3g} S rms), but "
            f"sigma_rel is {show(i_rel)} [1] and sigma_abs {show(i_abs)} [S]: widen one of them (--priors)")
    return [rel_ok, z_abs]


def noise_start(rms_rel: float, min_abs_Y: float) -> tuple[list[float], list[float]]:
    """Centre and spread, in sampling space, of ``(sigma_rel, sigma_abs)`` for walkers started
    from a fit with rms relative residual ``rms_rel`` of data whose smallest |Y| is ``min_abs_Y``."""
    sig0 = max(rms_rel / math.sqrt(2), 1e-5)
    return [math.log(sig0), math.log(1e-3 * sig0 * min_abs_Y)], [0.05, 1.0]


def start_ball(target, z0, cov, centre, spread, nwalkers: int, rng: np.random.Generator) -> np.ndarray:
    """``nwalkers`` sampling-space points: the first ``len(z0)`` coordinates from ``N(z0, cov)``,
    the rest (noise) from independent normals (``centre``, ``spread``); clipped to the prior
    support of ``target.params``, each with a finite posterior; the ball shrinks if too many fall
    outside. Correlations are shrunk to at most 0.99 in magnitude: a parameter the data do not
    separate from another (a lead resistance beside R0) makes the fit's covariance nearly singular,
    and walkers drawn from it would be linearly dependent (emcee refuses such a start)."""
    k = len(z0)
    cov = 0.5 * (cov + cov.T)
    cov = 0.99 * cov + 0.01 * np.diag(np.diag(cov))
    cov = cov + np.eye(k) * 1e-12 * np.max(np.abs(np.diag(cov)))
    lo, hi = target.params.bounds_z()
    out = np.empty((nwalkers, target.ndim))
    filled = 0
    for _ in range(50):
        n = nwalkers - filled
        zm = rng.multivariate_normal(z0, cov, size=n, method="eigh")
        zn = np.asarray(centre) + np.asarray(spread) * rng.standard_normal((n, len(centre)))
        span = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
        cand = np.clip(np.hstack([zm, zn]), lo + 1e-9 * span, hi - 1e-9 * span)
        good = cand[np.isfinite(target.log_posterior_z(cand))][:n]
        out[filled : filled + good.shape[0]] = good
        filled += good.shape[0]
        if filled == nwalkers:
            return out
        cov = cov * 0.25
    raise FitError(f"{target.label}: could not start the walkers: the posterior is zero around "
                   "the least-squares fit (check the priors against the fitted values)")


def _tau(chain: np.ndarray) -> tuple[np.ndarray, bool]:
    """Integrated autocorrelation time of each parameter [steps], and whether some parameter never
    moved. emcee returns NaN for a parameter whose walkers never moved (0/0); its τ is then at
    least the chain's length, which is used instead, so every rule reads 'not converged' and no
    NaN reaches an integer (burn-in, thinning)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = emcee.autocorr.integrated_time(chain, tol=0)
    ok = np.isfinite(tau)
    return np.where(ok, tau, float(chain.shape[0])), not bool(np.all(ok))


def stopping_rule(chain: np.ndarray, n: int, settings: SamplerSettings) -> dict:
    """The stopping rule (module docstring) at step ``n``, from ``chain[:n]`` only.

    ``chain`` has shape ``(steps, walkers, ndim)``. Returns the step, τ_max, the minimum ESS,
    each criterion's verdict and ``converged``.
    """
    chain = chain[:n]
    nwalkers = chain.shape[1]
    tau, stuck = _tau(chain)
    prev = n - settings.check_every
    change = math.inf
    if prev >= settings.check_every:
        tau_prev, _ = _tau(chain[:prev])
        change = float(np.max(np.abs(tau - tau_prev) / tau))
    burn = min(int(math.ceil(2 * np.max(tau))), n)
    ess = nwalkers * max(n - burn, 0) / tau
    out = {"step": int(n), "tau_max": float(np.max(tau)), "n_over_tau": float(n / np.max(tau)),
           "tau_change": change, "ess_min": float(np.min(ess)),
           "long_enough": bool(n >= settings.min_tau_multiple * np.max(tau)),
           "tau_stable": bool(change < settings.tau_rtol),
           "ess_reached": bool(np.min(ess) >= settings.ess_target), "stuck": stuck}
    out["converged"] = out["long_enough"] and out["tau_stable"] and out["ess_reached"] and not stuck
    return out


def _verdict_message(v: dict, max_steps: int, settings: SamplerSettings) -> str:
    if v["converged"]:
        return (f"converged at step {v['step']}: chain {v['n_over_tau']:.0f} tau_max, "
                f"min ESS {v['ess_min']:.0f}, tau changed {100 * v['tau_change']:.1f} % since the last check")
    why = []
    if v.get("stuck"):
        why.append("some parameters never moved (no accepted proposal: tau undefined); the posterior is "
                   "far narrower than the walkers' start, or zero around it: check the priors")
    elif not v["long_enough"]:
        why.append(f"chain = {v['n_over_tau']:.1f} tau_max (need {settings.min_tau_multiple:g})")
    if not v["tau_stable"]:
        ch = "no previous check" if not math.isfinite(v["tau_change"]) else f"{100 * v['tau_change']:.1f} %"
        why.append(f"tau still changing ({ch}; need < {100 * settings.tau_rtol:g} %)")
    if not v["ess_reached"]:
        why.append(f"min ESS {v['ess_min']:.0f} (need {settings.ess_target:g})")
    return f"not converged within {max_steps} steps: " + ", ".join(why)


def _run_identity(target, seed: int, nwalkers: int, settings: SamplerSettings) -> dict:
    return {**target.identity(), "seed": int(seed), "nwalkers": int(nwalkers),
            "reseed_every": settings.reseed_every, "moves": "DE 0.8 + snooker 0.2"}


def _check_resume(path: Path, ident: dict) -> None:
    try:
        with h5_open(path, "r") as f:
            stored = json.loads(f[_GROUP].attrs["bayes_emt"])
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: cannot resume: not a bayes_emt sampler checkpoint ({exc})") from None
    for key, val in ident.items():
        if key != "source" and stored.get(key) != val:
            what = {"data_sha256": "data", "priors_sha256": "priors"}.get(key, key)
            shown = ("" if key.endswith("sha256")
                     else f": the checkpoint has {stored.get(key)!r}, this run {val!r}")
            raise ValueError(f"{path}: cannot resume: different {what}{shown}")


def _block_state(seed: int, block: int):
    """emcee's legacy RandomState for steps ``[block·reseed_every, (block + 1)·reseed_every)``."""
    words = np.random.SeedSequence([int(seed), int(block)]).generate_state(4)
    return np.random.RandomState(words).get_state()


def _open_backend(checkpoint, resume, overwrite, ident, nwalkers, ndim, reseed_every):
    if checkpoint is None:
        backend = emcee.backends.Backend()
        backend.reset(nwalkers, ndim)
        return backend
    path = Path(checkpoint)
    check_checkpoint(path, resume=resume, overwrite=overwrite)
    if resume:
        _check_resume(path, ident)
        with h5_open(path, "a") as f:
            g = f[_GROUP]
            g.attrs["iteration"] = (int(g.attrs["iteration"]) // reseed_every) * reseed_every
        return CheckpointBackend(str(path), name=_GROUP)
    if path.exists():
        path.unlink()
    backend = CheckpointBackend(str(path), name=_GROUP)
    try:
        backend.reset(nwalkers, ndim)
        with h5_open(path, "a") as f:
            f[_GROUP].attrs["bayes_emt"] = json.dumps(ident)
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return backend


def _acceptance(chain: np.ndarray, burn: int) -> float:
    """Fraction of accepted proposals after burn-in, from the chain itself (a continuous proposal
    never lands on its start), immune to the backend's counters."""
    c = chain[max(burn, 1) - 1 :]
    if c.shape[0] < 2:
        return float("nan")
    return float(np.mean(np.any(c[1:] != c[:-1], axis=-1)))


def run_ensemble(target, start: Callable[[int], np.ndarray], *, seed: int = 0, max_steps: int | None = None,
                 checkpoint: str | Path | None = None, resume: bool = False, overwrite: bool = False,
                 progress: bool | None = None, settings: SamplerSettings = SamplerSettings()) -> dict:
    """Run the ensemble sampler on any ``target`` to the stopping rule (module docstring).

    ``target`` has ``params`` (ParamSet with priors), ``ndim``, ``label``, ``identity()`` (what a
    checkpoint must match) and ``emcee_log_prob``
    (:class:`~bayes_emt.inference.likelihood.SamplingSpaceDensity`);
    ``start(nwalkers)`` returns the walkers' sampling-space start (only called for a fresh run).
    Returns the chain ``(steps, walkers, k)``, ``log_prob``, ``blobs``, ``tau``, ``burn``, the
    verdict, its message and history, and the keyword arguments :meth:`Posterior.from_chain`
    takes besides them.
    """
    t0 = time.perf_counter()
    max_steps = int(settings.max_steps if max_steps is None else max_steps)
    if max_steps < 1:
        raise ValueError(f"max_steps must be positive, got {max_steps}")
    if resume and checkpoint is None:
        raise ValueError("resume needs the checkpoint file of the run to continue")
    ndim = target.ndim
    nwalkers = max(settings.walkers_per_dim * ndim, 2 * ndim + 2)
    nwalkers += nwalkers % 2
    ident = _run_identity(target, seed, nwalkers, settings)
    backend = _open_backend(checkpoint, resume, overwrite, ident, nwalkers, ndim, settings.reseed_every)
    progress = sys.stderr.isatty() if progress is None else bool(progress)
    from tqdm.auto import tqdm

    bar = tqdm(total=max_steps, initial=min(backend.iteration, max_steps), disable=not progress,
               file=sys.stderr, desc=f"emcee {target.label}", unit="step", leave=False)
    history: list[dict] = []
    verdict = None
    try:
        z0 = start(nwalkers) if backend.iteration == 0 else None
        sampler = emcee.EnsembleSampler(nwalkers, ndim, target.emcee_log_prob, moves=default_moves(),
                                        vectorize=True, backend=backend)
        while True:
            n = backend.iteration
            if n > 0 and (n % settings.check_every == 0 or n >= max_steps):
                verdict = stopping_rule(backend.get_chain(), n, settings)
                history.append(verdict)
                bar.set_postfix(tau_max=f"{verdict['tau_max']:.0f}", n_tau=f"{verdict['n_over_tau']:.0f}",
                                ess=f"{verdict['ess_min']:.0f}")
                if verdict["converged"] or n >= max_steps:
                    break
            block = n // settings.reseed_every
            seg = min((block + 1) * settings.reseed_every - n, max_steps - n)
            if n == 0:
                state = emcee.State(z0, random_state=_block_state(seed, 0))
            else:
                state = backend.get_last_sample()
                if n % settings.reseed_every == 0:
                    state.random_state = _block_state(seed, block)
            sampler.run_mcmc(state, seg, skip_initial_state_check=n > 0)
            bar.update(seg)
    except BaseException:
        # a run that stored no step leaves no checkpoint of its own making behind
        if checkpoint is not None and not resume and checkpoint_steps(checkpoint) in (0, None):
            Path(checkpoint).unlink(missing_ok=True)
        raise
    finally:
        bar.close()
    message = _verdict_message(verdict, max_steps, settings)
    if not verdict["converged"]:
        warnings.warn(f"{target.label}: {message}", ConvergenceWarning, stacklevel=3)
    chain = backend.get_chain()
    tau, _ = _tau(chain)
    burn = min(int(math.ceil(2 * np.max(tau))), chain.shape[0] - 1)
    return {"chain": chain, "log_prob": backend.get_log_prob(), "blobs": backend.get_blobs(), "tau": tau,
            "burn": burn, "max_draws": settings.max_draws,
            "converged": verdict["converged"], "seed": seed, "message": message, "history": history,
            "acceptance": _acceptance(chain, burn), "wall_time": time.perf_counter() - t0,
            "settings": {**asdict(settings), "max_steps": max_steps, "nwalkers": nwalkers,
                         "moves": ident["moves"]},
            "checkpoint": None if checkpoint is None else str(checkpoint)}


def sample_likelihood(lik: Likelihood, *, fit: FitResult | None = None, seed: int = 0,
                      max_steps: int | None = None, checkpoint: str | Path | None = None,
                      resume: bool = False, overwrite: bool = False, progress: bool | None = None,
                      settings: SamplerSettings = SamplerSettings()) -> Posterior:
    """Sample the posterior defined by a :class:`~bayes_emt.inference.likelihood.Likelihood` (its model,
    data, priors and noise model); arguments as :func:`sample_posterior`."""
    t0 = time.perf_counter()

    def start(nwalkers):
        nonlocal fit
        if fit is None:
            from ..estimation.fitting import fit_admittance

            fit = fit_admittance(lik.meas, lik.model)
        return initial_walkers(lik, fit, nwalkers, np.random.default_rng(seed))

    run = run_ensemble(lik, start, seed=seed, max_steps=max_steps, checkpoint=checkpoint, resume=resume,
                       overwrite=overwrite, progress=progress, settings=settings)
    run["wall_time"] = time.perf_counter() - t0
    return Posterior.from_chain(lik, **run)


def sample_posterior(meas: Measurement, model: Model, *, fit: FitResult | None = None, seed: int = 0,
                     max_steps: int | None = None, checkpoint: str | Path | None = None,
                     resume: bool = False, overwrite: bool = False, progress: bool | None = None,
                     likelihood: LikelihoodKind = "gaussian", nu: float | None = 4.0,
                     noise_params: ParamSet | None = None,
                     settings: SamplerSettings = SamplerSettings()) -> Posterior:
    """Sample the posterior of ``model`` given ``meas`` with emcee (see the module docstring).

    Parameters
    ----------
    meas : the measurement (ω [rad/s], Y [S]).
    model : the model; its ``params`` carry the priors (e.g. after ``Model.with_priors``).
    fit : the least-squares fit to start from (default: :func:`~bayes_emt.estimation.fitting.fit_admittance`;
        not needed when resuming past the first ``reseed_every`` steps).
    seed : the run's seed (walkers' start and emcee's random stream).
    max_steps : step budget (default ``settings.max_steps``).
    checkpoint : HDF5 file for emcee's backend; ``None`` keeps the chain in memory.
    resume : continue the run stored in ``checkpoint`` (same model, priors, data, seed).
    overwrite : replace an existing ``checkpoint`` (otherwise that raises: it may hold a long run).
    progress : tqdm progress bar on stderr (default: when stderr is a terminal).
    likelihood, nu : ``"gaussian"``, or ``"student"`` with ``nu`` degrees of freedom (``None``:
        sampled).
    noise_params : noise priors (default :func:`~bayes_emt.inference.likelihood.noise_param_set`).
    settings : :class:`SamplerSettings`.

    Returns
    -------
    Posterior
        Thinned draws after burn-in, diagnostics and provenance; ``converged`` False (with a
        :class:`~bayes_emt.errors.ConvergenceWarning`) when the budget ran out first.
    """
    lik = Likelihood(model, meas, likelihood, nu, noise_params)
    return sample_likelihood(lik, fit=fit, seed=seed, max_steps=max_steps, checkpoint=checkpoint,
                             resume=resume, overwrite=overwrite, progress=progress, settings=settings)
