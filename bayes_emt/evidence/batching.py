"""A pool-like object that turns dynesty's many one-point likelihood calls into few vectorised ones.

dynesty asks for new live points through ``pool.map(sampler, jobs)``: each of the ``queue_size``
jobs is a whole proposal (a random walk of ``walks`` steps, a slice-sampling sequence, or one
uniform draw from the bound) that calls ``loglikelihood(v)`` for *one* point at a time, each
call depending on the previous one. :class:`BatchingPool` runs the jobs of one ``map`` as
threads in lockstep: every call a job makes to :meth:`BatchingPool.loglike` parks that job;
when every unfinished job is parked the pool evaluates all their points in **one** vectorised
call of the batch log-likelihood ``(n, k) -> (n,)`` and releases them. A queue of ``Q`` random
walks therefore costs ``walks`` vectorised calls of ``Q`` points instead of ``Q·walks`` scalar
calls; the Python work of the jobs still runs one at a time (the GIL), only the model
evaluation is batched. Thread hand-offs cost about 0.2 ms per point, so for the default
random walk there is a faster path: :class:`BatchRWalkSampler` is dynesty's ``rwalk`` with a
``sample`` function that the pool recognises and runs for the whole queue at once, in numpy,
without threads (:func:`batched_random_walk`: dynesty's move, vectorised), and likewise for
slice sampling (:class:`BatchSliceSampler`, :func:`batched_slice`). The initial live points are
also evaluated in one call.

The result does not depend on thread scheduling: each job draws from its own generator (dynesty
seeds one per queued job) and receives exactly the likelihood of the point it asked for, so a
seeded run is reproducible.

Checkpoints: dynesty pickles its sampler, including the ``loglikelihood`` and ``prior_transform``
it was given. The pool's threads and locks cannot be pickled (nor should a checkpoint carry the
whole likelihood with its data), so the functions handed to dynesty are :class:`Relay` objects that
pickle as a name only; :func:`register` binds the name to the live pool again before a checkpoint is loaded.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np
from dynesty.internal_samplers import RWalkSampler, SamplerReturn, SliceSampler, UnitCubeSampler
from dynesty.utils import LogLikelihood, LoglOutput, get_random_generator

__all__ = ["BatchingPool", "BatchRWalkSampler", "BatchSliceSampler", "Relay", "batched_random_walk",
           "batched_slice", "register", "unregister"]

_REGISTRY: dict[str, BatchingPool] = {}
_REGISTRY_LOCK = threading.Lock()


def register(key: str, pool: BatchingPool) -> None:
    """Bind ``key`` to ``pool`` so that :class:`Relay` objects named ``key`` reach it (also after
    unpickling a checkpoint)."""
    with _REGISTRY_LOCK:
        _REGISTRY[key] = pool


def unregister(key: str) -> None:
    with _REGISTRY_LOCK:
        _REGISTRY.pop(key, None)


def _lookup(key: str) -> BatchingPool:
    with _REGISTRY_LOCK:
        try:
            return _REGISTRY[key]
        except KeyError:
            raise RuntimeError(f"no batching pool registered as {key!r} (a nested-sampling checkpoint "
                               "is being used without its run)") from None


class Relay:
    """dynesty's ``loglikelihood`` (``what="loglike"``) or ``prior_transform`` (``"prior_transform"``),
    forwarding to the pool registered as ``key``; pickles as ``(key, what)`` only."""

    def __init__(self, key: str, what: str):
        if what not in ("loglike", "prior_transform"):
            raise ValueError(f"unknown relay {what!r}")
        self.key, self.what = key, what

    def __call__(self, x):
        return getattr(_lookup(self.key), self.what)(x)

    def __reduce__(self):
        return (Relay, (self.key, self.what))


class BatchingPool:
    """Lockstep thread pool for dynesty (module docstring).

    Parameters
    ----------
    batch_loglike : ``(n, k)`` physical values → ``(n,)`` log-likelihood [nats], vectorised.
    prior_transform : ``(..., k)`` unit cube → physical values, vectorised.
    size : the queue size dynesty reads as ``pool.size`` (jobs evaluated together).

    Attributes
    ----------
    n_calls : points evaluated so far (likelihood calls in dynesty's sense).
    n_batches : vectorised calls made so far.
    """

    def __init__(self, batch_loglike: Callable[[np.ndarray], np.ndarray],
                 prior_transform: Callable[[np.ndarray], np.ndarray], size: int):
        if int(size) < 1:
            raise ValueError(f"queue size must be at least 1, got {size!r}")
        self.size = int(size)
        self._batch = batch_loglike
        self._ptform = prior_transform
        self.n_calls = 0
        self.n_batches = 0
        self._local = threading.local()
        self._lock = threading.Lock()  # guards _pending and _running
        self._pending: dict[int, np.ndarray] = {}
        self._results: dict[int, float] = {}
        self._go: list[threading.Semaphore] = []  # one per job: its batch is evaluated
        self._all_parked = threading.Semaphore(0)  # every unfinished job is parked or done
        self._running = 0

    # ---- what dynesty calls ---------------------------------------------------------------------
    def prior_transform(self, u):
        return self._ptform(np.asarray(u, float))

    def loglike(self, v) -> float:
        """One point's log-likelihood: parks the calling job until its batch is evaluated (inside
        :meth:`map`), or evaluates at once (outside)."""
        v = np.asarray(v, float)
        slot = getattr(self._local, "slot", None)
        if slot is None:
            return float(self._evaluate(v[None, :])[0])
        with self._lock:
            self._pending[slot] = v
            self._park()
        self._go[slot].acquire()
        return self._results.pop(slot)

    def _park(self) -> None:
        """One job parked or finished (caller holds ``_lock``); wake the coordinator on the last."""
        self._running -= 1
        if self._running == 0:
            self._all_parked.release()

    def map(self, func, iterable) -> list:
        """``[func(x) for x in iterable]``, the jobs run in lockstep with batched likelihoods."""
        items = list(iterable)
        batched = _unit_cube_batched if func is UnitCubeSampler.sample else getattr(func, "batched", None)
        if batched is not None and items:
            return batched(items, self._prior_batch, self._evaluate)
        if isinstance(func, LogLikelihood) and isinstance(func.loglikelihood, Relay) and items:
            return [LoglOutput(float(v), False) for v in self._evaluate(np.stack(items))]
        if len(items) <= 1:
            return [func(x) for x in items]
        out: list = [None] * len(items)
        errors: list[BaseException] = []

        def job(i, x):
            self._local.slot = i
            try:
                out[i] = func(x)
            except BaseException as exc:  # re-raised in the caller's thread
                errors.append(exc)
            finally:
                self._local.slot = None
                with self._lock:
                    self._park()

        self._pending.clear()
        self._results.clear()
        self._go = [threading.Semaphore(0) for _ in items]
        self._running = len(items)
        threads = [threading.Thread(target=job, args=(i, x), daemon=True) for i, x in enumerate(items)]
        for t in threads:
            t.start()
        while True:
            self._all_parked.acquire()
            with self._lock:
                slots = sorted(self._pending)
                batch = [self._pending.pop(s) for s in slots]
            if not slots:
                break
            try:
                vals = self._evaluate(np.stack(batch))
            except BaseException as exc:
                errors.append(exc)
                vals = np.full(len(slots), -np.inf)
            self._running = len(slots)
            for s, val in zip(slots, vals, strict=True):
                self._results[s] = float(val)
            for s in slots:
                self._go[s].release()
        for t in threads:
            t.join()
        if errors:
            raise errors[0]
        return out

    # ---- internals ----------------------------------------------------------------------------
    def _prior_batch(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(self._ptform(np.asarray(u, float)), float)

    def _evaluate(self, batch: np.ndarray) -> np.ndarray:
        vals = np.asarray(self._batch(batch), float).reshape(batch.shape[0])
        self.n_calls += batch.shape[0]
        self.n_batches += 1
        # -inf (outside the model's domain) is allowed by dynesty >= 3.1; NaN never is
        return np.where(np.isnan(vals), -np.inf, vals)


def _queue(args: list, what: str):
    """``(kwargs, loglstar, u (Q, k), axes (Q, k, k), scale (Q,), rng)`` of a queue of dynesty jobs
    (the sampler's keyword arguments, ``L*`` and the generator from the first job), refusing what
    the batched samplers do not support (``what`` names the sampler in the message)."""
    kw = args[0].kwargs
    if kw.get("periodic") is not None or kw.get("reflective") is not None:
        raise ValueError(f"{what} supports no periodic or reflective parameters")
    u = np.array([a.u for a in args], float)
    n = u.shape[1]
    axes = np.array([a.axes for a in args], float)
    if axes.shape[1:] != (n, n):
        raise ValueError(f"{what} needs ncdim == ndim")
    scale = np.array([a.scale for a in args], float)
    return kw, args[0].loglstar, u, axes, scale, get_random_generator(args[0].rseed)


def batched_random_walk(args: list, prior_transform, evaluate) -> list:
    """dynesty's random walk (``generic_random_walk``) for a whole queue of jobs, vectorised: one
    likelihood call per step, proposals drawn for all jobs at once.

    Each job makes exactly ``walks`` proposals uniform in its ellipsoid ``u + scale · axes · ball``
    (ball: the unit ``k``-ball), rejected outright outside the unit cube; a proposal with
    ``log L > loglstar`` replaces the walker. This is dynesty's move, same distribution and same
    counts; the random numbers come from one generator seeded by the first job's seed (dynesty
    seeds every job from the run's ``rstate``), so a seeded run is reproducible, but its draws
    differ from dynesty's per-job function.
    """
    kw, loglstar, u, axes, scale, rng = _queue(args, "the batched random walk")
    walks = int(kw["walks"])
    nq, n = u.shape
    scale = scale[:, None]
    v = np.full_like(u, np.nan)
    logl = np.full(nq, np.nan)
    n_accept = np.zeros(nq, int)
    n_reject = np.zeros(nq, int)
    for _ in range(walks):
        g = rng.standard_normal((nq, n))
        r = rng.uniform(size=(nq, 1)) ** (1.0 / n)
        ball = g / np.linalg.norm(g, axis=1, keepdims=True) * r
        prop = u + scale * np.einsum("qij,qj->qi", axes, ball)
        ok = np.all((prop > 0) & (prop < 1), axis=1)
        n_reject[~ok] += 1
        if not ok.any():
            continue
        idx = np.flatnonzero(ok)
        vp = prior_transform(prop[idx])
        lp = evaluate(vp)
        acc = lp > loglstar
        hit = idx[acc]
        u[hit], v[hit], logl[hit] = prop[hit], vp[acc], lp[acc]
        n_accept[hit] += 1
        n_reject[idx[~acc]] += 1
    stuck = n_accept == 0
    if stuck.any():  # as dynesty: the start point's value is recomputed
        v[stuck] = prior_transform(u[stuck])
        logl[stuck] = evaluate(v[stuck])
    return [SamplerReturn(u=u[q].copy(), v=v[q].copy(), logl=float(logl[q]), ncalls=walks,
                          tuning_info={"accept": int(n_accept[q]), "reject": int(n_reject[q]),
                                       "scale": args[q].scale},
                          evaluation_history=[],
                          proposal_stats={"n_accept": int(n_accept[q]), "n_reject": int(n_reject[q])})
            for q in range(nq)]


def _unit_cube_batched(args: list, prior_transform, evaluate) -> list:
    """dynesty's ``UnitCubeSampler.sample`` (uniform draws from the cube until ``log L > loglstar``;
    the sampler of the first iterations) for a whole queue, one vectorised call per round."""
    ndim = args[0].kwargs.get("ndim")
    loglstar = args[0].loglstar
    rng = [get_random_generator(a.rseed) for a in args]
    nq = len(args)
    u = np.empty((nq, ndim))
    v = np.empty((nq, ndim))
    logl = np.empty(nq)
    nc = np.zeros(nq, int)
    todo = np.arange(nq)
    while todo.size:
        cand = np.array([rng[q].uniform(size=ndim) for q in todo])
        vc = prior_transform(cand)
        lc = evaluate(vc)
        nc[todo] += 1
        u[todo], v[todo], logl[todo] = cand, vc, lc
        todo = todo[~(lc > loglstar)]
    return [SamplerReturn(u=u[q], v=v[q], logl=float(logl[q]), ncalls=int(nc[q]), tuning_info=None,
                          evaluation_history=[], proposal_stats={"n_proposals": int(nc[q])})
            for q in range(nq)]


def _batchable(base, batched):
    """A ``sample`` for a subclass of dynesty's sampler ``base``: one job ``base``'s own way (when
    no :class:`BatchingPool` runs the queue), carrying ``batched``, the vectorised version for a
    whole queue that :meth:`BatchingPool.map` runs instead."""

    def sample(args):
        return base.sample(args)

    sample.batched = batched
    return staticmethod(sample)


class BatchRWalkSampler(RWalkSampler):
    """dynesty's ``rwalk`` whose queue a :class:`BatchingPool` runs vectorised."""

    sample = _batchable(RWalkSampler, batched_random_walk)


