"""The robust RC shunt by sample-average approximation (SAA) over posterior draws.

One ``(Rs, Cs)`` for all draws of the design half (common random numbers: every candidate is
scored on the same draws), minimising a risk measure of the attenuation ``a_i(x)`` [dB] over the
draws on which it is stable (:mod:`bayes_emt.shunt.risk`: CVaR_α, mean or worst), subject to the
chance constraint ``#unstable ≤ ⌊ε n_m⌋`` within every model's draws (``n_m`` of them). With
``ε n_m < 1`` that is "stable on every design draw"; an unstable draw's peak is infinite and a
draw close to its threshold has a tall, lightly damped peak, so the risk measure itself keeps the
design away from the stability boundary.

**Solver.** Each draw's attenuation is the largest of its peaks, ``a_i = max_k a_ik`` (smooth
``a_ik``, gradients by the envelope theorem): a min-max problem, made smooth by its epigraph
form (variables ``x = (Rs, ln Cs)``, a level ``t`` and excesses ``z_i ≥ 0``):

* CVaR (Rockafellar–Uryasev): ``min t + Σ z_i / ((1 − α) n)`` s.t. ``z_i ≥ a_ik(x) − t``;
* mean: ``min Σ z_i / n`` s.t. ``z_i ≥ a_ik(x)``;  worst: ``min t`` s.t. ``t ≥ a_ik(x)``;

plus ``Rs ≥ Rs_limit(Cs) + 1e-9 Ω`` (the ``⌊ε n_m⌋+1``-th largest threshold of every model), solved
by SLSQP. Only draws that can reach the tail enter (the active set: CVaR the ``2(1−α)n + 10``
highest, worst the highest 8); after each solve every draw is re-scored and the set grown if the tail
left it. Where the last SQP round stopped on "no decrease" rather than converging, a short
Nelder–Mead on the exact SAA objective finishes from its result (:func:`_finish`: the peaks' kinks
made where the SQP stops depend on its start). The result is compared, on the exact SAA objective,
with the starts (the nominal design among them), and the best is kept: the robust shunt is never
worse than the nominal one on the design half. For a posterior collapsed to a point this problem
*is* the equal-peak H∞ problem, so the robust shunt is the nominal one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from .batch.peaks import SLOTS, rc_peaks_batch
from .batch.plant import BatchPlant
from .risk import RiskKind, cvar, risk_value

__all__ = ["DrawPool", "PoolEval", "RobustChoice", "choose_robust"]

_DB = 20.0 / math.log(10.0)
_DELTA_STAB = 1e-9  # Ω: strict stability at the optimum


@dataclass(frozen=True)
class PoolEval:
    """One shunt scored on the draws of a :class:`DrawPool` (``n`` rows, pool order).

    Attributes
    ----------
    attenuation : ``(n,)`` [dB]; +inf where the loop is unstable.
    slots : ``(n, SLOTS)`` [dB] each peak (lower, upper, at the binding crossing, the band's low
        edge; a missing one repeats the largest). grads : ``(n, SLOTS, 2)`` [dB per Ω, dB per unit
        ln Cs] or None.
    margin : ``(n,)`` ``Rs − threshold`` [Ω]. stable : ``(n,)``. threshold : ``(n,)`` [Ω].
    """

    attenuation: np.ndarray
    slots: np.ndarray
    grads: np.ndarray | None
    margin: np.ndarray
    stable: np.ndarray
    threshold: np.ndarray


class DrawPool:
    """Draws of several models scored together: ``parts`` is a list of ``(BatchPlant, idx)``."""

    def __init__(self, parts: Sequence[tuple[BatchPlant, np.ndarray]]):
        self.parts = [(bp, np.asarray(idx, int)) for bp, idx in parts]
        self.group = np.concatenate([np.full(idx.size, g) for g, (_, idx) in enumerate(self.parts)])
        self.n = int(self.group.size)
        self._offsets = np.cumsum([0] + [idx.size for _, idx in self.parts])

    def _split(self, rows):
        """Per part: (part index, positions in ``rows``, draw indices in its BatchPlant)."""
        rows = np.arange(self.n) if rows is None else np.asarray(rows, int)
        for g, (bp, idx) in enumerate(self.parts):
            a, b = self._offsets[g], self._offsets[g + 1]
            pos = np.flatnonzero((rows >= a) & (rows < b))
            if pos.size:
                yield bp, pos, idx[rows[pos] - a]

    def thresholds(self, Cs, Rs=None, rows=None) -> np.ndarray:
        rows_n = self.n if rows is None else len(rows)
        out = np.empty(rows_n)
        for bp, pos, idx in self._split(rows):
            out[pos] = bp.threshold(Cs, idx, Rs)
        return out

    def evaluate(self, Rs: float, Cs: float, *, gradients: bool = False, rows=None) -> PoolEval:
        """Score the shunt ``(Rs [Ω], Cs [F])`` on draws ``rows`` (default all)."""
        m = self.n if rows is None else len(rows)
        # peak slots per draw: the two coarse maxima, the binding crossing, the band's low edge
        att, slots = np.full(m, np.inf), np.full((m, SLOTS), np.nan)
        grads = np.full((m, SLOTS, 2), np.nan) if gradients else None
        margin, stable, thr = np.empty(m), np.empty(m, bool), np.empty(m)
        for bp, pos, idx in self._split(rows):
            cr = bp.crossings(Cs, idx, Rs)
            pb = rc_peaks_batch(bp, Rs, Cs, idx, gradients=gradients, crossings=cr)
            v = 20 * np.log10(pb.value / bp.open_peak[idx][:, None])
            best = np.nanargmax(np.where(np.isfinite(v), v, -np.inf), axis=1)
            top = v[np.arange(idx.size), best]
            fill = ~np.isfinite(v)
            slots[pos] = np.where(fill, top[:, None], v)
            if gradients:
                gb = pb.grad[np.arange(idx.size), best]
                grads[pos] = np.where(fill[..., None], gb[:, None, :], pb.grad) * _DB
            st = cr.stable(Rs)
            att[pos] = np.where(st, top, np.inf)
            margin[pos], stable[pos], thr[pos] = Rs - cr.threshold, st, cr.threshold
        return PoolEval(att, slots, grads, margin, stable, thr)


@dataclass(frozen=True)
class RobustChoice:
    """The SAA optimum: ``Rs`` [Ω], ``Cs`` [F], ``risk`` [dB] on the design half, and ``info``
    (solver record: starts and their risks, active-set sizes, SLSQP messages)."""

    Rs: float
    Cs: float
    risk: float
    info: dict = field(default_factory=dict)


def _allowed(pool: DrawPool, epsilon: float) -> np.ndarray:
    counts = np.bincount(pool.group, minlength=len(pool.parts))
    return np.floor(epsilon * counts + 1e-12).astype(int)


def _score(pool, ev: PoolEval, risk, alpha, allowed) -> float:
    """The exact SAA objective: risk over stable draws; inf when the chance constraint fails."""
    bad = np.bincount(pool.group[~ev.stable], minlength=len(pool.parts))
    if np.any(bad > allowed):
        return math.inf
    return risk_value(ev.attenuation[ev.stable], risk, alpha)


def _limit(pool, Cs, Rs, allowed, excluded) -> float:
    """The Rs [Ω] below which more draws than allowed (beyond ``excluded``) would be unstable."""
    thr = pool.thresholds(Cs, Rs)
    thr[excluded] = -np.inf
    out = -np.inf
    for g, k in enumerate(allowed):
        t = np.sort(thr[pool.group == g])[::-1]
        k_left = int(k - np.count_nonzero(excluded[pool.group == g]))
        if t.size and k_left < t.size:
            out = max(out, t[max(k_left, 0)])
    return out


def _active(ev: PoolEval, risk, alpha, keep) -> np.ndarray:
    a = np.where(keep, ev.attenuation, -np.inf)
    n = int(np.count_nonzero(keep))
    if risk == "mean":
        return np.flatnonzero(keep)
    k = 8 if risk == "worst" else int(math.ceil(2 * (1 - alpha) * n)) + 10
    return np.argsort(-a)[: min(k, n)]


def _tail(ev: PoolEval, risk, alpha) -> np.ndarray:
    """The draws the risk measure is made of at this shunt (CVaR: the worst ⌈(1−α)n⌉ + 1)."""
    a = np.where(ev.stable, ev.attenuation, -np.inf)
    n = int(np.count_nonzero(ev.stable))
    if risk == "mean":
        return np.flatnonzero(ev.stable)
    k = 1 if risk == "worst" else int(math.ceil((1 - alpha) * n)) + 1
    return np.argsort(-a)[: min(k, n)]


def _risk_rows(att, risk, alpha, n_eff) -> float:
    """The risk over ``n_eff`` draws of which only ``att`` (the ones that can reach the tail) are
    given; the others are taken to lie below it."""
    if risk == "cvar":
        return cvar(np.r_[att, np.full(n_eff - att.size, -np.inf)], alpha) if n_eff > att.size \
            else cvar(att, alpha)
    return risk_value(att, risk, alpha)


def _psd(B, floor):
    w, V = np.linalg.eigh(0.5 * (B + B.T))
    return (V * np.maximum(w, floor)) @ V.T


def _phi(a, g, d, risk, alpha, n_eff):
    """The linearised SAA objective ``Φ(d)`` = risk over draws of ``max_k (a_ik + g_ik·d)``, a
    subgradient, and the weights ``λ (na, 3)`` of the pieces that make it up."""
    lin = a + g @ d
    k = np.argmax(lin, axis=1)
    top = lin[np.arange(a.shape[0]), k]
    w = np.zeros(a.shape[0])
    if risk == "worst":
        w[np.argmax(top)] = 1.0
    elif risk == "mean":
        w[:] = 1.0 / n_eff
    else:
        cap = 1.0 / ((1 - alpha) * n_eff)
        order = np.argsort(-top)
        room = np.clip(1.0 - cap * np.arange(order.size), 0.0, cap)
        w[order] = room
    lam = np.zeros(a.shape)
    lam[np.arange(a.shape[0]), k] = w
    return float(w @ top), np.einsum("ik,ikq->q", lam, g), lam


def _qp(a, g, B, risk, alpha, n_eff, stab, trust, up=math.inf):
    """The SQP subproblem ``min_d ½ dᵀBd + Φ(d)`` (``Φ`` from :func:`_phi`, convex and piecewise
    linear) subject to the linearised stability limit ``stab = (c, ∇c)`` and ``|d| ≤ trust``, by
    cutting planes (proximal bundle: each cut is exact, the model is exact once it holds the pieces
    active at the optimum). Returns ``(d, λ (na, 3))``, the pieces' multipliers."""
    cuts_v, cuts_s, cuts_d, cuts_l = [], [], [], []

    def add(d):
        v, sg, lam = _phi(a, g, d, risk, alpha, n_eff)
        cuts_v.append(v), cuts_s.append(sg), cuts_d.append(d.copy()), cuts_l.append(lam)
        return v

    d = np.zeros(2)
    add(d)
    mu = np.ones(1)
    for _ in range(80):
        V, S, D = np.array(cuts_v), np.array(cuts_s), np.array(cuts_d)
        off = V - np.einsum("jq,jq->j", S, D)

        def cons(z, S=S, off=off):
            return z[2] - off - S @ z[:2]

        jac = np.hstack([-S, np.ones((S.shape[0], 1))])
        r0 = float(np.max(off + S @ d))
        res = optimize.minimize(lambda z: 0.5 * z[:2] @ B @ z[:2] + z[2], np.r_[d, r0],
                                jac=lambda z: np.r_[B @ z[:2], 1.0], method="SLSQP",
                                bounds=[(-trust[0], trust[0]), (-trust[1], max(min(trust[1], up), -trust[1])),
                                        (None, None)],
                                constraints=[{"type": "ineq", "fun": cons, "jac": lambda z, jac=jac: jac},
                                             {"type": "ineq", "fun": lambda z: stab[0] + stab[1] @ z[:2],
                                              "jac": lambda z: np.r_[stab[1], 0.0][None, :]}],
                                options={"maxiter": 200, "ftol": 1e-16})
        d, r = res.x[:2], res.x[2]
        mu = np.maximum(np.asarray(res.multipliers[: len(cuts_v)], float), 0.0) \
            if res.multipliers is not None else np.r_[np.zeros(len(cuts_v) - 1), 1.0]
        if add(d) - r <= 1e-13 * (1.0 + abs(r)):
            break
    mu = mu / mu.sum() if mu.sum() > 0 else np.r_[np.zeros(len(mu) - 1), 1.0]
    lam = np.einsum("j,jik->ik", mu, np.array(cuts_l[: mu.size]))
    return d, lam


