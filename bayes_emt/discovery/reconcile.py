"""One answer whatever the start: the search's final model against the other coil families.

The search (:func:`.diagnose.diagnose`) climbs from its starting model: each round adds the term the
evidence prefers *given the model it stands on*. Two starts of the same recording then reach
different final models (a UD start escalates to NL(4) and names a winding capacitance; an NL(5)
start, whose five rings already bend to follow what UD leaves, names a creep instead), and which
one the user gets is an accident of the path. Two steps make the answer a comparison instead:

* **A healthy start** (:func:`healthy_start`). A starting fit that is broken physics
  (:func:`.sanity.defects`: a parameter at its prior's edge, merged resonances, Qms or Qes outside
  physical ranges; an NL ring ladder that took over the DC resistance, R0 ≈ 0) is no place to search
  from: the nearest healthy coil model (down the ring ladder NL(n−1), …, NL(2), then UD, III, II, I,
  the start's own terms kept) replaces it, and one line says so.
* **The final comparison** (:func:`final_comparison`). The search's final model ``B + T`` (coil
  model ``B``, found terms ``T``) is compared, by the same Laplace evidence on the same points, with
  the found terms on every coil family a search may start from, :data:`FAMILIES` (``B' + T``,
  polished from the final fit's values with ``B'``'s own coil values); then each found term is
  dropped in turn from the leader while the evidence does not fall (backward elimination: a term
  that earned its place on one coil model may be absorbed on another). Among the healthy candidates
  (no defect, every parameter checked for its prior's edge; a candidate with a defect is never kept,
  so its evidence is not computed) the best log Z wins;
  candidates within :data:`TIE_NATS` of it are a tie the data
  cannot resolve (Kass & Raftery 1995: a Bayes factor below e² ≈ 7 is "positive" at most), and the
  simplest of them (fewest parameters, then best log Z) is kept, the others named with their
  log Z. The decision therefore depends on the set of models compared, not on the order in which
  the search met them.
"""

from __future__ import annotations

import math
import time
import warnings

from ..errors import FitError
from ..estimation.fitting import fit_admittance, fit_reusing
from ..estimation.results import FitResult
from ..evidence.fit_evidence import fit_log_evidence
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, Model, parse_model_spec
from .name import await_task, portable
from .sanity import defects

__all__ = ["FAMILIES", "TIE_NATS", "healthy_start", "final_comparison", "start_ladder", "kept_findings"]

#: the coil families a search may start from (and the ring counts of NL the escalation reaches)
FAMILIES: tuple[str, ...] = ("UD", "III", "NL(2)", "NL(3)", "NL(4)", "NL(5)")
#: nats within which two final models are a tie (module docstring)
TIE_NATS = 2.0


def _extra(model: Model) -> str:
    return "".join("+" + t.id for t in model.augmentations)


def _base_label(model: Model) -> str:
    return model.base_model().label


def _added(model: Model, base: Model) -> list[str]:
    return [n for n in model.names if n not in base.names]


def start_ladder(model: Model) -> list[str]:
    """Coil models nearest to ``model``'s first (its terms appended): down the NL ring ladder, then
    UD, III, II, I (module docstring)."""
    base = _base_label(model)
    out = []
    if model.rings is not None:  # the ring ladder
        out += [f"NL({n})" for n in range(model.rings - 1, 1, -1)]
    out += [b for b in ("UD", "III", "II", "I") if b != base]
    return [b + _extra(model) for b in out]


def healthy_start(meas: Measurement, fit: FitResult, cache=None) -> tuple[FitResult, str | None]:
    """``(fit, None)`` when the starting ``fit`` has no defect (:func:`.sanity.defects`), else the
    fit of the nearest healthy start (:func:`start_ladder`) and the line saying what was replaced and
    why (the broken fit itself when no coil model is healthy, with that line)."""
    base = fit.model.base_model()
    bad = defects(fit, _added(fit.model, base))
    if not bad:
        return fit, None
    reuse = None if cache is None else cache.fits
    for spec in start_ladder(fit.model):
        try:
            m = parse_model_spec(spec)
            f = fit_reusing(meas, m, reuse)
        except (FitError, ValueError):
            continue
        if not defects(f, _added(m, m.base_model())):
            return f, (f"the start {fit.model.label} is broken physics ({'; '.join(bad)}): the search "
                       f"starts from {m.label}, the nearest healthy start")
    return fit, (f"the start {fit.model.label} is broken physics ({'; '.join(bad)}) and no nearer coil "
                 "model is healthy: the search starts from it")


