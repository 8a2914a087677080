"""Naming the missing physics: fit each candidate, rank by evidence and by how much it whitens the band.

For a located band (:mod:`.locate`) each candidate physics (:mod:`.candidates`) is fitted:

* a catalogue term is added to the current model and started inside the band from the current fit
  (:func:`~bayes_emt.estimation.augment.augmentation_starts`, the term's own multi-start), each of
  the best few starts polished by :func:`~bayes_emt.estimation.fitting.fit_admittance` (whose
  resonance rule keeps ``ω0`` where the data has its resonance, so the fits compare like with
  like); the best polish counts;
* the eddy-current escalation (:data:`~bayes_emt.models.EDDY_PHYSICS`) fits the coil models up
  the ladder from the data (ring count of NL by evidence among them).

Each fit's log evidence is the Laplace screen of :mod:`bayes_emt.evidence` (the same
approximation its comparison uses from a least-squares fit, with the noise scales as parameters),
so ``Δ log Z`` is against the current model on the same data and priors. When the screen fails (a
flat direction: a parameter not determined against another, a noise scale pressed against its
bound, a step's frequency between two measured points), :mod:`.evidence` falls back to Laplace on
the identifiable subspace with the flat directions integrated numerically; the candidate records
which method gave its ``Δ log Z`` (:attr:`Candidate.evidence_method`), and a candidate whose new
parameters lie along a flat direction is not identifiable (the fit improves, the data do not
determine the value). The band's χ² is the sum
of squared normalised residuals (both parts) in the band with the noise of the location
(:attr:`~.locate.Location.sigma_rel`), before and after.

A candidate is **accepted** when ``Δ log Z ≥`` :data:`MIN_DELTA_LOG_Z` (≥ 5 nats: "very strong" on
Kass & Raftery's scale, :mod:`bayes_emt.evidence.scale`), it removes at least
:data:`MIN_WHITENING` of the band's structure (:attr:`Candidate.whitening`) and its fitted values
are this physics (:meth:`~bayes_emt.models.term.Term.implausible`: a vented box's port tuned far
from the driver's resonance is another mode). It is **identifiable** when every parameter it adds
has a relative standard error (sampling space, from the fit's covariance) below
:data:`MAX_REL_SE` and the term's catalogue entry does not say otherwise (lead resistance).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from ..errors import FitError
from ..estimation.augment import augmentation_starts
from ..estimation.fitting import covariance_z, fit_admittance, fit_reusing
from ..estimation.results import FitResult
from ..evidence.fit_evidence import Evidence, fit_log_evidence
from ..evidence.scale import verbal
from ..inference.likelihood import Likelihood
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, Model, make_term, parse_model_spec
from ..models.residual import relative_residual, rms_relative_residual
from .candidates import escalations
from .locate import Band, scan_statistics

__all__ = [
    "Candidate",
    "log_evidence",
    "max_log_likelihood",
    "band_chi2",
    "fit_candidate",
    "fit_jobs",
    "CpuClock",
    "FitCache",
    "rank_candidates",
    "MIN_DELTA_LOG_Z",
    "REFINE_TOP",
    "MIN_WHITENING",
    "MAX_REL_SE",
]

MIN_DELTA_LOG_Z = 5.0
MIN_WHITENING = 0.3
MAX_REL_SE = 0.5
#: augmentation starts polished per candidate term (three: a step's frequency found by the third of
#: its starts was lost with two, and a polish costs a second)
STARTS_POLISHED = 3


@dataclass(frozen=True)
class Candidate:
    """One tried explanation of a band.

    ``physics`` the catalogue id; ``fit`` its least-squares fit; ``log_z`` its Laplace log evidence
    [nats] (``evidence_method`` ``"laplace"``; ``"laplace_step"`` for a step term, its frequency
    summed over the intervals between points; or ``"laplace_subspace"``: the fallback of
    :mod:`.evidence`, ``evidence_note`` why and what it did); ``delta_log_z`` against the current
    model; ``chi2_band_before``/``after`` the band's
    χ²; ``identifiable`` and ``identifiability`` (why); ``n_band`` the band's residual count
    (its χ² expectation when white); ``added`` the parameters the candidate
    adds ``{name: (value, stderr)}`` [SI]."""

    physics: str
    fit: FitResult
    log_z: float
    delta_log_z: float
    chi2_band_before: float
    chi2_band_after: float
    identifiable: bool
    identifiability: str
    n_band: int = 0
    scan_before: float = 0.0
    scan_after: float = 0.0
    added: dict = field(default_factory=dict)
    implausible: str | None = None
    evidence_method: str = "laplace"
    evidence_note: str = ""
    #: a generic patch (:func:`.prefer.is_patch`) and, when it has not earned its place, why
    patch: bool = False
    patch_problem: str | None = None

    @property
    def n_added(self) -> int:
        return len(self.added)

    @property
    def whitening(self) -> float:
        """Fraction of the band's structure removed: ``(T_before − T_after)/(T_before − 3)`` with ``T``
        the largest scan statistic (:func:`~.locate.scan_statistics`, χ²₃ when white, mean 3) of the
        windows inside the band, residuals normalised by the location's noise."""
        excess = self.scan_before - 3.0
        return float((self.scan_before - self.scan_after) / excess) if excess > 0 else 0.0

    @property
    def accepted(self) -> bool:
        return bool(
            self.delta_log_z >= MIN_DELTA_LOG_Z
            and self.whitening >= MIN_WHITENING
            and self.implausible is None
            and self.patch_problem is None
        )

    @property
    def strength(self) -> str:
        return verbal(self.delta_log_z)


