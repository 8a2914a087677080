"""Joint evidence: the physics a diagnosis names must explain a second recording too.

A diagnosis of recording A names terms; a second recording B of the same transducer (a known added
mass ``Δm`` [kg], or the same driver at another drive level or session: ``Δm`` ``None``) must need
them as well: the coil and the suspension do not change with a mass on the cone (an instrument step
of one session is what B should not need, and is then flagged). :func:`check_with` fits B with A's
final model and, for each finding, with that finding taken out (a term removed; for the eddy-current
escalation, the coil model it replaced), from A's final values (``ω0`` moved to B's resonance), and
judges each finding by **one log evidence of both recordings together**
(:mod:`.joint_evidence`): the finding shared by both (one set of values), in neither, or in A
alone, each recording with its own mechanics ``ζ, ω0, φ̄`` (and its own ``R0`` when that raises
the final model's joint evidence: the coil's temperature changes between sessions) and everything
else shared;
``Δ log Z_joint = log Z(shared) − max(log Z(neither), log Z(A only))`` below
:data:`MIN_DELTA_LOG_Z` (the acceptance threshold of :mod:`.name`) is a finding the pair does not
share: it is **flagged** (a warning). The record says ``"method": "laplace-joint"``. B's own gain
``Δ log Z_B`` (its Laplace evidence with and without the finding) is kept beside as a diagnostic.
With ``Δm`` the joint added-mass fit (:func:`bayes_emt.added_mass.fit_added_mass`: one ``m, c, k,
φ`` and one coil shared by both runs) is run with A's baseline and final models; the record gives
``m``, ``Bl``, ``k``, ``R0`` and the pair's consistency F-test for each: a diagnostic printed
beside the verdicts, not one of them.

**The same values** (:func:`value_disagreements`): B needing a term is not B needing it *for the
same thing*. Each finding's own parameters (those its removal takes out) from A's final fit and
from B's fit with A's final model must agree: a parameter disagrees when its two values differ by
more than three combined standard errors *and* by more than a factor :data:`VALUE_FACTOR` (or
the mass ratio ``(m + Δm)/m = (ω0_A/ω0_B)²`` when that is larger: the most a mass-dependent value
may move). Such a finding, when B alone needs it (``Δ log Z_B ≥`` :data:`MIN_DELTA_LOG_Z`), is
**flagged** whatever its joint evidence: the two recordings do not use the term for the same
thing (B uses it for another feature, or its values trade against the other terms). On the
LS10-44 run2 pair the free-air run's second resonance sits at 148.6 rad/s (23.6 Hz); the added-mass
run, refitted with the same model, puts it at 4925 rad/s (784 Hz), 33 times higher, while its
``Δ log Z_B`` of +3285 nats said B needs it, and the joint evidence prefers one shared mode to none
(+2112 nats: one set of values between the two features fits the pair better than no mode).

**The other way round** (:func:`search_other`, ``search``): B is diagnosed too, from A's starting
model with A's settings, and each term B's diagnosis names that A's findings do not is added to A's
final model and fitted on A (the same warm starts the search uses, in the band B found it). Its gain
``Δ log Z_A`` decides: below :data:`MIN_DELTA_LOG_Z` it is a term only B needs (**flagged**, as the
terms only A needs are); at or above it A gains from it too, and A's diagnosis did not name it (its
search chose other terms): a warning says so, since then A's findings are not the whole story. On
the LS10-44 run2 pair (10 Hz-1 kHz) the added-mass run names suspension creep, which the free-air
run gains 69 nats from but its own search did not name; over 1 Hz-1 kHz it names a broad second
mode that the free-air run gains 0.4 nats from (flagged). Named terms are compared by their physics
ids (a joint ``"a+b"`` finding counts as both; the eddy-current escalation as ``eddy_current``
whatever its ring count).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..added_mass import fit_added_mass
from ..errors import FitError
from ..estimation.checks import locate_resonance
from ..estimation.fitting import fit_admittance
from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, Model, parse_model_spec
from .diagnose import _fmt, diagnose
from .joint_evidence import JOINT_METHOD, PER_RUN, finding_joint_evidence, pair_log_evidence
from .locate import Band
from .name import MIN_DELTA_LOG_Z, fit_candidate, log_evidence

__all__ = ["check_with", "with_second_recordings", "model_without", "search_other", "named_ids",
           "value_disagreements", "VALUE_FACTOR"]

#: the factor by which a term's value on the two recordings may differ before it counts as another
#: feature (with three combined standard errors; :func:`value_disagreements`)
VALUE_FACTOR = 2.0
#: combined standard errors a disagreement must exceed
VALUE_SE = 3.0


def model_without(diag, i: int) -> Model:
    """The final model of ``diag`` with its finding ``i`` taken out: its terms removed, or for the
    eddy-current escalation the coil model before it (the previous finding's, or the baseline's)."""
    final = diag.final_fit.model
    f = diag.findings[i]
    ids = f.physics.split("+")
    m = final
    for t in final.augmentations:
        if t.id in ids:
            m = m.without(t)
    if EDDY_PHYSICS in ids:
        before = diag.findings[i - 1].model_spec if i > 0 else diag.baseline_fit.model.label
        coil = before.split("+")[0]
        m = parse_model_spec("+".join([coil, *[t.id for t in m.augmentations]]))
    return m


def value_disagreements(fit_a: FitResult, fit_b: FitResult, names,
                        factor: float = VALUE_FACTOR) -> list[dict] | None:
    """The parameters of ``names`` whose values in ``fit_a`` and ``fit_b`` (the same model) disagree
    (module docstring): more than :data:`VALUE_SE` combined standard errors apart in sampling space,
    and more than a factor ``factor`` apart for a log-uniform parameter (any other: more than
    ``factor − 1`` times the larger magnitude). Each ``{"name", "unit", "first", "other"}`` [SI];
    ``None`` when either fit has no covariance (nothing can be judged); a parameter whose standard
    error is not finite is not judged."""
    out = []
    za, zb = fit_a.z, fit_b.z
    sa = np.sqrt(np.clip(np.diag(fit_a.cov_z), 0, None)) if fit_a.cov_z is not None else None
    sb = np.sqrt(np.clip(np.diag(fit_b.cov_z), 0, None)) if fit_b.cov_z is not None else None
    if sa is None or sb is None:
        return None
    va, vb = fit_a.parameters, fit_b.parameters
    for n in names:
        i = fit_a.model.names.index(n)
        spec = fit_a.model.params[n]
        se = math.hypot(float(sa[i]), float(sb[i]))
        dz = abs(float(zb[i] - za[i]))
        if not (math.isfinite(se) and math.isfinite(dz)) or dz <= VALUE_SE * se:
            continue
        a, b = va[n], vb[n]
        if spec.transform == "log":
            far = dz > math.log(factor)
        else:
            far = abs(b - a) > (factor - 1.0) * max(abs(a), abs(b))
        if far:
            out.append({"name": n, "unit": spec.unit, "first": a, "other": b})
    return out


def _fit(meas: Measurement, model: Model, start: dict) -> FitResult:
    """The better (by χ²) of ``model``'s fits from ``start`` (when it names every parameter) and from
    the automatic initial estimate: a start carried over from the other recording may sit in
    another basin."""
    init = {k: v for k, v in start.items() if k in model.names}
    fits = []
    for kw in ([{"initial": init}] if len(init) == len(model.names) else []) + [{}]:
        try:
            fits.append(fit_admittance(meas, model, **kw))
        except (FitError, ValueError):
            continue
    if not fits:
        raise FitError(f"{meas.source}: {model.label} could not be fitted")
    return min(fits, key=lambda f: f.chi2)


def _final_on(meas: Measurement, diag) -> FitResult:
    """``diag``'s final fit on all of ``meas`` (polished there when the search saw fewer points)."""
    fit = diag.final_fit
    if meas.n_points != fit.n_points:
        fit = fit_admittance(meas, fit.model, initial=fit.theta, warm=True)
    return fit