def _polish(meas: Measurement, model: Model, final: FitResult, reuse) -> FitResult | None:
    """``model`` (a coil family with the final model's terms) fitted from two starts: its coil
    family's own fit with the final model's values for the shared names, and the same with the
    family's values for the plant too; the better by χ²."""
    vals = final.model.as_dict(final.theta)
    try:
        own = fit_reusing(meas, model.base_model(), reuse)
    except (FitError, ValueError):
        return None
    ov = own.model.as_dict(own.theta)
    fits = []
    for prefer_final in (True, False):
        init = {}
        for n in model.names:
            if prefer_final and n in vals:
                init[n] = vals[n]
            elif n in ov:
                init[n] = ov[n]
            elif n in vals:
                init[n] = vals[n]
        if len(init) != model.ndim:
            continue
        try:
            fits.append(fit_admittance(meas, model, initial=init, warm=True))
        except (FitError, ValueError):
            continue
    return min(fits, key=lambda f: f.chi2) if fits else None


def _without(meas: Measurement, fit: FitResult, term) -> FitResult | None:
    m = fit.model.without(term)
    vals = fit.model.as_dict(fit.theta)
    try:
        return fit_admittance(meas, m, initial={n: vals[n] for n in m.names}, warm=True)
    except (FitError, ValueError):
        return None


def _term(fit: FitResult, term_id: str):
    """The term of ``fit``'s model with id ``term_id``."""
    return next(t for t in fit.model.augmentations if t.id == term_id)


def _make(meas: Measurement, job: tuple, reuse) -> FitResult | None:
    """The fit a final-comparison job names: ``("given", fit)``, ``("polish", label, final)`` (the
    final's terms on another coil family, :func:`_polish`), ``("fit", label)`` (a bare coil family from
    the automatic start) or ``("without", fit, term id)`` (a found term dropped)."""
    kind = job[0]
    if kind == "given":
        return job[1]
    if kind == "polish":
        return _polish(meas, parse_model_spec(job[1]), job[2], reuse)
    if kind == "fit":
        return _safe_fit(meas, parse_model_spec(job[1]), reuse)
    return _without(meas, job[1], _term(job[1], job[2]))


def _job_label(job: tuple) -> str:
    if job[0] == "given":
        return job[1].model.label
    if job[0] == "without":
        return job[1].model.without(_term(job[1], job[2])).label
    return job[1]


def _compare_task(meas_parts, job, reuse):
    """One final-comparison job in a worker process: ``(fit, Evidence, CPU seconds, new fits)``."""
    t = time.process_time()
    meas = Measurement(*meas_parts)
    known = set(reuse or ())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = _make(meas, job, reuse)
        # a candidate with a defect is never kept: its evidence is not needed (a final's always is)
        ev = None if fit is None or (job[0] != "given" and defects(fit, fit.model.names)) else \
            fit_log_evidence(meas, fit)
    new = None if reuse is None else {k: v for k, v in reuse.items() if k not in known}
    return fit, ev, time.process_time() - t, new


def _run_jobs(meas, jobs, cache, pool, clock, deadline):
    """``(fit, Evidence or None)`` of each job of ``jobs`` in their order (``fit`` ``None`` for one
    that failed), lazily, until ``deadline`` (on ``clock``) passes: the jobs left are not run. With
    ``pool`` (and ``cache``) they run in parallel, each with its evidence (``None`` for a candidate
    with a defect), those still running at the deadline abandoned; without one, a job is started
    only before the deadline (its evidence is the caller's to compute)."""
    reuse = None if cache is None else cache.fits
    if pool is None or cache is None:
        for job in jobs:
            if deadline is not None and clock() > deadline:
                return
            yield _make(meas, job, reuse), None
        return
    parts = portable(meas)
    futures = [None if job[0] == "given" and cache.holds(job[1]) else
               pool.submit(_compare_task, parts, job, reuse) for job in jobs]
    try:
        for job, fut in zip(jobs, futures, strict=True):
            if deadline is not None and clock() > deadline:
                return
            if fut is None:
                yield job[1], None
                continue
            got = await_task(fut, pool, clock, deadline)  # a job still running is abandoned
            if got is None:
                return
            fit, ev, cpu, new = got
            if hasattr(clock, "workers"):
                clock.workers += cpu
            for k, v in (new or {}).items():
                reuse.setdefault(k, v)
            yield fit, ev
    finally:
        for fut in futures:
            if fut is not None:
                fut.cancel()