def log_evidence(meas: Measurement, fit: FitResult) -> float:
    """Log evidence [nats] of ``fit.model`` on ``meas`` (Gaussian likelihood with sampled noise
    scales) from the least-squares fit: the Laplace screen, its fallback when the screen fails
    (:func:`.evidence.evidence`); ``nan`` when neither gives a number."""
    return fit_log_evidence(meas, fit).log_z


def max_log_likelihood(meas: Measurement, fit: FitResult) -> float:
    """``max log p(Y | θ, σ)`` [nats] at the least-squares ``θ`` over the noise scales
    (``σ_rel``, ``σ_abs``), used in place of the current model's evidence when both its Laplace
    screen and the fallback of :mod:`.evidence` fail. It is *not* an upper bound of ``log Z``:
    the likelihood is maximised over the noise scales only, at ``θ`` fitted by least squares, and
    where the absolute noise floor matters the posterior's ``θ`` differs (on II fitted to data with
    leads, the fallback's log Z, an importance-sampling estimate that overstates by ``a`` nats with
    probability at most ``e^-a``, lies 1189 nats above it); ``Δ log Z`` is then approximate."""
    lik = Likelihood(fit.model, meas)
    rel = rms_relative_residual(fit.model, fit.theta, meas) / math.sqrt(2)
    ymin = float(np.min(np.abs(meas.Y)))

    def nll(x):
        th = np.r_[fit.theta, np.exp(x[0]), np.exp(x[1]), [10.0] * lik.sample_nu]
        v = float(lik(th))
        return -v if math.isfinite(v) else 1e300

    best = min(
        (
            optimize.minimize(
                nll,
                [math.log(rel), math.log(a * ymin)],
                method="Nelder-Mead",
                options={"xatol": 1e-6, "fatol": 1e-6},
            )
            for a in (1e-6, 1e-2)
        ),
        key=lambda r: r.fun,
    )
    return float(-best.fun)


def band_chi2(meas: Measurement, model: Model, theta, band: Band, sigma_rel: float) -> float:
    """χ² of the band: Σ over its points of ``|Y(θ) − Y|²/(σ |Y|)²`` (both parts)."""
    sl = slice(band.i_lo, band.i_hi + 1)
    with np.errstate(all="ignore"):
        d = relative_residual(model, theta, meas)[sl]
    v = float(np.sum(np.abs(d) ** 2) / sigma_rel**2)
    return v if math.isfinite(v) else float("inf")


def band_scan(meas: Measurement, model: Model, theta, band: Band, sigma_rel: float) -> float:
    """Largest scan statistic of the windows lying inside ``band`` (both parts)."""
    with np.errstate(all="ignore"):
        rel = relative_residual(model, theta, meas)
    r = np.stack([rel.real, rel.imag]) / sigma_rel
    best = 0.0
    for L, starts, T in scan_statistics(r):
        inside = (starts >= band.i_lo) & (starts + L - 1 <= band.i_hi)
        if np.any(inside):
            best = max(best, float(np.max(T[:, inside])))
    return best if math.isfinite(best) else float("inf")


def _held_step_sd(meas: Measurement, fit: FitResult, steps: set) -> dict | None:
    """Standard deviations in sampling space of ``fit``'s parameters other than its step frequencies,
    from the relative-residual Jacobian with those held (``s² (JᵀJ)⁻¹``, central differences): the
    fit's own covariance is ``None`` because a step frequency's column is zero between two points.
    ``None`` when the rest is rank-deficient too."""
    model = fit.model
    z = np.asarray(model.params.to_z(fit.theta), float)
    free = [i for i, n in enumerate(model.names) if n not in steps]

    def res(zz):
        with np.errstate(all="ignore"):
            r = relative_residual(model, model.params.from_z(zz), meas)
        return np.r_[r.real, r.imag]

    r0 = res(z)
    J = np.empty((r0.size, len(free)))
    for c, i in enumerate(free):
        h = 1e-6 * max(1.0, abs(z[i]))
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        J[:, c] = (res(zp) - res(zm)) / (2 * h)
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r0))):
        return None
    cov = covariance_z(J, r0, len(free))
    if cov is None:
        return None
    return {model.names[i]: float(np.sqrt(max(cov[c, c], 0.0))) for c, i in enumerate(free)}