def _sqp(pool, x0, risk, alpha, rows, n_eff, allowed, excluded, *, max_iter: int = 30,
         lcs_max: float = math.inf, deadline: float = math.inf, tick=None):
    """SQP on the SAA problem restricted to draws ``rows`` (module docstring): the Lagrangian's
    Hessian in ``x`` is ``Σ λ_ik ∇²a_ik`` with the peaks' Hessians from finite differences of
    their envelope gradients, so convergence is fast once the active pieces settle.
    Returns ``(x, record)``."""
    h = np.array([1e-5, 1e-5])
    x = np.asarray(x0, float).copy()
    trust = np.array([0.05, 0.2])
    evals = 0

    def evaluate(x, grad):
        nonlocal evals
        evals += 1
        return pool.evaluate(x[0], math.exp(x[1]), gradients=grad, rows=rows)

    def merit(e):
        if np.any(~e.stable):
            return math.inf
        return _risk_rows(e.attenuation, risk, alpha, n_eff)

    e = evaluate(x, True)
    f = merit(e)
    lam = None
    msg = "iteration limit"
    it = 0
    while it < max_iter:
        if time.perf_counter() > deadline:
            msg = "time budget reached"
            break
        it += 1
        if tick is not None:
            tick(f"iteration {it}, {risk} {f:.4f} dB" if math.isfinite(f) else f"iteration {it}")
        H = np.empty(e.grads.shape + (2,))
        for q in range(2):
            xq = x.copy()
            xq[q] += h[q]
            H[..., q] = (evaluate(xq, True).grads - e.grads) / h[q]
        H = 0.5 * (H + np.swapaxes(H, -1, -2))
        lim = _limit(pool, math.exp(x[1]), x[0], allowed, excluded)
        dlim = (_limit(pool, math.exp(x[1] + h[1]), x[0], allowed, excluded) - lim) / h[1]
        stab = (x[0] - lim - _DELTA_STAB, np.array([1.0, -dlim if math.isfinite(dlim) else 0.0]))
        if lam is None:  # first guess: the largest peak of every draw, equally weighted
            lam = (e.slots == np.max(e.slots, axis=1, keepdims=True)) / max(rows.size, 1)
        for _ in range(2):
            B = np.einsum("ik,ikab->ab", lam, H)
            scale = max(float(np.max(np.abs(B))), 1e-12)
            d, lam = _qp(e.slots, e.grads, _psd(B, 1e-8 * scale), risk, alpha, n_eff, stab, trust,
                         lcs_max - x[1])
        step, accepted = 1.0, False
        for _ in range(12):
            xn = x + step * d
            xn[1] = min(xn[1], lcs_max)
            en = evaluate(xn, True)
            fn = merit(en)
            if fn <= f:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            msg = "no decrease along the SQP step (converged to the precision of the peaks)"
            break
        moved = np.abs(xn - x)
        x, e, f_old, f = xn, en, f, fn
        trust = np.minimum(np.maximum(trust, 4 * moved), [0.5, 1.0])
        if np.all(moved < 1e-11) or f_old - f < 1e-13:
            msg = "converged"
            break
    return x, {"message": msg, "iterations": it, "evaluations": evals}