def check_with(diag, other: Measurement, delta_m: float | None = None, *, meas: Measurement | None = None
               ) -> dict:
    """The joint-evidence record of ``diag`` (of ``meas``, the first recording) against ``other``
    (module docstring): ``{"source", "delta_m_kg", "final_model", "method": "laplace-joint",
    "per_run" (each recording's own parameters: the mechanics, and R0 when that raises the final
    model's joint log Z), "log_z_joint_other_r0" [nats], "log_z_final" [nats, the other recording
    alone], "log_z_joint" [nats, both under the final model], "terms": [{"physics",
    "delta_log_z_joint" [nats], "log_z_joint": {"shared", "neither", "first_only"},
    "needed_by_other" (the joint verdict), "delta_log_evidence_other"
    [nats, the other recording alone, a diagnostic], "model_without", "values_agree",
    "values_apart", "verdict", "note"}], "flagged": [physics], "added_mass": {...} (with
    ``delta_m``: the joint added-mass fits and their F-test, a diagnostic)}``."""
    if meas is None:
        raise ValueError("the joint evidence needs the first recording too (meas=)")
    if delta_m is not None and not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"--also {other.source}: the added mass must be a non-zero number of kg, "
                         f"got {delta_m!r}")
    final = diag.final_fit.model
    start = final.as_dict(diag.final_fit.theta)
    res = locate_resonance(other)
    if res is not None and "omega0" in start:
        start["omega0"] = float(res.omega)
    fb = _fit(other, final, start)
    fa = _final_on(meas, diag)
    lz = log_evidence(other, fb)
    # each recording's own R0 too when the pair's evidence prefers it (the coil's temperature, the
    # leads and contacts change between sessions)
    per_run, lz_joint = PER_RUN, pair_log_evidence(meas, other, fa, fb)
    lz_r0 = (pair_log_evidence(meas, other, fa, fb, (*PER_RUN, "R0")) if "R0" in final.names
             else (math.nan, ""))
    if math.isfinite(lz_r0[0]) and not lz_joint[0] >= lz_r0[0]:
        per_run, lz_joint, lz_r0 = (*PER_RUN, "R0"), lz_r0, lz_joint
    start_b = fb.model.as_dict(fb.theta)
    start_a = fa.model.as_dict(fa.theta)
    w_a, w_b = fa.parameters.get("omega0"), start_b.get("omega0")
    factor = VALUE_FACTOR
    if delta_m is not None and w_a and w_b and w_a > 0 and w_b > 0:
        # the mass ratio (m + Δm)/m (or its inverse for a mass taken off): the most a mass-dependent
        # value may move
        factor = max(factor, (w_a / w_b) ** 2, (w_b / w_a) ** 2)
    terms, flagged = [], []
    for i, f in enumerate(diag.findings):
        m0 = model_without(diag, i)
        own = [n for n in final.names if n not in m0.names]
        apart = value_disagreements(fa, fb, own, factor)
        try:
            f0 = _fit(other, m0, start_b)
            fa0 = _fit(meas, m0, start_a)
        except (FitError, ValueError) as exc:
            terms.append({"physics": f.physics, "delta_log_z_joint": None, "delta_log_evidence_other": None,
                          "needed_by_other": None, "model_without": m0.label, "verdict": "not judged",
                          "note": f"the fit without it failed: {exc}"})
            continue
        lz0 = log_evidence(other, f0)
        d_b = lz - lz0 if math.isfinite(lz) and math.isfinite(lz0) else math.nan
        je = finding_joint_evidence(meas, other, (fa, fb), (fa0, f0), shared=lz_joint, per_run=per_run)
        d = je["delta_log_z_joint"]
        needed = None if d is None else bool(d >= MIN_DELTA_LOG_Z)
        if needed is None:
            verdict = "not judged"
            note = "the joint evidence failed (" + "; ".join(
                f"{k}: {v}" for k, v in je["estimators"].items() if str(v).startswith("failed")) + ")"
        else:
            verdict = "shared, kept" if needed else "flagged: not shared"
            note = (f"the log evidence of {meas.source} and {other.source} together is {d:+.1f} nats "
                    f"higher with it shared than {_ALTERNATIVE[je['best_alternative']]}")
            note += (": both recordings need it" if needed else
                     f" (< {MIN_DELTA_LOG_Z:g}): a term only one recording needs")
        failed = [k for k in ("neither", "first_only") if je[k] is None]
        if needed is not None and failed:
            note += (f" (the evidence {_ALTERNATIVE[failed[0]]} failed: compared with the other "
                     "alternative only)")
        if apart and not d_b < MIN_DELTA_LOG_Z:  # B uses the term (a term B does without: values moot)
            pairs = ", ".join(f"{a['name']} {_fmt(a['first'], a['unit'])} here, "
                              f"{_fmt(a['other'], a['unit'])} there" for a in apart)
            verdict = "flagged: other values"
            note += (f"; its values disagree ({pairs}, beyond a factor "
                     f"{factor:.3g} and {VALUE_SE:g} standard errors): the two recordings do not use it "
                     "for the same thing (another feature there, or values traded against the other "
                     "terms)")
        if needed is False or verdict == "flagged: other values":
            flagged.append(f.physics)
        terms.append({"physics": f.physics, "delta_log_z_joint": d, "log_z_joint": {
                          k: je[k] for k in ("shared", "neither", "first_only")},
                      "joint_estimators": je["estimators"], "best_alternative": je["best_alternative"],
                      "needed_by_other": needed, "verdict": verdict,
                      "delta_log_evidence_other": d_b if math.isfinite(d_b) else None,
                      "model_without": m0.label, "note": note, "method": JOINT_METHOD,
                      "values_agree": None if apart is None else not apart, "values_apart": apart or []})
    rec = {"source": str(other.source), "delta_m_kg": delta_m, "final_model": final.label,
           "method": JOINT_METHOD, "per_run": list(per_run), "rms_rel_residual_other": fb.rms_rel_residual,
           "log_z_final": lz if math.isfinite(lz) else None,
           "log_z_joint": lz_joint[0] if math.isfinite(lz_joint[0]) else None,
           # the final model's joint log Z with the other choice of R0 (shared, or each recording's)
           "log_z_joint_other_r0": lz_r0[0] if math.isfinite(lz_r0[0]) else None,
           "terms": terms, "flagged": flagged}
    if delta_m is not None:
        rec["added_mass"] = {}
        for which, fit in (("baseline", diag.baseline_fit), ("final", diag.final_fit)):
            try:
                r = fit_added_mass(meas, other, float(delta_m), fit.model, base_fit=fit,
                                   loaded_fit=fb if which == "final" else None)
            except (FitError, ValueError) as exc:
                rec["added_mass"][which] = {"model": fit.model.label, "error": str(exc)}
                continue
            rec["added_mass"][which] = {
                "model": fit.model.label, "m_kg": r.values["m"], "Bl_N_per_A": r.values["phi_raw"],
                "k_N_per_m": r.values["k"], "R0_ohm": r.values.get("R0"),
                "consistency_p_value": r.consistency["p_value"], "consistency_F": r.consistency["F"],
                "rms_rel_residual": list(r.rms_rel_residual)}
    return rec