def _identifiable(fit: FitResult, new_names: list[str], physics: str,
                  ev: Evidence | None = None, meas: Measurement | None = None) -> tuple[bool, str, dict]:
    model = fit.model
    se = fit.stderr
    added = {n: (float(v), float(se[n])) for n, v in model.as_dict(fit.theta).items() if n in new_names}
    # a step between two measured points (a term's ``step_at``) is flat between them by construction:
    # the data pin it to that interval, which :func:`.prefer.step_evidence` checks; the other added
    # parameters must be determined
    ids = physics.split("+")
    steps = {t.step_at for t in model.augmentations if t.id in ids and t.step_at}
    new_names = [n for n in new_names if n not in steps]
    flat = sorted({n for f in (ev.flat if ev is not None else ()) for n in f if n in new_names})
    if flat:
        return (
            False,
            f"the posterior is flat along {', '.join(flat)}: the data do not determine "
            + ("it" if len(flat) == 1 else "them")
            + " (its evidence integrates that direction numerically)",
            added,
        )
    if fit.cov_z is None and not steps:
        return (
            False,
            "the fit's Jacobian is rank-deficient: the data do not determine the new parameters",
            added,
        )
    if fit.cov_z is None:  # the step's own column is zero: the rest judged with the step held there
        sd = None if meas is None else _held_step_sd(meas, fit, steps)
        if sd is None and meas is not None:
            return (False, "the fit's Jacobian is rank-deficient with the step held: the data do not "
                    "determine the new parameters", added)
        bad = [n for n in new_names if sd is not None and sd.get(n, 0.0) > MAX_REL_SE]
        if bad:
            return (False, f"not determined by the data: {', '.join(bad)} (relative sd > {MAX_REL_SE:g})",
                    added)
        return True, "the step lies between two adjacent points; its size is determined by the data", added
    sd_z = np.sqrt(np.clip(np.diag(fit.cov_z), 0, None))
    bad = [n for n in new_names if sd_z[model.names.index(n)] > MAX_REL_SE]
    notes = [t.identifiability for t in model.augmentations if t.id in ids and t.identifiability]
    if bad:
        return False, f"not determined by the data: {', '.join(bad)} (relative sd > {MAX_REL_SE:g})", added
    if notes:
        return False, notes[0], added
    return True, "every added parameter is determined by the data", added


def fit_candidate(
    meas: Measurement, current: FitResult, physics: str, band: Band, *, warm: bool = True,
    cache: dict | None = None, evidence: bool = True,
) -> list[tuple[FitResult, Evidence | None]]:
    """``(fit, evidence)`` of ``physics`` added to ``current.model`` (module docstring); for
    the eddy-current escalation one per escalated coil model; for a joint ``"a+b"`` the second
    term added to the first's fit (``current`` is then that fit). Fits that fail are left out.

    ``warm`` (default): a catalogue term's starts, which :func:`augmentation_starts` builds from
    ``current``'s fit (the shared parameters at their fitted values), are polished directly
    (:func:`fit_admittance` ``warm=True``: no paper steps 1-2, which only hand on a start); without
    it each start runs the full fit. ``cache``: a :class:`FitCache` of ``meas``, read and filled: a
    coil model of the escalation (and the nested fits its start-up needs: NL's UL surrogate, the
    model without its last augmentation) is fitted once per diagnosis whatever the band or round;
    the result does not depend on it (:func:`~bayes_emt.estimation.fitting.fit_reusing`).
    ``evidence=False``: a catalogue term's best fit alone, ``[(fit, None)]`` (its evidence is
    computed by whoever needs it: :func:`_refine` only for a fit that replaces its warm one). A single
    step term's fit whose step the measured points do not show gets no evidence (method
    ``"refused"``, :func:`_step_fit_evidence`): it is refused whatever its evidence."""
    out = []
    single = "+" not in physics
    if not single:
        physics = physics.split("+")[-1]
    if physics == EDDY_PHYSICS:
        # up the ladder; NL's ring count by evidence: more rings until one more ring loses, or until
        # NO_EVIDENCE_RUNGS rungs in a row have no finite evidence (nothing to compare: a rung's
        # evidence fails where its rings are not determined, and more rings only add such directions)
        best, without = -math.inf, 0
        for model in escalations(current.model):
            try:
                fit = fit_reusing(meas, model, None if cache is None else cache.fits)
            except (FitError, ValueError):
                continue
            ev = fit_log_evidence(meas, fit) if cache is None else cache.evidence_of(meas, fit)
            lz = ev.log_z
            out.append((fit, ev))
            if model.rings is not None:  # the ring ladder
                if best > -math.inf and not lz > best:
                    break
                best = max(best, lz) if math.isfinite(lz) else best
                without = 0 if math.isfinite(lz) else without + 1
                if without >= NO_EVIDENCE_RUNGS:
                    break
        return out
    term = make_term(physics)
    try:
        new, starts = augmentation_starts(meas, current.model, current.theta, term, band=(band.lo, band.hi))
    except ValueError:
        return []
    fits = []
    for s in starts[:STARTS_POLISHED]:
        try:
            fits.append(fit_admittance(meas, new, initial=s, warm=warm))
        except (FitError, ValueError):
            continue
    if term.step_at and term.stage == "measurement":
        fits += _divided_fits(meas, current, new, starts[:STARTS_POLISHED], term.step_at)
    ok = [f for f in fits if not f.info.get("resonance_mismatch")] or fits
    if not ok:
        return []
    if term.step_at:
        # a step's fits at different frequencies are different explanations: the best by χ² may put
        # it where the data are smooth (another misfit pulls it), so each distinct one is ranked and
        # the step evidence (:func:`.prefer.step_evidence`) tells them apart
        distinct = []
        for f in sorted(ok, key=lambda f: f.chi2):
            w = f.model.as_dict(f.theta)[term.step_at]
            if all(abs(math.log(w / f2.model.as_dict(f2.theta)[term.step_at])) > 1e-3 for f2 in distinct):
                distinct.append(f)
        return [(f, _step_fit_evidence(meas, current, f, physics, single)) for f in distinct]
    best = min(ok, key=lambda f: f.chi2)
    return [(best, fit_log_evidence(meas, best) if evidence else None)]