def final_comparison(meas: Measurement, finals, evidence, *, cache=None, families=FAMILIES,
                     say=lambda msg: None, pool=None, clock=None, deadline: float | None = None) -> dict:
    """The final comparison of the module docstring over the final fits ``finals`` the searches reached
    (the given start's first). ``evidence(fit) -> log Z`` [nats] (the search's own, recomputed for the
    finals too: a search's log Z may be a stand-in, the maximum likelihood when its Laplace evidence
    failed, which no evidence can be compared with). Returns ``{"fit", "log_z", "origin": index of
    the final whose terms the kept fit holds, "compared": [{"model", "log_z", "defects"}], "tie":
    [labels within TIE_NATS of the kept one], "line": one line when the answer is not the first
    final or a tie remains, else "", "cut": [models not compared]}``; the first final is kept when no
    candidate is healthy.

    ``pool`` (with ``cache``, a :class:`.name.FitCache` that ``evidence`` reads): the candidates of
    each step fitted, with their evidence, in parallel (the same decisions: they are added in the
    same order); ``deadline`` on ``clock``: the candidates not done by then are left out and named in
    ``"cut"`` (the pool's running ones abandoned)."""
    clock = clock or time.monotonic
    seen: dict[str, tuple] = {}
    cut: list[str] = []

    def add(fit, origin, given=False):
        if fit is None:
            return
        # every parameter, the coil family's own too (an NL ring pressed to zero, Pg = 1e-16 on
        # grs_12SW-4HE, is a broken fit as much as a term's); a candidate with a defect is never kept,
        # so its evidence, often the costliest (it fails at the prior's edge and falls back), is not
        # computed: the decisions are the same (a healthy route of a model beats a broken one whatever
        # their log Z); a final's evidence always is (the line names the first final's)
        bad = defects(fit, fit.model.names)
        lz = evidence(fit) if given or not bad else math.nan
        had = seen.get(fit.model.label)
        # a model reached by two routes (two finals with the same terms, polished from each): the
        # route the comparison itself prefers stands for it (healthy, then the larger log Z, then the
        # lower chi2), whichever came first, so the answer does not depend on the order of the finals
        if had is not None and not _better((fit, lz, bad), had[:3]):
            return
        seen[fit.model.label] = (fit, lz, bad, origin)
        say(f"final comparison: {fit.model.label} " + (f"log Z {lz:.1f}" if given or not bad else
                                                         "evidence not computed")
            + (f" ({'; '.join(bad)})" if bad else ""))

    def run(jobs):
        """``add`` each job's fit in order, as it comes; whether every job was done."""
        n = 0
        results = _run_jobs(meas, [j for j, _ in jobs], cache, pool, clock, deadline)
        for (fit, ev), (job, origin) in zip(results, jobs, strict=False):
            if ev is not None:  # computed by a worker: what ``evidence`` reads
                cache.evidence[fit.model.label] = (fit, ev)
            add(fit, origin, job[0] == "given")
            n += 1
        cut.extend(_job_label(j) for j, _ in jobs[n:])
        return n == len(jobs)

    jobs, planned = [], set()
    for i, final in enumerate(finals):
        jobs.append((("given", final), i))
        planned.add(final.model.label)
    for i, final in enumerate(finals):
        extra = _extra(final.model)
        for fam in families:
            try:
                m = parse_model_spec(fam + extra)
            except ValueError:
                continue
            if m.label == final.model.label or (not extra and m.label in planned):
                continue  # the final itself; a bare coil family is the same fit from any final
            planned.add(m.label)
            jobs.append(((("polish", m.label, final) if extra else ("fit", m.label)), i))
    done = run(jobs)

    def healthy():
        return [(f, lz, o) for f, lz, bad, o in seen.values() if not bad and math.isfinite(lz)]

    # backward elimination from the leader: drop a found term while the evidence does not fall
    while done:
        ok = healthy()
        if not ok:
            break
        lead, lead_lz, lead_o = max(ok, key=lambda x: x[1])
        drop = [t for t in lead.model.augmentations if lead.model.without(t).label not in seen]
        done = run([(("without", lead, t.id), lead_o) for t in drop])
        if not any(m.label in seen and seen[m.label][1] >= lead_lz and not seen[m.label][2]
                   for m in (lead.model.without(t) for t in drop)):
            break
    compared = [{"model": k, "log_z": v[1], "defects": v[2]} for k, v in seen.items()]
    first = finals[0]
    ok = healthy()
    if not ok:
        return {"fit": first, "log_z": seen.get(first.model.label, (None, math.nan))[1], "origin": 0,
                "compared": compared, "tie": [], "line": "", "cut": cut}
    best_lz = max(lz for _, lz, _ in ok)
    near = [x for x in ok if best_lz - x[1] <= TIE_NATS]
    keep, keep_lz, origin = min(near, key=lambda x: (x[0].model.ndim, -x[1]))
    tie = [f.model.label for f, _, _ in near if f is not keep]
    line = ""
    if keep.model.label != first.model.label:
        _, first_lz, first_bad, _ = seen.get(first.model.label, (None, None, [], None))
        why = ("its evidence not computed within the time budget" if first_lz is None else
               f"log Z {first_lz:.1f}" if math.isfinite(first_lz) else "its evidence could not be computed")
        if first_bad:
            why += "; " + "; ".join(first_bad)
        line = (f"final comparison: {keep.model.label} (log Z {keep_lz:.1f}) is kept over "
                f"{first.model.label} ({why}), by one evidence on the same data over every start's final "
                "model, its found terms on each coil family, terms dropped while the evidence did not fall")
    if tie:
        line = (line + "; " if line else "final comparison: ") + (
            "the data cannot tell " + ", ".join(
                f"{lab} (log Z {seen[lab][1]:.1f})" for lab in [keep.model.label, *tie])
            + f" apart (within {TIE_NATS:g} nats): the simplest, {keep.model.label}, is kept")
    return {"fit": keep, "log_z": keep_lz, "origin": origin, "compared": compared, "tie": tie, "line": line,
            "cut": cut}