def choose_robust(pool: DrawPool, starts: Sequence[tuple[float, float]], *, risk: RiskKind = "cvar",
                  alpha: float = 0.9, epsilon: float = 1e-3, max_rounds: int = 5,
                  cs_max: float | None = None, time_budget: float | None = None,
                  tick=None) -> RobustChoice:
    """The SAA-optimal shunt over ``pool`` (module docstring), from the best of ``starts``
    (``(Rs [Ω], Cs [F])`` pairs; put the nominal design first). ``cs_max`` [F]: the upper bound on
    Cs the designs of single draws respect (:func:`~bayes_emt.shunt.batch.design.cs_bound`); without
    it a loudspeaker's robust Cs wandered to 1e7 F. ``time_budget`` [wall s]: stop the rounds
    there and keep the best shunt so far (``info["time_budget_reached"]``). ``tick``: optional
    ``callable(str)`` told each SQP iteration (progress)."""
    deadline = math.inf if time_budget is None else time.perf_counter() + time_budget
    if not 0 <= epsilon < 1:
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}")
    allowed = _allowed(pool, epsilon)
    scored = []
    for rs, cs in starts:
        ev = pool.evaluate(rs, cs)
        scored.append((_score(pool, ev, risk, alpha, allowed), float(rs), float(cs), ev))
    info = {"starts": [{"Rs": s[1], "Cs": s[2], "risk_db": s[0]} for s in scored], "rounds": []}
    best = min(scored, key=lambda s: s[0])
    feasible = [s for s in scored if math.isfinite(s[0])]
    if feasible:
        cur = min(feasible, key=lambda s: s[0])
    else:  # lift the best start above the stability limit
        rs, cs = best[1], best[2]
        none = np.zeros(pool.n, bool)
        rs = _limit(pool, cs, rs, allowed, none) + 1e-3 * (1 + abs(rs))
        ev = pool.evaluate(rs, cs)
        cur = (_score(pool, ev, risk, alpha, allowed), rs, cs, ev)
        info["lifted_start"] = {"Rs": rs, "Cs": cs, "risk_db": cur[0]}
    x = np.array([cur[1], math.log(cur[2])])
    ev = cur[3]
    active = np.empty(0, int)
    for rnd in range(max_rounds):
        if time.perf_counter() > deadline:
            info["time_budget_reached"] = True
            break
        excluded = ~ev.stable
        keep = ~excluded
        active = np.union1d(active, _active(ev, risk, alpha, keep)).astype(int)
        active = active[keep[active]]
        x_new, rec = _sqp(pool, x, risk, alpha, active, int(np.count_nonzero(keep)), allowed, excluded,
                          lcs_max=math.inf if cs_max is None else math.log(cs_max), deadline=deadline,
                          tick=None if tick is None else (lambda m, r=rnd: tick(f"round {r + 1}, {m}")))
        if rec["message"] == "time budget reached":
            info["time_budget_reached"] = True
        ev_new = pool.evaluate(x_new[0], math.exp(x_new[1]))
        val = _score(pool, ev_new, risk, alpha, allowed)
        tail = _tail(ev_new, risk, alpha)
        info["rounds"].append({"active": int(active.size), **rec, "Rs": float(x_new[0]),
                               "Cs": math.exp(x_new[1]), "risk_db": val})
        improved = val < cur[0]
        if improved:
            cur, x, ev = (val, float(x_new[0]), math.exp(x_new[1]), ev_new), x_new, ev_new
        if np.all(np.isin(tail, active)) or not improved:
            break
    val, rs, cs = cur[:3]
    last = info["rounds"][-1]["message"] if info["rounds"] else ""
    if last != "converged" and time.perf_counter() < deadline:
        val, rs, cs = _finish(pool, (val, rs, cs), risk, alpha, allowed, cs_max, info)
    return RobustChoice(rs, cs, val, info)