def _step_fit_evidence(meas: Measurement, current: FitResult, fit: FitResult, physics: str,
                       single: bool) -> Evidence:
    """The evidence of a step term's fit, or, for a single term whose step the measured points do not
    show (:func:`.prefer.step_evidence`, the refusal :func:`rank_candidates` gives it whatever its
    evidence), none: method ``"refused"``, the reason as its note (the step's evidence sums a Laplace
    evidence over the intervals between points, the costliest of a round's candidates). A pair's
    step is judged against the round's model, not the pair's first term: its evidence is computed."""
    from .prefer import step_evidence

    why = step_evidence(meas, current, fit, physics) if single else None
    return fit_log_evidence(meas, fit) if why is None else Evidence(float("nan"), "refused", why)


#: NL rungs in a row without a finite evidence after which the eddy-current escalation's ring ladder
#: stops (:func:`fit_candidate`): on koan_tweeter.zma all six rungs NL(2)..NL(7) had none, half the
#: diagnosis's time
NO_EVIDENCE_RUNGS = 2

#: points either side of a step start searched for its discontinuity (:func:`_divided_fits`)
STEP_SHIFT = 3


def _divided_fits(meas: Measurement, current: FitResult, new: Model, starts, step_at: str) -> list[FitResult]:
    """A measurement step's fits that do not inherit the current fit's valley: the current fit has
    absorbed the unexplained step into the device's parameters (an NL(5) ring ladder bends its phase
    to follow a 0.05 rad step), and a polish warm-started from it keeps that bend, so the step no
    longer pays (an NL(5) plant's 25-sigma phase step at 3000 rad/s was lost to the rings). For each
    start the step it proposes (``Y_new(start) / Y_current(start)``: the term multiplies ``Y``) is divided out
    of the data, the current model is fitted afresh to the corrected data (automatic start), and the
    model with the step is polished on the measured data from that fit and the start's step."""
    from .prefer import STEP_CHI2, local_step_fit

    out = []
    cur = current.model.bind(meas.omega)
    full = new.bind(meas.omega)
    shared = [new.names.index(n) for n in current.model.names]
    for s in starts:
        s = np.asarray(s, float)
        # the start's step moved to the strongest local discontinuity within STEP_SHIFT points
        # (the start's median windows place it a point or two off); a start with none there is
        # not refitted: a step without one is refused by the same local test whatever the fit
        # (:func:`.prefer.step_evidence`)
        i = new.names.index(step_at)
        k0 = int(np.searchsorted(meas.omega, s[i]))
        best = None
        for k in range(max(k0 - STEP_SHIFT, 1), min(k0 + STEP_SHIFT + 1, meas.n_points)):
            ws = float(np.sqrt(meas.omega[k - 1] * meas.omega[k]))
            est = local_step_fit(meas, current, ws)
            if est is not None and est[1] >= STEP_CHI2 and (best is None or est[1] > best[1]):
                best = (ws, est[1])
        if best is None:
            continue
        s[i] = best[0]
        with np.errstate(all="ignore"):
            ratio = full.admittance(meas.omega, s) / cur.admittance(meas.omega, s[shared])
        if not np.all(np.isfinite(ratio)) or np.any(ratio == 0):
            continue
        try:
            corrected = Measurement(meas.omega, meas.Y / ratio, meas.weights, dict(meas.meta))
            base = fit_admittance(corrected, current.model)
            init = s.copy()
            init[shared] = base.theta
            out.append(fit_admittance(meas, new, initial=init, warm=True))
        except (FitError, ValueError):
            continue
    return out


