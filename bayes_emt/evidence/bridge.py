"""log Z by bridge sampling on converged posterior draws (Meng & Wong 1996; Gronau et al. 2017).

With ``q(ξ)`` the unnormalised posterior density (prior × likelihood, in the unbounded coordinates
of :mod:`bayes_emt.evidence.warp`), ``Z = ∫ q``, posterior draws ``ξ_i`` (``i ≤ N1``) and draws
``ξ̃_j`` (``j ≤ N2``) of a normalised proposal ``g``, the ratios ``l1_i = q(ξ_i)/g(ξ_i)`` and
``l2_j = q(ξ̃_j)/g(ξ̃_j)`` give the iterative (optimal-bridge) estimate

    Z^(t+1) = [ (1/N2) Σ_j l2_j / (s1 l2_j + s2 Z^(t)) ] / [ (1/N1) Σ_i 1 / (s1 l1_i + s2 Z^(t)) ]

(Meng & Wong 1996 eq. 4.1; Gronau et al. 2017 eq. 9), ``s1 = N1_eff/(N1_eff + N2)``, ``s2 = 1 − s1``
with ``N1_eff`` the effective size of the autocorrelated posterior draws (as Gronau et al.'s
``bridgesampling`` package), iterated in log space until ``|Δ log Z| < tol``.

Proposal: a multivariate normal (or Student-t) with the mean and covariance of one half of the
posterior draws (half the walkers: ``fit`` half); the estimate uses the other half (``eval``), so
the proposal is independent of the draws it is tested on (Overstall & Forster 2010; Gronau et
al. 2017 §4).

Error: the relative mean-squared error of ``Ẑ`` (Frühwirth-Schnatter 2004, eq. 14, as in
Gronau et al. 2017 eq. 14 and ``bridgesampling::error_measures``),

    RE² = Var_g(f1) / (N2 E_g(f1)²) + τ_f2 Var_p(f2) / (N1 E_p(f2)²),
    f1 = p̂/(s1 p̂ + s2 g) on proposal draws,   f2 = g/(s1 p̂ + s2 g) on posterior draws,

with ``p̂ = q/Ẑ`` and ``τ_f2`` the integrated autocorrelation time of ``f2`` along the chains
(the normalised spectral density at zero frequency, which accounts for the draws' autocorrelation
through the effective sample size ``N1/τ_f2``). ``sqrt(RE²)`` is the standard error of ``log Ẑ``
(delta method). :func:`bridge_evidence` repeats the estimate with the halves swapped and over
proposal seeds and reports their spread beside the formula error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import emcee
import numpy as np
from scipy import special, stats

from ..params import ParamSet
from .warp import Warp

__all__ = ["BridgeEstimate", "BridgeResult", "bridge_estimate", "bridge_evidence"]


@dataclass(frozen=True)
class BridgeEstimate:
    """One bridge-sampling estimate (one split, one proposal seed).

    Attributes
    ----------
    log_z : log evidence [nats]; err : ``sqrt(RE²)`` [nats] (module docstring).
    n_post, n_proposal : posterior draws the estimate used and proposal draws.
    tau_f2 : integrated autocorrelation time of ``f2`` [draws]; ess : ``n_post/tau_f2``.
    n_iter : iterations of the Meng-Wong scheme; converged : whether it met ``tol``.
    """

    log_z: float
    err: float
    n_post: int
    n_proposal: int
    tau_f2: float
    ess: float
    n_iter: int
    converged: bool


@dataclass(frozen=True)
class BridgeResult:
    """Bridge sampling repeated over half-splits and proposal seeds.

    Attributes
    ----------
    log_z : mean of the repeats [nats].
    err : the formula error, root-mean-square over the repeats [nats] (averaging repeats that
        share draws does not shrink it).
    spread : standard deviation of the repeats' ``log_z`` [nats].
    repeats : every :class:`BridgeEstimate`.
    n_calls : log-density evaluations made (proposal draws; posterior draws unless supplied).
    proposal : ``"normal"`` or ``"t"``.
    """

    log_z: float
    err: float
    spread: float
    repeats: tuple[BridgeEstimate, ...]
    n_calls: int
    proposal: str
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def to_json_dict(self) -> dict:
        return {"method": "bridge", "log_evidence": self.log_z, "err": self.err, "spread": self.spread,
                "n_calls": self.n_calls, "proposal": self.proposal,
                "repeats": [{"log_evidence": r.log_z, "err": r.err, "n_post": r.n_post,
                             "n_proposal": r.n_proposal, "tau_f2": r.tau_f2, "ess": r.ess,
                             "n_iter": r.n_iter, "converged": r.converged} for r in self.repeats],
                "warnings": list(self.warnings)}


class _Proposal:
    """Multivariate normal or Student-t (``df``) fitted to draws.

    Fitted in standardised coordinates ``u = (x − mean)/sd``: posterior draws of a transducer model
    span scales from 1e-12 to 1e4 in sampling space (a noise floor the data do not bound spreads
    over decades), so the raw covariance can be too ill-conditioned for scipy's positive-definite
    check (condition ≈ 1e11 seen on NL(5)); the correlation matrix is not, and its eigenvalues are
    floored at 1e-9 of the largest. ``logpdf`` carries the Jacobian ``−Σ log sd``.
    """

    def __init__(self, draws: np.ndarray, kind: str, df: float = 5.0):
        self.kind, self.df = kind, df
        draws = np.atleast_2d(draws)
        self.mean = draws.mean(axis=0)
        sd = draws.std(axis=0, ddof=1)
        self.sd = np.where(sd > 0, sd, 1.0)
        self._log_jac = float(np.sum(np.log(self.sd)))
        u = (draws - self.mean) / self.sd
        cov = np.atleast_2d(np.cov(u, rowvar=False))
        if kind == "t":
            cov = cov * (df - 2) / df  # the t's covariance is scale · df/(df − 2)
        w, V = np.linalg.eigh(0.5 * (cov + cov.T))
        w = np.maximum(w, 1e-9 * max(float(w.max()), 1e-300))
        cov = (V * w) @ V.T
        self.cov = 0.5 * (cov + cov.T)
        zero = np.zeros(self.mean.size)
        if kind == "normal":
            self.dist = stats.multivariate_normal(zero, self.cov, allow_singular=True)
        else:
            self.dist = stats.multivariate_t(zero, self.cov, df=df, allow_singular=True)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        u = np.atleast_2d(self.dist.rvs(size=n, random_state=rng)).reshape(n, -1)
        return self.mean + self.sd * u

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        u = (np.atleast_2d(x) - self.mean) / self.sd
        return np.atleast_1d(self.dist.logpdf(u)) - self._log_jac


def _iterate(l1: np.ndarray, l2: np.ndarray, n1_eff: float, tol: float, max_iter: int):
    """Meng-Wong fixed point in log space; ``l1``, ``l2`` are log ratios ``log q − log g``."""
    n1, n2 = l1.size, l2.size
    ls1, ls2 = math.log(n1_eff / (n1_eff + n2)), math.log(n2 / (n1_eff + n2))
    # start from the importance-sampling estimate with the proposal draws
    log_z = float(special.logsumexp(l2) - math.log(n2))
    for it in range(1, max_iter + 1):
        num = special.logsumexp(l2 - np.logaddexp(ls1 + l2, ls2 + log_z)) - math.log(n2)
        den = special.logsumexp(-np.logaddexp(ls1 + l1, ls2 + log_z)) - math.log(n1)
        new = float(num - den)
        if abs(new - log_z) < tol:
            return new, it, True, ls1, ls2
        log_z = new
    return log_z, max_iter, False, ls1, ls2


def _tau(series: np.ndarray) -> float:
    """Integrated autocorrelation time of ``series (draws, chains)``, at least 1."""
    if series.shape[0] < 4:
        return 1.0
    with np.errstate(all="ignore"):
        tau = float(emcee.autocorr.integrated_time(series[:, :, None], tol=0)[0])
    return max(tau, 1.0) if math.isfinite(tau) else float(series.shape[0])


def bridge_estimate(log_q, fit_draws: np.ndarray, eval_draws: np.ndarray, *, rng: np.random.Generator,
                    log_q_eval: np.ndarray | None = None, n_proposal: int | None = None,
                    proposal: str = "normal", tau_floor: float = 1.0, tol: float = 1e-10,
                    max_iter: int = 1000) -> tuple[BridgeEstimate, int]:
    """One bridge-sampling estimate in unbounded coordinates.

    Parameters
    ----------
    log_q : vectorised unnormalised log posterior ``(n, k) -> (n,)`` in these coordinates.
    fit_draws : (n, k) posterior draws the proposal is fitted to.
    eval_draws : (draws, chains, k) posterior draws the estimate uses, in chain order (for ``τ_f2``).
    log_q_eval : ``log_q`` at ``eval_draws`` (draws, chains), if already known.
    n_proposal : proposal draws (default: as many as ``eval_draws``).
    tau_floor : lower bound on ``τ_f2`` [draws] (e.g. the chains' largest parameter τ over the thinning).

    Returns
    -------
    (estimate, number of ``log_q`` evaluations made)
    """
    nd, nc, k = eval_draws.shape
    flat = eval_draws.reshape(-1, k)
    n1 = flat.shape[0]
    n2 = int(n_proposal or n1)
    g = _Proposal(fit_draws, proposal)
    calls = 0
    if log_q_eval is None:
        lq1 = np.asarray(log_q(flat), float)
        calls += n1
    else:
        lq1 = np.asarray(log_q_eval, float).reshape(-1)
    prop = g.sample(n2, rng)
    lq2 = np.asarray(log_q(prop), float)
    calls += n2
    l1 = lq1 - g.logpdf(flat)
    l2 = lq2 - g.logpdf(prop)
    # first pass with N1 as effective size, then τ_f2 from that estimate, then the final pass
    log_z, _, _, ls1, ls2 = _iterate(l1, l2, n1, tol, max_iter)
    f2 = np.exp(-np.logaddexp(ls1 + l1 - log_z, ls2))
    tau = max(_tau(f2.reshape(nd, nc)), tau_floor, 1.0)
    log_z, n_iter, ok, ls1, ls2 = _iterate(l1, l2, n1 / tau, tol, max_iter)
    r1 = l2 - log_z  # log p̂/g on proposal draws
    r2 = l1 - log_z  # on posterior draws
    f1 = np.exp(r1 - np.logaddexp(ls1 + r1, ls2))
    f2 = np.exp(-np.logaddexp(ls1 + r2, ls2))
    tau = max(_tau(f2.reshape(nd, nc)), tau_floor, 1.0)
    re2 = (np.var(f1) / (n2 * np.mean(f1) ** 2) if np.mean(f1) > 0 else math.inf) \
        + tau * np.var(f2) / (n1 * np.mean(f2) ** 2)
    return BridgeEstimate(float(log_z), float(math.sqrt(re2)), n1, n2, float(tau), float(n1 / tau), n_iter,
                          bool(ok)), calls


def bridge_evidence(log_density_z, params: ParamSet, draws_z: np.ndarray, *, seed: int = 0,
                    log_density_draws: np.ndarray | None = None, n_seeds: int = 2,
                    n_proposal: int | None = None, proposal: str = "normal",
                    tau_floor: float = 1.0) -> BridgeResult:
    """log Z from posterior draws in sampling space, repeated over both half-splits and seeds.

    Parameters
    ----------
    log_density_z : vectorised unnormalised log posterior in sampling space ``(n, k) -> (n,)``
        (prior with its log-Jacobian plus log-likelihood: ``Likelihood.log_posterior_z``).
    params : the sampled ParamSet (its bounds define the logit warp).
    draws_z : (chains, draws, k) posterior draws in sampling space (walkers × kept steps).
    seed : seeds the proposal draws (repeat ``s`` uses ``seed + s``).
    log_density_draws : (chains, draws) ``log_density_z`` at ``draws_z`` (e.g. the stored
        ``log_prob``), to save evaluations.
    n_seeds : proposal seeds per split (2 splits: walkers ``0::2`` fit/``1::2`` estimate and swapped).
    n_proposal : proposal draws per estimate (default: as many as the half's draws).
    proposal : ``"normal"`` (Gronau et al.) or ``"t"`` (5 degrees of freedom, heavier tails).
    tau_floor : lower bound on ``τ_f2`` [kept draws].
    """
    if proposal not in ("normal", "t"):
        raise ValueError(f"proposal must be 'normal' or 't', got {proposal!r}")
    draws_z = np.asarray(draws_z, float)
    if draws_z.ndim != 3 or draws_z.shape[0] < 2:
        raise ValueError("draws_z must be (chains, draws, k) with at least 2 chains")
    flat = draws_z.reshape(-1, draws_z.shape[-1])
    warp = Warp.near_bounds(params, flat.min(axis=0), flat.max(axis=0), flat.std(axis=0), n_sd=3.0)
    log_q = warp.log_density(log_density_z)
    xi = warp.to_xi(draws_z)
    lq = None
    if log_density_draws is not None:
        lq = np.asarray(log_density_draws, float) + warp.log_jacobian(xi)
    if not np.all(np.isfinite(xi)):
        raise ValueError("posterior draws lie on a prior bound: cannot bridge-sample them")
    halves = (slice(0, None, 2), slice(1, None, 2))
    reps, calls = [], 0
    for s in range(max(1, int(n_seeds))):
        for h in (0, 1):
            fit, ev = xi[halves[h]], xi[halves[1 - h]]
            lq_ev = None if lq is None else lq[halves[1 - h]].T
            est, c = bridge_estimate(log_q, fit.reshape(-1, xi.shape[-1]), np.swapaxes(ev, 0, 1),
                                     rng=np.random.default_rng([int(seed), s, h]), log_q_eval=lq_ev,
                                     n_proposal=n_proposal, proposal=proposal, tau_floor=tau_floor)
            reps.append(est)
            calls += c
    vals = np.array([r.log_z for r in reps])
    errs = np.array([r.err for r in reps])
    warn = []
    if not all(r.converged for r in reps):
        warn.append("bridge sampling: the Meng-Wong iteration did not converge in some repeats")
    if not np.all(np.isfinite(vals)):
        warn.append("bridge sampling: a repeat gave a non-finite log evidence")
    err, spread = float(np.sqrt(np.mean(errs**2))), float(np.std(vals, ddof=1))
    if spread > 3 * err + 0.1:
        warn.append(f"bridge sampling: repeats spread {spread:.2f} nats, more than their error {err:.2f}: "
                    "the two halves of the walkers describe different posteriors (multimodal or unconverged)")
    return BridgeResult(float(np.mean(vals)), err, spread, tuple(reps), calls, proposal, tuple(warn))