def batched_slice(args: list, prior_transform, evaluate) -> list:
    """dynesty's ``slice`` sampler (``SliceSampler.sample``: ``slices`` rounds, each a univariate
    slice step along every principal axis of the bound in a random order, with stepping out and
    shrinkage, Neal 2003) for a whole queue of jobs, vectorised: the jobs take their axis steps in
    lockstep, and every stage (the two first ends, each stepping-out round, each shrinkage
    round) evaluates the points of all jobs that need one in a single likelihood call.

    Same moves, same interval rules and the same call counts per job as dynesty's (a point outside
    the unit cube counts as a call of log L = −inf, as there); the random numbers come from one
    generator seeded by the first job's seed. Neal's doubling variant (dynesty switches to it after
    1000 expansions in one step) is not implemented: a job with such a step reports
    ``expansion_warning_set`` in its tuning info, and stepping out goes on one width at a time.
    """
    kw, loglstar, u, axes, scale, rng = _queue(args, "the batched slice sampler")
    slices = int(kw.get("slices", 5))
    nq, n = u.shape
    dirs = scale[:, None, None] * np.transpose(axes, (0, 2, 1))
    maxlen = np.sqrt(n) / 2.0
    nc = np.zeros(nq, int)
    n_expand = np.zeros(nq, int)
    n_contract = np.zeros(nq, int)
    long_step = np.zeros(nq, bool)  # a step that expanded more than 1000 times
    v = np.full_like(u, np.nan)
    logl = np.full(nq, np.nan)
    allq = np.arange(nq)

    def F(q, x, d):
        """log L at ``u[q] + x d`` (−inf outside the cube); counts a call per point."""
        pts = u[q] + x[:, None] * d
        out = np.full(q.size, -np.inf)
        inside = np.all((pts > 0) & (pts < 1), axis=1)
        vv = np.full_like(pts, np.nan)
        if inside.any():
            vv[inside] = prior_transform(pts[inside])
            out[inside] = evaluate(vv[inside])
        np.add.at(nc, q, 1)  # q repeats a job asking for both ends of its interval
        return pts, vv, out

    for _ in range(slices):
        order = np.array([rng.permutation(n) for _ in range(nq)])
        for j in range(n):
            d = dirs[allq, order[:, j]]  # (nq, n): each job's axis of this step
            dl = np.linalg.norm(d, axis=1)
            d = d / np.where(dl > maxlen, dl / maxlen, 1.0)[:, None]
            r0 = rng.random(nq)
            left, right = -r0, 1.0 - r0
            ends = F(np.r_[allq, allq], np.r_[left, right], np.r_[d, d])[2]
            ll, lr = ends[:nq], ends[nq:]
            expand_before = n_expand.copy()
            while True:  # stepping out, both ends of every job in one call per round
                gl, gr = np.flatnonzero(ll > loglstar), np.flatnonzero(lr > loglstar)
                if gl.size == 0 and gr.size == 0:
                    break
                left[gl] -= 1.0
                right[gr] += 1.0
                n_expand[gl] += 1
                n_expand[gr] += 1
                q = np.r_[gl, gr]
                vals = F(q, np.r_[left[gl], right[gr]], d[q])[2]
                ll[gl], lr[gr] = vals[: gl.size], vals[gl.size :]
            long_step |= n_expand - expand_before > 1000
            todo = allq.copy()
            while todo.size:  # shrinkage
                x = left[todo] + rng.random(todo.size) * (right[todo] - left[todo])
                pts, vv, lp = F(todo, x, d[todo])
                n_contract[todo] += 1
                acc = lp > loglstar
                hit = todo[acc]
                u[hit], v[hit], logl[hit] = pts[acc], vv[acc], lp[acc]
                miss, xm = todo[~acc], x[~acc]
                if np.any(xm == 0):
                    raise RuntimeError("slice sampler: shrank onto its start point without a valid point")
                left[miss] = np.where(xm < 0, xm, left[miss])
                right[miss] = np.where(xm > 0, xm, right[miss])
                todo = miss
    return [SamplerReturn(u=u[q].copy(), v=v[q].copy(), logl=float(logl[q]), ncalls=int(nc[q]),
                          tuning_info={"n_expand": int(n_expand[q]), "n_contract": int(n_contract[q]),
                                       "expansion_warning_set": bool(long_step[q])},
                          evaluation_history=[],
                          proposal_stats={"n_expand": int(n_expand[q]), "n_contract": int(n_contract[q])})
            for q in range(nq)]


class BatchSliceSampler(SliceSampler):
    """dynesty's ``slice`` whose queue a :class:`BatchingPool` runs vectorised."""

    sample = _batchable(SliceSampler, batched_slice)