class FitCache:
    """Fits of one measurement from the automatic start, ``fits`` ``{model label: FitResult}``
    (:func:`~bayes_emt.estimation.fitting.fit_reusing`), and their evidence, ``evidence``
    ``{model label: (fit, Evidence)}``."""

    def __init__(self):
        self.fits: dict = {}
        self.evidence: dict = {}

    def holds(self, fit: FitResult) -> bool:
        """Whether the evidence of this very fit (model and values) is held."""
        hit = self.evidence.get(fit.model.label)
        return hit is not None and hit[0].model.names == fit.model.names and \
            np.array_equal(hit[0].theta, fit.theta)

    def evidence_of(self, meas: Measurement, fit: FitResult) -> Evidence:
        """:func:`fit_log_evidence` of ``fit``, computed once per fit."""
        if self.holds(fit):
            return self.evidence[fit.model.label][1]
        ev = fit_log_evidence(meas, fit)
        self.evidence[fit.model.label] = (fit, ev)
        return ev

    def new_since(self, other: FitCache) -> FitCache:
        """The entries of this cache ``other`` does not hold."""
        out = FitCache()
        out.fits = {k: v for k, v in self.fits.items() if k not in other.fits}
        out.evidence = {k: v for k, v in self.evidence.items() if k not in other.evidence}
        return out

    def update(self, other: FitCache) -> None:
        for k, v in other.fits.items():
            self.fits.setdefault(k, v)
        for k, v in other.evidence.items():
            self.evidence.setdefault(k, v)

    def copy(self) -> FitCache:
        out = FitCache()
        out.fits, out.evidence = dict(self.fits), dict(self.evidence)
        return out


class CpuClock:
    """CPU seconds of this process plus those its worker processes reported (:func:`fit_jobs`), for a
    time budget that means the same with and without a pool."""

    def __init__(self):
        self.workers = 0.0

    def __call__(self) -> float:
        return time.process_time() + self.workers


def portable(meas: Measurement) -> tuple:
    """``meas`` as arrays and a dict, for a worker process (its metadata mapping does not pickle)."""
    return (np.asarray(meas.omega), np.asarray(meas.Y), meas.weights, dict(meas.meta))


def await_task(task, pool, clock, deadline: float | None):
    """The result of ``task`` (submitted to ``pool``), or ``None`` when ``deadline`` passes first on a
    wall ``clock`` (:class:`bayes_emt._procs.WallClock`): the pool's workers, still running, are then
    stopped. Without a deadline, or on a CPU clock (which does not move while this process waits), it
    waits for the result."""
    try:
        return task.result(None if deadline is None or not getattr(clock, "wall", False)
                           else max(0.0, deadline - clock()))
    except TimeoutError:
        getattr(pool, "stop_workers", lambda: None)()
        return None


def base_task(meas_parts, name: str):
    """One base model fitted from the automatic start in a worker process: ``(fit, evidence, CPU
    seconds)``, ``(None, None, s)`` when it cannot be fitted."""
    t = time.process_time()
    omega, Y, w, meta = meas_parts
    meas = Measurement(omega, Y, w, meta)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fit = fit_admittance(meas, parse_model_spec(name))
        except (FitError, ValueError):
            return None, None, time.process_time() - t
        ev = fit_log_evidence(meas, fit)
    return fit, ev, time.process_time() - t


def _candidate_task(meas_parts, base, physics, band, warm, known, evidence=True):
    """One candidate in a worker process: ``(fits, CPU seconds, new cache entries)``."""
    t = time.process_time()
    omega, Y, w, meta = meas_parts
    cache = None if known is None else known.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_candidate(Measurement(omega, Y, w, meta), base, physics, band, warm=warm, cache=cache,
                            evidence=evidence)
    return res, time.process_time() - t, None if cache is None else cache.new_since(known)


def fit_jobs(meas: Measurement, jobs, band: Band, *, warm: bool = True, cache: dict | None = None,
             pool=None, clock=None, deadline: float | None = None, evidence: bool = True):
    """``(physics, base, fits, seconds)`` of each job ``(physics, base)`` in the order given
    (:func:`fit_candidate`), lazily: a job is not started once ``clock()`` passes ``deadline``
    (``(physics, base, None, 0)`` then, and nothing after it). With ``pool`` (a
    :class:`concurrent.futures.Executor` of processes) the jobs run in parallel, the eddy-current
    escalation (the slowest) submitted first; the order of the results, and so every decision, is
    the same as without it; the workers' CPU time is added to ``clock`` (a :class:`CpuClock`)."""
    clock = clock or time.process_time
    if pool is None:
        for physics, base in jobs:
            if deadline is not None and clock() > deadline:
                yield physics, base, None, 0.0
                return
            t0 = time.perf_counter()
            yield physics, base, fit_candidate(meas, base, physics, band, warm=warm, cache=cache,
                                               evidence=evidence), time.perf_counter() - t0
        return
    if deadline is not None and clock() > deadline and jobs:
        yield jobs[0][0], jobs[0][1], None, 0.0
        return
    parts = portable(meas)
    order = sorted(range(len(jobs)), key=lambda i: jobs[i][0] != EDDY_PHYSICS)
    t0 = time.perf_counter()
    futures = {i: pool.submit(_candidate_task, parts, jobs[i][1], jobs[i][0], band, warm,
                              cache if jobs[i][0] == EDDY_PHYSICS else None, evidence) for i in order}
    for i, (physics, base) in enumerate(jobs):
        if deadline is not None and clock() > deadline:
            for f in futures.values():
                f.cancel()
            yield physics, base, None, 0.0
            return
        got = await_task(futures[i], pool, clock, deadline)  # a candidate still running is abandoned
        if got is None:
            yield physics, base, None, 0.0
            return
        res, cpu, new = got
        if hasattr(clock, "workers"):
            clock.workers += cpu
        if cache is not None and new is not None:
            cache.update(new)
        yield physics, base, res, time.perf_counter() - t0