#: two routes' log Z closer than this [nats] are the same evidence (the lower chi2 then decides)
SAME_LOG_Z = 1e-6


def _better(a, b) -> bool:
    """Whether route ``a`` ``(fit, log Z, defects)`` of a model beats route ``b`` of the same model."""
    ok_a, ok_b = not a[2] and math.isfinite(a[1]), not b[2] and math.isfinite(b[1])
    if ok_a != ok_b:
        return ok_a
    if math.isfinite(a[1]) and math.isfinite(b[1]) and abs(a[1] - b[1]) > SAME_LOG_Z:
        return a[1] > b[1]
    if math.isfinite(a[1]) != math.isfinite(b[1]):
        return math.isfinite(a[1])
    return a[0].chi2 < b[0].chi2


def _safe_fit(meas, model, reuse):
    try:
        return fit_reusing(meas, model, reuse)
    except (FitError, ValueError):
        return None


def kept_findings(findings, fit: FitResult) -> list:
    """The findings whose terms ``fit``'s model holds (an eddy-current finding while its coil model is
    ``fit``'s)."""
    ids = {t.id for t in fit.model.augmentations}
    base = _base_label(fit.model)
    out = []
    for f in findings:
        parts = f.physics.split("+")
        ok = True
        for p in parts:
            if p == EDDY_PHYSICS:
                spec = f.model_spec.split("+")[0] if f.model_spec else ""
                ok &= spec == base
            else:
                ok &= p in ids
        if ok:
            out.append(f)
    return out