#: the alternative a finding's joint evidence was measured against, in words
_ALTERNATIVE = {"neither": "without it in either recording",
                "first_only": "with it in the first recording alone"}


def named_ids(diag) -> list[str]:
    """The physics ids ``diag``'s findings name, in order, each once (``"a+b"`` gives ``a`` and ``b``)."""
    out: list[str] = []
    for f in diag.findings:
        for i in f.physics.split("+"):
            if i not in out:
                out.append(i)
    return out


def search_other(diag, meas: Measurement, other: Measurement, **settings) -> dict:
    """B (``other``) diagnosed from ``diag``'s starting model with ``settings`` (the keyword arguments
    of :func:`~bayes_emt.discovery.diagnose.diagnose`: seed, setup, per_decade, time_budget, ...), and
    each physics id it names that ``diag``'s findings do not, fitted on A (``meas``, thinned as
    ``diag``'s search was) added to ``diag``'s final fit (module docstring). Returns ``{"final_model",
    "baseline_model", "findings", "seconds", "budget_hit", "only_other": [{"physics",
    "delta_log_evidence_first" [nats], "needed_by_first", "model", "note"}]}``; a step A's points do not
    show is not needed by A, with no gain computed (``None``; :func:`.name.fit_candidate`)."""
    say = settings.get("progress")
    if say:
        say(f"the second recording {other.source}, diagnosed from {diag.baseline_fit.model.label}:")
    # from A's start alone (the search other starts would add is A's diagnosis's, not this check's)
    d_b = diagnose(other, diag.baseline_fit.model, **{"starts": (), **settings})
    mine = set(named_ids(diag))
    fit_a = diag.final_fit
    a = meas.thin(diag.search_points.get("per_decade")) if diag.search_points else meas
    lz_a = math.nan
    try:
        if a.n_points != fit_a.n_points:  # the final fit is of other points: polish it on these
            fit_a = fit_admittance(a, fit_a.model, initial=fit_a.theta, warm=True)
        lz_a = log_evidence(a, fit_a)
    except (FitError, ValueError):
        pass  # every term only B names is then reported with its check on A failed
    only = []
    for f in d_b.findings:
        for pid in f.physics.split("+"):
            if pid in mine or any(o["physics"] == pid for o in only):
                continue
            i_lo = int(np.searchsorted(a.omega, f.band.lo))
            i_hi = max(i_lo, int(np.searchsorted(a.omega, f.band.hi, side="right")) - 1)
            band = Band(f.band.lo, f.band.hi, min(i_lo, a.n_points - 1), min(i_hi, a.n_points - 1),
                        f.band.parts, 0.0, 0.0, f.band.peak_omega)
            tried = fit_candidate(a, fit_a, pid, band) if math.isfinite(lz_a) else []
            res = [(c, ev) for c, ev in tried if ev is not None and math.isfinite(ev.log_z)]
            refused = [(c, ev) for c, ev in tried if ev is not None and ev.method == "refused"]
            if not res and refused:  # a step A's measured points do not show: A does not need it
                only.append({"physics": pid, "delta_log_evidence_first": None, "needed_by_first": False,
                             "model": refused[0][0].model.label,
                             "note": f"{other.source} names it and {meas.source} does not need it (its "
                             f"measured points show no such step: {refused[0][1].note}): a term only one "
                             "recording needs"})
                continue
            if not res:
                only.append({"physics": pid, "delta_log_evidence_first": None, "needed_by_first": None,
                             "model": None, "note": f"{other.source} names it; its fit on {meas.source} "
                             "or that fit's evidence failed"})
                continue
            best, ev = max(res, key=lambda r: r[1].log_z)
            d = float(ev.log_z - lz_a)
            needed = d >= MIN_DELTA_LOG_Z
            note = (f"{other.source} names it and {meas.source} gains {d:+.1f} nats from it too: this "
                    "diagnosis did not name it (its search chose other terms), so its findings are not the "
                    "whole story" if needed else
                    f"{other.source} names it and {meas.source} does not need it (log Z {d:+.1f} nats "
                    f"with it, < {MIN_DELTA_LOG_Z:g}): a term only one recording needs")
            only.append({"physics": pid, "delta_log_evidence_first": d, "needed_by_first": bool(needed),
                         "model": best.model.label, "note": note})
    return {"final_model": d_b.final_model, "baseline_model": d_b.baseline_model,
            "findings": [f.physics for f in d_b.findings], "seconds": d_b.seconds,
            "budget_hit": d_b.budget_hit, "only_other": only}


def with_second_recordings(diag, meas: Measurement, also, search: dict | None = None) -> object:
    """``diag`` with the joint-evidence records of ``also`` (``[(recording, delta_m_kg or None), ...]``)
    in its ``joint`` field and a warning per flagged finding. ``search``: the settings with which each
    second recording is diagnosed too (:func:`search_other`, its record under ``"search"``; a warning
    per term only it names); ``None``: not searched."""
    recs, warn = [], list(diag.warnings)
    for other, dm in also:
        rec = check_with(diag, other, dm, meas=meas)
        if search is not None:
            rec["search"] = search_other(diag, meas, other, **search)
            for t in rec["search"]["only_other"]:
                warn.append(f"{t['physics']}: {t['note']} (joint evidence)")
        recs.append(rec)
        for t in rec["terms"]:
            if t["physics"] in rec["flagged"]:
                warn.append(f"{t['physics']}: {t['note']} (joint evidence)")
    return dataclasses.replace(diag, joint=tuple(recs), warnings=tuple(warn))