def rank_candidates(
    meas: Measurement,
    current: FitResult,
    current_log_z: float,
    band: Band,
    sigma_rel: float,
    physics_ids: list[str],
    progress=None,
    deadline: float | None = None,
    joint: bool = True,
    *,
    warm: bool = True,
    cache: FitCache | None = None,
    pool=None,
    clock=None,
    refine: int | None = None,
) -> list[Candidate]:
    """Every candidate of ``physics_ids`` for ``band``, best first (accepted first, then by
    ``Δ log Z``). Patches (:func:`.prefer.is_patch`) are accepted only with determined parameters
    and, for a step, a discontinuity of their own (:func:`.prefer.step_evidence`). With ``joint``,
    when no physical term alone is accepted or a patch leads, pairs of the best physical terms are
    tried together (the second added to the first's fit).

    ``warm``, ``cache``: :func:`fit_candidate`'s; with ``warm`` the ``refine`` (default
    :data:`REFINE_TOP`) single terms leading by ``Δ log Z`` (a step term aside: its fits are ranked
    by frequency) are fitted again the full way (:func:`fit_candidate` ``warm=False``), and the full
    fit replaces the warm one when its χ² is lower: the warm start screens, the leaders get the full
    search. ``pool``: run the candidates of a batch in parallel (:func:`fit_jobs`; the same ranking as
    without); ``clock``: the CPU clock ``deadline`` is on (default :func:`time.process_time`; a
    :class:`CpuClock` counts the pool's workers too)."""
    refine = REFINE_TOP if refine is None else refine
    from .prefer import is_patch, step_evidence

    before = band_chi2(meas, current.model, current.theta, band, sigma_rel)
    scan0 = band_scan(meas, current.model, current.theta, band, sigma_rel)
    n_band = 2 * (band.i_hi - band.i_lo + 1)
    out = []
    batches = [[(p, current) for p in physics_ids]]
    pairs_due, first, stopped = joint, True, False
    ctx = (current_log_z, before, scan0, n_band, progress, is_patch, step_evidence)
    while batches:
        for physics, _base, res, dt in fit_jobs(meas, batches.pop(0), band, warm=warm, cache=cache,
                                                pool=pool, clock=clock, deadline=deadline):
            if res is None:
                if progress:
                    progress(f"time budget reached: {physics} and later candidates not tried")
                pairs_due, stopped = False, True
                break
            out.extend(_candidates(meas, current, band, sigma_rel, physics, res, dt, *ctx))
        if first and warm and refine and not stopped:
            _refine(meas, current, band, sigma_rel, out, refine, ctx, pool, clock, deadline)
        first = False
        if pairs_due:
            pairs_due = False
            pairs = _joint_jobs(out, current)
            if pairs:
                if progress:
                    progress("  trying physical terms jointly: " + ", ".join(p for p, _ in pairs))
                batches.append(pairs)
    # the eddy-current escalation: keep only its best rung (the ring count by evidence), and its best
    # physical rung (the first) beside a better patch rung
    eddy = [c for c in out if c.physics == EDDY_PHYSICS]
    best_eddy = max(eddy, key=lambda c: c.log_z, default=None)
    best_phys = max((c for c in eddy if not c.patch), key=lambda c: c.log_z, default=None)
    out = [c for c in out if c.physics != EDDY_PHYSICS or c is best_eddy or c is best_phys]
    out.sort(key=lambda c: (not c.accepted, -c.delta_log_z if math.isfinite(c.delta_log_z) else math.inf))
    return out


#: warm-started single terms, the best by Δ log Z, fitted again the full way (:func:`rank_candidates`)
REFINE_TOP = 2


