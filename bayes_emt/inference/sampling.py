"""emcee driver: a refined start, a warm-up, a frozen proposal, τ-based stopping, HDF5 checkpoints.

Sampler
-------
``emcee.EnsembleSampler`` with ``vectorize=True`` (one model call per step for the whole
ensemble: on two cores that beats a process pool), ``4·ndim`` walkers, in sampling space (log of
positive parameters, :mod:`bayes_emt.params`). The moves (:mod:`bayes_emt.inference.moves`) come
in two phases: ``warmup`` (200) steps of ensemble moves (ensemble-t independence, differential
evolution, corrected snooker), then production segments: a multivariate-t independence proposal
frozen on the second half of the steps before, mixed with differential evolution. At each
``warmup · 2^k`` the second half of the current segment is compared with the sample the proposal
was fitted to; only if they disagree does a new segment begin there, with the proposal refitted.
Every move keeps the posterior invariant.
Each step stores one blob per walker, its total log-likelihood (``log_prob − log_likelihood`` is
then the log prior in sampling space, for bridge sampling and prior-sensitivity checks).

Start
-----
:func:`initial_walkers` refines the least-squares fit into the posterior mode before placing the
walkers: the least-squares fit weighs relative residuals, so with a model that misses some
physics the noise may be better explained by the absolute floor, and the posterior's mode then
lies elsewhere (UD fitted to the bundled NL data: the mode with ``sigma_abs`` carrying the misfit
is 2,560 nats above the one next to the fit, where the earlier start left 3 of 36 walkers stranded
for good). The mode is searched from two noise starts (relative and absolute floor dominating)
by quasi-Newton steps whitened with the fit's covariance (:func:`posterior_mode`).

Stopping rule
-------------
Checked every ``check_every`` (100) steps, at fixed multiples of it, as a pure function of the
stored chain (:func:`stopping_rule`), on the current production segment once there is one: with
τ the integrated autocorrelation time of each parameter there, stop when

* that part is at least ``min_tau_multiple`` (50) τ_max long (STACK.md: trust τ then);
* every τ changed by less than ``tau_rtol`` (5 %) since the previous check — not STACK.md's 1 %:
  the largest change over all parameters keeps moving by a few per cent per check long after
  the chain is stationary (the estimator's downward bias on shorter chains shrinking, plus
  noise), so 1 % would buy many more steps for no change in the answer; the 50 τ and ESS
  conditions carry the weight. With ``tau_margin`` (the T/S posterior's settings) a τ still
  moving by Δ also passes when the other two conditions hold with every τ taken as ``τ (1 + Δ)``:
  the estimate's remaining drift can then no longer bring the chain below its length or ESS
  target (on a 344-point woofer recording the NL(3)+creep posterior ran 1000 production steps
  for an ESS of 6000 against a target of 400, waiting for a 5 % τ step the estimator's noise
  hardly allows);
* the effective sample size ``ESS_i = n_walkers (n − burn) / τ_i`` reaches ``ess_target``
  (1000) for every parameter, with burn-in ``⌈2 τ_max⌉`` steps after the segment's start.

A run that reaches ``max_steps`` first returns with ``converged = False`` and warns
(:class:`~bayes_emt.errors.ConvergenceWarning`): never a quiet number.

Randomness, checkpoints, resume
-------------------------------
The run is a deterministic function of (data, model and priors, likelihood, seed, settings).
The walkers' start comes from ``numpy.random.default_rng(seed)``. emcee draws from a legacy
``RandomState``; this driver re-seeds it at every multiple of ``reseed_every`` (100) steps from
``SeedSequence([seed, block])``, so the random numbers of steps ``[100 b, 100 (b + 1))`` depend
on the seed and ``b`` only, not on how the run was cut into calls. The segments and their
proposals are functions of the stored chain, rebuilt identically on resume.

With a checkpoint, the chain is written to HDF5 at the end of every block
(:class:`~bayes_emt.inference.checkpoint.ChainStore`: chunked by blocks, compressed, no per-step
random state). ``resume`` reads the stored chain up to its last multiple of ``reseed_every``
(a partly written block is recomputed, bit for bit the same) and continues to the same stopping
rule. So a run killed at any moment (SIGKILL included) and resumed ends with exactly the chain of
an uninterrupted run: same number of steps, same values. A resume checks that the checkpoint
belongs to the same model, priors, likelihood, data (SHA-256), seed, walker count and moves,
and refuses otherwise.

Checkpoints are opened without HDF5 file locking, so a reader never kills the run; a run that
stores no step removes the checkpoint it created, and a checkpoint holding no step never blocks
the next run (:mod:`bayes_emt.inference.checkpoint`). A parameter whose walkers never moved has no
autocorrelation time (emcee's estimate is 0/0): it counts as correlated over the whole chain and
the run as not converged, with a message saying so.

Interrupts and concurrent runs
------------------------------
A run holds the checkpoint's lock (:class:`~bayes_emt.inference.checkpoint.CheckpointLock`) from
before it reads or creates the file to after its last write: a second run on the same file is
refused in one line. SIGINT (and SIGTERM, when the program has turned it into an exception, as the
command line does) are held while the sampler steps and acted on between two steps
(:class:`_HeldSignals`): emcee's log-probability wrapper catches *every* exception, KeyboardInterrupt
included, and prints its traceback and arguments before re-raising, which is what a Ctrl-C showed
whenever it arrived inside a model evaluation. The run then raises
:class:`~bayes_emt.errors.Interrupted` saying how many steps the checkpoint holds; ``resume``
continues from there to the same chain.
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import emcee
import numpy as np

from ..errors import ConvergenceWarning, Interrupted, PriorConflictWarning
from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import Model
from ..params import ParamSet
from ..params.priors import LogNormal, LogUniform, Normal, Uniform
from .checkpoint import ChainStore, CheckpointLock, check_checkpoint, checkpoint_steps, read_identity
from .likelihood import Likelihood, LikelihoodKind, NoiseKind
from .moves import MOVES_DESCRIPTION, SnookerMove, production_moves, proposal_mismatch, warmup_moves
from .posterior import Posterior
from .start import initial_walkers, noise_start, start_ball

__all__ = ["SamplerSettings", "SnookerMove", "default_moves", "initial_walkers", "stopping_rule",
           "integrated_time", "integrated_time_stuck",
           "sample_posterior", "sample_likelihood",
           "run_ensemble", "start_ball", "noise_start", "checkpoint_steps", "check_checkpoint",
           "prior_conflicts", "conflict_message"]


@dataclass(frozen=True)
class SamplerSettings:
    """Knobs of :func:`sample_posterior` (the defaults are the documented ones).

    Attributes
    ----------
    walkers_per_dim : walkers per sampled dimension (emcee: ≥ 2; 4 is comfortable).
    max_steps : step budget.
    check_every : steps between stopping-rule checks.
    reseed_every : block length [steps] of the random stream and of checkpoint writes (divides
        ``check_every`` and ``warmup``).
    warmup : steps of ensemble moves before the proposal is frozen (:mod:`bayes_emt.inference.moves`).
    min_tau_multiple : required production length in units of τ_max.
    tau_rtol : required relative stability of every τ between two checks.
    tau_margin : also accept a τ that still moves (by Δ, the largest relative change since the
        last check) when the chain is long enough and reaches ``ess_target`` even with every τ
        taken as ``τ (1 + Δ)`` (:func:`stopping_rule`); off by default (``sample``), on for the T/S
        posterior, whose 5-95 % quantiles need a few hundred effective draws, not a precise τ.
    ess_target : required effective sample size of every parameter.
    max_draws : at most this many draws (all walkers) are kept after burn-in and thinning.
    """

    walkers_per_dim: int = 4
    max_steps: int = 20000
    check_every: int = 100
    reseed_every: int = 100
    warmup: int = 200
    min_tau_multiple: float = 50.0
    tau_rtol: float = 0.05
    tau_margin: bool = False
    ess_target: float = 1000.0
    max_draws: int = 2000

    def __post_init__(self):
        if self.walkers_per_dim < 2:
            raise ValueError(f"walkers_per_dim must be at least 2, got {self.walkers_per_dim}")
        if self.reseed_every < 1 or self.check_every % self.reseed_every:
            raise ValueError(f"reseed_every ({self.reseed_every}) must divide check_every "
                             f"({self.check_every})")
        if self.warmup < 0 or self.warmup % self.reseed_every:
            raise ValueError(f"reseed_every ({self.reseed_every}) must divide warmup ({self.warmup})")


def default_moves():
    """The warm-up mix of :mod:`bayes_emt.inference.moves` (valid on its own at any time)."""
    return warmup_moves()


def integrated_time(chain: np.ndarray, c: float = 5.0) -> np.ndarray:
    """Integrated autocorrelation time per parameter (:func:`integrated_time_stuck`'s first part)."""
    return integrated_time_stuck(chain, c)[0]


def integrated_time_stuck(chain: np.ndarray, c: float = 5.0) -> tuple[np.ndarray, bool]:
    """Integrated autocorrelation time per parameter of ``chain (steps, walkers, ndim)`` [steps]:
    emcee's estimator (``emcee.autocorr.integrated_time``: each walker's normalised
    autocorrelation function by FFT, averaged over walkers, Sokal's window with ``c = 5``), with
    the walkers' FFTs done together, one parameter at a time. A parameter some walker never moved
    in counts as correlated over the whole chain (emcee gives NaN there), so every rule reads 'not
    converged' and no NaN reaches an integer (burn-in, thinning); the flag says whether one did."""
    chain = np.asarray(chain, float)
    n, _, ndim = chain.shape
    nfft = 2 * (1 << max(int(n - 1).bit_length(), 0))
    lags = np.arange(n)
    tau = np.empty(ndim)
    for d in range(ndim):
        x = chain[:, :, d] - chain[:, :, d].mean(axis=0)
        spec = np.fft.rfft(x, n=nfft, axis=0)
        acf = np.fft.irfft(spec.real**2 + spec.imag**2, n=nfft, axis=0)[:n]
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.mean(acf / acf[0], axis=1)
        taus = 2.0 * np.cumsum(f) - 1.0
        inside = lags < c * taus
        tau[d] = taus[np.argmin(inside)] if np.any(inside) else taus[-1]
    ok = np.isfinite(tau)
    return np.where(ok, tau, float(n)), not bool(np.all(ok))


def stopping_rule(chain: np.ndarray, n: int, settings: SamplerSettings, start: int = 0,
                  cache: dict | None = None) -> dict:
    """The stopping rule (module docstring) at step ``n``, from ``chain[start:n]`` only.

    ``chain`` has shape ``(steps, walkers, ndim)``; ``start`` is where the production segment
    begins (0: the whole chain); ``cache`` (a dict kept between calls on the same chain) memoises
    τ of ``chain[start:m]``. Returns the step, τ_max, the minimum ESS, each criterion's verdict and
    ``converged``.
    """
    cache = {} if cache is None else cache

    def tau_of(m_):
        key = (int(start), int(m_))
        if key not in cache:
            cache[key] = integrated_time_stuck(chain[start : start + m_])
        return cache[key]

    part = chain[start:n]
    m = part.shape[0]
    nwalkers = chain.shape[1]
    tau, stuck = tau_of(m)
    prev = m - settings.check_every
    change = math.inf
    if prev >= settings.check_every:
        tau_prev, _ = tau_of(prev)
        change = float(np.max(np.abs(tau - tau_prev) / tau))
    def ess_of(t):
        burn = min(int(math.ceil(2 * np.max(t))), m)
        return nwalkers * max(m - burn, 0) / t

    ess = ess_of(tau)
    stable = bool(change < settings.tau_rtol)
    margin = False
    if not stable and settings.tau_margin and math.isfinite(change):
        # a τ still moving by Δ may be low by about as much: the length and ESS conditions are
        # then judged with every τ enlarged by that change
        wide = tau * (1.0 + change)
        margin = bool(m >= settings.min_tau_multiple * np.max(wide)
                      and np.min(ess_of(wide)) >= settings.ess_target)
    out = {"step": int(n), "start": int(start), "tau_max": float(np.max(tau)),
           "n_over_tau": float(m / np.max(tau)), "tau_change": change, "ess_min": float(np.min(ess)),
           "long_enough": bool(m >= settings.min_tau_multiple * np.max(tau)),
           "tau_stable": stable or margin, "tau_margin": margin,
           "ess_reached": bool(np.min(ess) >= settings.ess_target), "stuck": stuck}
    out["converged"] = out["long_enough"] and out["tau_stable"] and out["ess_reached"] and not stuck
    return out


def _verdict_message(v: dict, max_steps: int, settings: SamplerSettings) -> str:
    what = "chain" if v.get("start", 0) == 0 else "production chain"
    if v["converged"]:
        return (f"converged at step {v['step']}: {what} {v['n_over_tau']:.0f} tau_max, "
                f"min ESS {v['ess_min']:.0f}, tau changed {100 * v['tau_change']:.1f} % since the last check"
                + (" (length and ESS met with tau enlarged by that change)" if v.get("tau_margin") else ""))
    why = []
    if v.get("stuck"):
        why.append("some parameters never moved (no accepted proposal: tau undefined); the posterior is "
                   "far narrower than the walkers' start, or zero around it: check the priors")
    elif not v["long_enough"]:
        why.append(f"{what} = {v['n_over_tau']:.1f} tau_max (need {settings.min_tau_multiple:g})")
    if not v["tau_stable"]:
        ch = "no previous check" if not math.isfinite(v["tau_change"]) else f"{100 * v['tau_change']:.1f} %"
        why.append(f"tau still changing ({ch}; need < {100 * settings.tau_rtol:g} %)")
    if not v["ess_reached"]:
        why.append(f"min ESS {v['ess_min']:.0f} (need {settings.ess_target:g})")
    return f"not converged within {max_steps} steps: " + ", ".join(why)


PRIOR_TAIL_Z = 4.0  # a posterior median this many prior standard deviations out: the prior's far tail
_BOUND_FRACTION = 1e-3  # of the prior's (log-)range: draws this close to a bound are piled against it


def prior_conflicts(params, draws: np.ndarray) -> list[dict]:
    """Parameters whose posterior sits in the far tail of their prior: the data and the prior
    disagree (a ``--priors`` file that excludes what the data say).

    ``draws`` are physical values ``(n, k)``. A normal or log-normal prior is in conflict when the
    draws' median lies more than :data:`PRIOR_TAIL_Z` prior standard deviations (of x, or of log x)
    from the prior's centre; a uniform or log-uniform prior when more than half the draws lie within
    :data:`_BOUND_FRACTION` of its range from one bound (the posterior piled against it). Returns
    ``{"name", "median", "unit", "prior", "how"}`` per parameter in conflict."""
    out = []
    draws = np.asarray(draws, float)
    if draws.ndim != 2 or draws.shape[0] == 0:
        return out
    for i, spec in enumerate(params):
        x = draws[:, i]
        x = x[np.isfinite(x)]
        if x.size == 0:
            continue
        med = float(np.median(x))
        pr = spec.prior
        how = None
        if isinstance(pr, Normal | LogNormal):
            if isinstance(pr, Normal):
                z = (med - pr.mu) / pr.sigma
                centre = f"{pr.mu:.4g}"
            else:
                z = (math.log(med) - math.log(pr.median)) / pr.sigma_log if med > 0 else -math.inf
                centre = f"{pr.median:.4g}"
            if abs(z) > PRIOR_TAIL_Z:
                how = (f"{abs(z):.3g} prior standard deviations {'above' if z > 0 else 'below'} the prior's "
                       f"centre {centre} {spec.unit}")
        elif isinstance(pr, Uniform | LogUniform):
            if isinstance(pr, LogUniform):
                u = (np.log(x) - math.log(pr.lower)) / math.log(pr.upper / pr.lower)
            else:
                u = (x - pr.lower) / (pr.upper - pr.lower)
            for side, near, bound in (("lower", u < _BOUND_FRACTION, pr.lower),
                                      ("upper", u > 1 - _BOUND_FRACTION, pr.upper)):
                if np.mean(near) > 0.5:
                    how = (f"{100 * np.mean(near):.0f} % of the draws against the prior's {side} bound "
                           f"{bound:.4g} {spec.unit}")
        if how is not None:
            out.append({"name": spec.name, "median": med, "unit": spec.unit, "prior": pr.to_dict(),
                        "how": how})
    return out


def conflict_message(conflicts: list[dict]) -> str:
    """One sentence naming each parameter of :func:`prior_conflicts` and what to do."""
    parts = [f"{c['name']} (posterior median {c['median']:.4g} {c['unit']}, {c['how']})" for c in conflicts]
    return ("the posterior lies in the far tail of the prior of " + "; ".join(parts)
            + ": the prior contradicts the data there; widen or recentre it (--priors), or check the data")


def _run_identity(target, seed: int, nwalkers: int, settings: SamplerSettings) -> dict:
    return {**target.identity(), "seed": int(seed), "nwalkers": int(nwalkers),
            "reseed_every": settings.reseed_every, "warmup": settings.warmup, "moves": MOVES_DESCRIPTION}


def _check_resume(path: Path, ident: dict) -> None:
    stored = read_identity(path)
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


def _open_store(checkpoint, resume, overwrite, ident, nwalkers, ndim, reseed_every) -> ChainStore:
    if checkpoint is None:
        store = ChainStore(None, reseed_every)
        store.create(nwalkers, ndim, ident)
        return store
    path = Path(checkpoint)
    check_checkpoint(path, resume=resume, overwrite=overwrite)
    store = ChainStore(path, reseed_every)
    if resume:
        _check_resume(path, ident)
        store.load()
        return store
    if path.exists():
        path.unlink()
    try:
        store.create(nwalkers, ndim, ident)
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return store


class _HeldSignals:
    """Hold SIGINT/SIGTERM while emcee steps (module docstring): the handler only records the
    signal; :meth:`check`, called between steps, raises :class:`~bayes_emt.errors.Interrupted`.
    SIGINT is held whenever its handler raises (Python's default); SIGTERM only when the program
    installed a handler of its own (the default, ending the process, is left alone). Only in the
    main thread (elsewhere signals are not delivered to Python code)."""

    def __init__(self):
        self.signum: int | None = None
        self._old: dict = {}

    def __enter__(self):
        if threading.current_thread() is not threading.main_thread():
            return self
        for sig in (signal.SIGINT, signal.SIGTERM):
            old = signal.getsignal(sig)
            if callable(old) and (sig == signal.SIGINT or old is not signal.default_int_handler):
                self._old[sig] = old
                signal.signal(sig, self._record)
        return self

    def _record(self, signum, frame):
        if self.signum is None:
            self.signum = signum

    def check(self) -> None:
        if self.signum is not None:
            raise Interrupted(self.signum)

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old = {}
        return False


def interruption(exc: KeyboardInterrupt, checkpoint) -> Interrupted:
    """The exception a stopped run raises: what the checkpoint holds, and how to continue."""
    signum = getattr(exc, "signum", signal.SIGINT)
    if checkpoint is None:
        return Interrupted(signum, "interrupted; no checkpoint was kept (the chain is lost)")
    steps = checkpoint_steps(checkpoint)
    if not steps:
        return Interrupted(signum, f"interrupted before the first block of steps was stored; nothing kept "
                                   f"(no checkpoint {checkpoint})")
    return Interrupted(signum, f"interrupted; checkpoint {checkpoint} is intact ({steps} steps stored), "
                               "continue with --resume")


def _acceptance(chain: np.ndarray, burn: int) -> float:
    """Fraction of accepted proposals after burn-in, from the chain itself (a continuous proposal
    never lands on its start), immune to the backend's counters."""
    c = chain[max(burn, 1) - 1 :]
    if c.shape[0] < 2:
        return float("nan")
    return float(np.mean(np.any(c[1:] != c[:-1], axis=-1)))


class _Phases:
    """The emcee samplers over one chain store (module docstring). Ensemble moves until
    ``warmup``; there the independence proposal is fitted to the warm-up's second half and a
    production segment starts. At every later ``warmup · 2^k`` the second half of the current
    segment is compared with the proposal (:func:`~bayes_emt.inference.moves.proposal_mismatch`);
    if they differ, a new segment starts there with the proposal refitted to that half. All of it is
    a function of the stored chain only, so a resume rebuilds the same segments and proposals."""

    def __init__(self, target, nwalkers: int, store: ChainStore, warmup: int):
        self.target, self.nwalkers, self.store, self.warmup = target, nwalkers, store, warmup
        self._warm = self._sampler(warmup_moves())
        self._segments: list[list] = []  # [start, proposal points' (mean, cov) or None, sampler or None]
        self._decided = 0  # refit points up to here are decided

    def _sampler(self, moves):
        return emcee.EnsembleSampler(self.nwalkers, self.target.ndim, self.target.emcee_log_prob,
                                     moves=moves, vectorize=True, backend=self.store)

    def _decide(self, n: int) -> None:
        """Decide every refit point up to step ``n`` (needs the chain up to it)."""
        if self.warmup == 0:
            return
        chain = None
        r = self.warmup if not self._segments else 2 * self._decided
        while r <= n:
            if chain is None:
                chain = self.store.get_chain()
            if not self._segments:
                pts = chain[r // 2 : r].reshape(-1, chain.shape[-1])
                self._segments.append([r, pts, None])
            else:
                start, pts, _ = self._segments[-1]
                new = chain[(start + r) // 2 : r].reshape(-1, chain.shape[-1])
                if proposal_mismatch(pts, new):
                    self._segments.append([r, new, None])
            self._decided = r
            r *= 2

    def at(self, n: int):
        """The sampler for the steps from ``n`` on (a block never crosses a refit point)."""
        self._decide(n)
        if not self._segments or n < self._segments[0][0]:
            return self._warm
        seg = self._segments[-1]
        if seg[2] is None:
            moves = production_moves(seg[1])
            seg[2] = self._sampler(moves) if moves is not None else self._warm
        return seg[2]

    def start(self, n: int) -> int:
        """Where the stopping rule's chain begins at step ``n``: the start of the segment step
        ``n − 1`` belongs to (0 during the warm-up)."""
        self._decide(n - 1)
        starts = [s for s, _, _ in self._segments if s <= n - 1]
        return starts[-1] if starts else 0


#: seconds between progress lines when ``progress`` is a callable (output redirected)
PROGRESS_EVERY_S = 5.0
#: steps a run makes before a ``deadline`` may stop it (the chain must be long enough to summarise)
MIN_STEPS_BEFORE_DEADLINE = 100


class _Lines:
    """Progress as periodic lines (``tell(str)`` at most every :data:`PROGRESS_EVERY_S` seconds):
    the tqdm bar's counterpart when the output is not a terminal."""

    def __init__(self, tell, label: str, total: int):
        self.tell, self.label, self.total = tell, label, total
        self.t0 = self.last = time.monotonic()
        self.postfix = ""

    def tick(self, n: int, force: bool = False) -> None:
        now = time.monotonic()
        if self.tell is not None and (force or now - self.last >= PROGRESS_EVERY_S):
            self.last = now
            self.tell(f"emcee {self.label}: step {n}/{self.total}{self.postfix} ({now - self.t0:.0f} s)")


def _run_locked(target, start, seed, max_steps, checkpoint, resume, overwrite, progress, settings, ident,
                nwalkers, ndim, deadline=None):
    """The body of :func:`run_ensemble`, run while holding the checkpoint's lock."""
    store = _open_store(checkpoint, resume, overwrite, ident, nwalkers, ndim, settings.reseed_every)
    lines = _Lines(progress if callable(progress) else None, target.label, max_steps)
    progress = sys.stderr.isatty() if progress is None else (False if callable(progress) else bool(progress))
    from tqdm.auto import tqdm

    bar = tqdm(total=max_steps, initial=min(store.iteration, max_steps), disable=not progress,
               file=sys.stderr, desc=f"emcee {target.label}", unit="step", leave=False)
    history: list[dict] = []
    verdict = None
    tau_cache: dict = {}
    stopped = None
    try:
        z0 = start(nwalkers) if store.iteration == 0 else None
        phases = _Phases(target, nwalkers, store, settings.warmup)
        with _HeldSignals() as held:
            while True:
                n = store.iteration
                sampler = phases.at(n)
                late = (deadline is not None and n >= MIN_STEPS_BEFORE_DEADLINE
                        and time.monotonic() >= deadline)
                if n > 0 and (n % settings.check_every == 0 or n >= max_steps or late):
                    verdict = stopping_rule(store.get_chain(), n, settings, phases.start(n), tau_cache)
                    history.append(verdict)
                    bar.set_postfix(tau_max=f"{verdict['tau_max']:.0f}", n_tau=f"{verdict['n_over_tau']:.0f}",
                                    ess=f"{verdict['ess_min']:.0f}")
                    lines.postfix = (f", tau_max {verdict['tau_max']:.0f}, {verdict['n_over_tau']:.0f} tau, "
                                     f"min ESS {verdict['ess_min']:.0f}")
                    if verdict["converged"] or n >= max_steps:
                        break
                    if late:
                        stopped = n
                        lines.tick(n, force=True)
                        break
                held.check()
                block = n // settings.reseed_every
                seg = min((block + 1) * settings.reseed_every - n, max_steps - n)
                if n == 0:
                    state = emcee.State(z0, random_state=_block_state(seed, 0))
                else:
                    state = store.get_last_sample()
                    state.random_state = _block_state(seed, block)
                # emcee's run_mcmc, a step at a time, acting on a held signal between steps
                for i, _ in enumerate(sampler.sample(state, iterations=seg, skip_initial_state_check=n > 0)):
                    held.check()
                    lines.tick(n + i + 1)
                store.flush()
                bar.update(seg)
    except BaseException as exc:
        # a run that stored no step leaves no checkpoint of its own making behind
        if checkpoint is not None and not resume and checkpoint_steps(checkpoint) in (0, None):
            Path(checkpoint).unlink(missing_ok=True)
        if isinstance(exc, KeyboardInterrupt):
            raise interruption(exc, checkpoint) from None
        raise
    finally:
        bar.close()
    return store, verdict, history, phases, tau_cache, stopped


def run_ensemble(target, start: Callable[[int], np.ndarray], *, seed: int = 0, max_steps: int | None = None,
                 checkpoint: str | Path | None = None, resume: bool = False, overwrite: bool = False,
                 progress: bool | None | Callable[[str], None] = None,
                 settings: SamplerSettings = SamplerSettings(), deadline: float | None = None) -> dict:
    """Run the ensemble sampler on any ``target`` to the stopping rule (module docstring).

    ``target`` has ``params`` (ParamSet with priors), ``ndim``, ``label``, ``identity()`` (what a
    checkpoint must match) and ``emcee_log_prob``
    (:class:`~bayes_emt.inference.likelihood.SamplingSpaceDensity`);
    ``start(nwalkers)`` returns the walkers' sampling-space start (only called for a fresh run).
    ``progress``: a tqdm bar on stderr (``None``: when stderr is a terminal), or a ``callable(str)``
    told the step, tau and ESS every :data:`PROGRESS_EVERY_S` seconds (for redirected output).
    ``deadline``: a :func:`time.monotonic` instant; at the first block boundary past it (and after
    :data:`MIN_STEPS_BEFORE_DEADLINE` steps) the run stops with what it has, its convergence verdict
    judged on that chain and its message saying the time budget stopped it.
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
    lock = None if checkpoint is None else CheckpointLock(checkpoint).acquire()
    try:
        store, verdict, history, phases, tau_cache, stopped = _run_locked(
            target, start, seed, max_steps, checkpoint, resume, overwrite, progress, settings, ident,
            nwalkers, ndim, deadline)
    finally:
        if lock is not None:
            lock.release()
    message = _verdict_message(verdict, max_steps, settings)
    if stopped is not None:
        message = message.replace(f"not converged within {max_steps} steps", "not converged: stopped by the "
                                  f"time budget at step {stopped} of {max_steps}")
    chain = store.get_chain()
    s0 = phases.start(chain.shape[0])
    cached = tau_cache.get((s0, chain.shape[0] - s0))
    tau = integrated_time(chain[s0:]) if cached is None else cached[0]
    burn = min(s0 + int(math.ceil(2 * np.max(tau))), chain.shape[0] - 1)
    with np.errstate(over="ignore", invalid="ignore"):
        conflicts = prior_conflicts(target.params, target.params.from_z(chain[burn:].reshape(-1, ndim)))
    if conflicts:
        # the specific cause first: a chain stuck in the prior's far tail also fails to converge
        conflict = conflict_message(conflicts)
        message = (f"{conflict} ({message})" if not verdict["converged"] else f"{message}; but {conflict}")
        warnings.warn(f"{target.label}: {conflict}", PriorConflictWarning, stacklevel=3)
    if not verdict["converged"]:
        warnings.warn(f"{target.label}: {message}", ConvergenceWarning, stacklevel=3)
    return {"chain": chain, "log_prob": store.get_log_prob(), "blobs": store.get_blobs(), "tau": tau,
            "burn": burn, "max_draws": settings.max_draws,
            "converged": verdict["converged"], "seed": seed, "message": message, "history": history,
            "acceptance": _acceptance(chain, burn), "wall_time": time.perf_counter() - t0,
            "settings": {**asdict(settings), "max_steps": max_steps, "nwalkers": nwalkers,
                         "moves": ident["moves"], "production_start": s0},
            "checkpoint": None if checkpoint is None else str(checkpoint)}


def sample_likelihood(lik: Likelihood, *, fit: FitResult | None = None, seed: int = 0,
                      max_steps: int | None = None, checkpoint: str | Path | None = None,
                      resume: bool = False, overwrite: bool = False,
                      progress: bool | None | Callable[[str], None] = None,
                      settings: SamplerSettings = SamplerSettings(),
                      deadline: float | None = None) -> Posterior:
    """Sample the posterior defined by a :class:`~bayes_emt.inference.likelihood.Likelihood` (its model,
    data, priors and noise model); arguments as :func:`sample_posterior`, ``progress`` and
    ``deadline`` as :func:`run_ensemble`."""
    t0 = time.perf_counter()

    def start(nwalkers):
        nonlocal fit
        if fit is None:
            from ..estimation.fitting import fit_admittance

            fit = fit_admittance(lik.meas, lik.model)
        return initial_walkers(lik, fit, nwalkers, np.random.default_rng(seed))

    run = run_ensemble(lik, start, seed=seed, max_steps=max_steps, checkpoint=checkpoint, resume=resume,
                       overwrite=overwrite, progress=progress, settings=settings, deadline=deadline)
    run["wall_time"] = time.perf_counter() - t0
    return Posterior.from_chain(lik, **run)


def sample_posterior(meas: Measurement, model: Model, *, fit: FitResult | None = None, seed: int = 0,
                     max_steps: int | None = None, checkpoint: str | Path | None = None,
                     resume: bool = False, overwrite: bool = False,
                     progress: bool | None | Callable[[str], None] = None,
                     likelihood: LikelihoodKind = "gaussian", nu: float | None = 4.0,
                     noise_params: ParamSet | None = None, noise: NoiseKind | None = None,
                     settings: SamplerSettings = SamplerSettings(),
                     deadline: float | None = None) -> Posterior:
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
    progress : tqdm progress bar on stderr (default: when stderr is a terminal), or a
        ``callable(str)`` told the step, tau and ESS every few seconds (:func:`run_ensemble`).
    likelihood, nu : ``"gaussian"``, or ``"student"`` with ``nu`` degrees of freedom (``None``:
        sampled).
    noise_params : noise priors (default :func:`~bayes_emt.inference.likelihood.noise_param_set`).
    noise : ``"white"`` (the default: independent errors, the posterior if the model were exact; the
        only choice with the Student-t likelihood) or ``"correlated"`` (instrument noise plus a model
        discrepancy correlated over log-frequency, :mod:`bayes_emt.inference.discrepancy`).
    settings : :class:`SamplerSettings`.
    deadline : a :func:`time.monotonic` instant at which the run stops with the chain it has
        (:func:`run_ensemble`; ``converged`` False, the message says the time budget stopped it).

    Returns
    -------
    Posterior
        Thinned draws after burn-in, diagnostics and provenance; ``converged`` False (with a
        :class:`~bayes_emt.errors.ConvergenceWarning`) when the budget ran out first.
    """
    if noise is None:
        noise = "white"
    lik = Likelihood(model, meas, likelihood, nu, noise_params, noise)
    return sample_likelihood(lik, fit=fit, seed=seed, max_steps=max_steps, checkpoint=checkpoint,
                             resume=resume, overwrite=overwrite, progress=progress, settings=settings,
                             deadline=deadline)