#: evaluations of the derivative-free finish (:func:`_finish`), about 2 CPU s on 500 design draws
FINISH_EVALS = 40


def _finish(pool, cur, risk, alpha, allowed, cs_max, info) -> tuple[float, float, float]:
    """A derivative-free finish on the exact SAA objective from the SQP's result ``cur`` ``(risk, Rs,
    Cs)``, returning the same triple: Nelder–Mead in ``(Rs, ln Cs)``, :data:`FINISH_EVALS`
    evaluations, simplex steps 2 % of Rs and 0.1 in ln Cs; kept only when lower. The SQP stops on
    "no decrease" where the peaks' kinks make its quadratic model a poor guide, and where it stops
    then depends on its start: on a posterior of LS10-44 (NL(4) + creep + winding capacitance)
    starts 1e-9 apart ended 0.85 dB apart in CVaR (-11.79 to -12.64 dB); with this finish, within
    0.03 dB (-12.62 to -12.64)."""
    lcs_max = math.inf if cs_max is None else math.log(cs_max)

    def f(x):
        if not np.all(np.isfinite(x)) or x[1] > lcs_max:
            return math.inf
        return _score(pool, pool.evaluate(float(x[0]), math.exp(x[1])), risk, alpha, allowed)

    x0 = np.array([cur[1], math.log(cur[2])])
    simplex = np.array([x0, x0 + [0.02 * abs(x0[0]) + 1e-3, 0.0], x0 + [0.0, -0.1 if x0[1] + 0.1 > lcs_max
                                                                      else 0.1]])
    res = optimize.minimize(f, x0, method="Nelder-Mead",
                            options={"initial_simplex": simplex, "maxfev": FINISH_EVALS,
                                     "xatol": 1e-9, "fatol": 1e-6})
    better = bool(math.isfinite(res.fun) and res.fun < cur[0])
    info["finish"] = {"method": "Nelder-Mead", "evaluations": int(res.nfev), "risk_db": float(res.fun),
                      "Rs": float(res.x[0]), "Cs": math.exp(float(res.x[1])), "kept": better}
    if not better:
        return cur
    return float(res.fun), float(res.x[0]), math.exp(float(res.x[1]))