def _refine(meas, current, band, sigma_rel, out, n, ctx, pool, clock, deadline) -> None:
    """Fit the ``n`` leading warm-started single terms of ``out`` the full way; a full fit of lower χ²
    replaces its warm candidate in ``out`` (:func:`rank_candidates`)."""
    best: dict = {}
    for c in out:
        if c.physics == EDDY_PHYSICS or "+" in c.physics or not math.isfinite(c.delta_log_z) \
                or make_term(c.physics).step_at:
            continue
        if c.physics not in best or c.delta_log_z > best[c.physics].delta_log_z:
            best[c.physics] = c
    top = sorted(best.values(), key=lambda c: -c.delta_log_z)[:n]
    progress = ctx[4]
    if top and progress:
        progress("  the leaders fitted the full way: " + ", ".join(c.physics for c in top))
    # the full fits without their evidence: only one that beats its warm fit needs it (a full fit of
    # no lower chi2 is dropped whatever its log Z), so that is computed for it alone
    for physics, _base, res, dt in fit_jobs(meas, [(c.physics, current) for c in top], band, warm=False,
                                            pool=pool, clock=clock, deadline=deadline, evidence=False):
        if res is None:
            break
        old = best[physics]
        better = [(f, ev) for f, ev in res if f.chi2 < old.fit.chi2 * (1 - 1e-9)]
        if not better:
            if progress and res:
                progress(f"  {physics}: the full fit is no better (chi2 {min(f.chi2 for f, _ in res):.6g} "
                         f"against {old.fit.chi2:.6g}; {dt:.0f} s): the warm one stays")
            continue
        res = [(f, fit_log_evidence(meas, f)) for f, _ev in better]
        new = _candidates(meas, current, band, sigma_rel, physics, res, dt, *ctx)
        if new:
            if progress:
                progress(f"  {physics}: the full fit is better (chi2 {old.fit.chi2:.6g} -> "
                         f"{new[0].fit.chi2:.6g}, log Z {old.log_z:.1f} -> {new[0].log_z:.1f}): it replaces "
                         "the warm one")
            out[next(i for i, c in enumerate(out) if c is old)] = new[0]


def _candidates(meas, current, band, sigma_rel, physics, res, dt, current_log_z, before, scan0, n_band,
                progress, is_patch, step_evidence) -> list[Candidate]:
    """The :class:`Candidate` of each ``(fit, evidence)`` of ``physics`` (:func:`rank_candidates`)."""
    out = []
    for fit, ev in res:
        lz = ev.log_z
        if progress:
            how = "" if not ev.fallback else f" [{ev.method}: {ev.note}]"
            progress(f"  {physics}: {fit.model.label} log Z {lz:.1f}{how} ({dt:.0f} s)")
        if not math.isfinite(lz) and ev.method != "refused":  # a refused step stays, for the record
            continue
        after = band_chi2(meas, fit.model, fit.theta, band, sigma_rel)
        new_names = [n for n in fit.model.names if n not in current.model.names]
        ident, why, added = _identifiable(fit, new_names, physics, ev, meas)
        values = fit.model.as_dict(fit.theta)
        ids = physics.split("+")
        bad = next(
            (
                w
                for t in fit.model.augmentations
                if t.id in ids and (w := t.implausible(values)) is not None
            ),
            None,
        )
        bad = bad or _at_prior_bound(fit, new_names)
        if physics != EDDY_PHYSICS:  # a coil model's escalation re-fits R0 with the coil
            # a structure beyond one driver gives each driver its own R0 (a pair's is about half each's)
            split = any(t.structural for t in fit.model.augmentations if t.id in ids)
            bad = bad or (None if split else _takes_r0(current, fit, meas)) or _moves_fs(current, fit, ids)
        patch = is_patch(physics, fit)
        problem = None
        if patch:
            problem = (None if ident else f"a patch with undetermined parameters ({why})")
            # a step refused before its evidence (:func:`_step_fit_evidence`) carries that test's reason
            refused = ev.note if ev.method == "refused" else None
            problem = problem or refused or step_evidence(meas, current, fit, physics)
        out.append(
            Candidate(
                physics,
                fit,
                lz,
                lz - current_log_z,
                before,
                after,
                ident,
                why,
                n_band,
                scan0,
                band_scan(meas, fit.model, fit.theta, band, sigma_rel),
                added,
                bad,
                ev.method,
                ev.note,
                patch,
                problem,
            )
        )
    return out


#: physical terms (the best by Δ log Z) paired in the joint step
JOINT_TOP = 3


def _joint_jobs(out: list[Candidate], current: FitResult) -> list[tuple[str, FitResult]]:
    """Pairs ``"a+b"`` of the best :data:`JOINT_TOP` physical single terms, each job the second term
    to add to the first's fit, when no physical single is accepted or a patch leads."""
    singles = [c for c in out if "+" not in c.physics and c.physics != EDDY_PHYSICS]
    phys = sorted((c for c in singles if not c.patch and c.implausible is None
                   and math.isfinite(c.delta_log_z) and c.delta_log_z > 0),
                  key=lambda c: -c.delta_log_z)[:JOINT_TOP]
    if not out:
        return []
    leader = max(out, key=lambda c: c.delta_log_z if math.isfinite(c.delta_log_z) else -math.inf)
    if len(phys) < 2:
        return _masked_jobs(singles, phys, leader)
    if any(c.accepted and not c.patch for c in out) and not leader.patch:
        return []
    jobs = []
    for i, a in enumerate(phys):
        for b in phys[i + 1:]:
            jobs.append((f"{a.physics}+{b.physics}", a.fit))
    jobs += _masked_jobs(singles, phys, leader)
    return jobs


def _masked_jobs(singles: list[Candidate], phys: list[Candidate], leader: Candidate) -> list:
    """When a patch leads (:mod:`.prefer`, "masked second effects"): the best physical term paired
    with the other physical candidates however little they gain alone (the best
    :data:`JOINT_TOP` of them by Δ log Z), and the leading patch with the same partners (the same
    footing)."""
    if not (leader.patch and phys) or "+" in leader.physics:
        return []
    others = sorted((c for c in singles if not c.patch and c.implausible is None
                     and math.isfinite(c.delta_log_z) and c not in phys),
                    key=lambda c: -c.delta_log_z)[:JOINT_TOP]
    return [(f"{a.physics}+{b.physics}", a.fit) for a in (phys[0], leader) for b in others]


#: an added parameter within this fraction of its prior's range (sampling space) from a bound sits
#: at the bound
AT_BOUND = 1e-3


def _at_prior_bound(fit: FitResult, new_names: list[str]) -> str | None:
    """Why the fit is not this physics when an added parameter sits at its prior's bound (the data
    push it past what the physics allows: the term absorbs another misfit); ``None`` otherwise."""
    z = fit.model.params.to_z(np.asarray(fit.theta, float))
    lo, hi = fit.model.params.bounds_z()
    out = []
    for n in new_names:
        i = fit.model.names.index(n)
        if not (math.isfinite(lo[i]) and math.isfinite(hi[i])):
            continue
        tol = AT_BOUND * (hi[i] - lo[i])
        if z[i] - lo[i] < tol or hi[i] - z[i] < tol:
            out.append(f"{n} = {fit.theta[i]:.4g}")
    if not out:
        return None
    return (f"{', '.join(out)} at the bound of its prior: the data push the term past what its "
            "physics allows (it absorbs another misfit)")


#: a candidate taking R0 below this fraction of its value before (or above its inverse) is not
#: accepted: the term takes over the DC resistance (a semi-inductance with n -> 0 is a resistor; on
#: the LS10-44 run2 recording it took R0 to 0.01 % of itself). True terms added to a base that
#: cannot fit them move R0 by up to -34 % in the concealed-effect benchmark (a vented box from model
#: I), so the limit is a factor 2, not the 5 % the final-model warning uses
R0_FACTOR_MAX = 0.5


def _takes_r0(current: FitResult, fit: FitResult, meas: Measurement | None = None) -> str | None:
    a, b = current.parameters.get("R0"), fit.parameters.get("R0")
    if not a or a <= 0 or b is None or R0_FACTOR_MAX <= b / a <= 1 / R0_FACTOR_MAX:
        return None
    if meas is not None and b > 0:
        # a current fit that missed the DC resistance (a lumped driver fitted to two drivers in
        # parallel put R0 at 3.6 ohm where the data's real part falls to 1.75 ohm): a term that
        # brings R0 closer to the data's resistance floor min Re Z restores it, it does not take it
        floor = float(np.min(meas.Z.real))
        if floor > 0 and abs(math.log(b / floor)) < abs(math.log(a / floor)) and b <= 1.05 * floor:
            return None
    return (f"it moves R0 by {100 * (b - a) / a:+.1f} % ({a:.4g} -> {b:.4g} ohm), beyond a factor "
            f"{1 / R0_FACTOR_MAX:g}: the term takes over the DC resistance instead of explaining the band")


#: a candidate moving the resonance ω0 by more than this factor is not accepted unless one of its
#: terms declares ``moves_resonance`` (a vented box: -42 % in the benchmark); every other true term
#: in the concealed-effect benchmark moves fs by under 1 %, the truth study's pair by 1.1 %, while on
#: the real tweeter a broad second mode took fs from 941 to 1303 Hz (the data's peak is near 924 Hz)
FS_FACTOR_MAX = 1.2


def _moves_fs(current: FitResult, fit: FitResult, ids: list[str]) -> str | None:
    if any(t.moves_resonance for t in fit.model.augmentations if t.id in ids):
        return None
    a, b = current.parameters.get("omega0"), fit.parameters.get("omega0")
    if not a or a <= 0 or b is None or 1 / FS_FACTOR_MAX <= b / a <= FS_FACTOR_MAX:
        return None
    return (f"it moves the resonance fs by {100 * (b - a) / a:+.1f} % ({a / (2 * math.pi):.4g} -> "
            f"{b / (2 * math.pi):.4g} Hz): the term re-assigns the driver's resonance instead of explaining "
            "the band")
