"""Discrepancy discovery end to end: locate, name, model, repeat until no significant mismatch.

:func:`diagnose` fits the starting model (given, or the base model the evidence prefers), then
repeats: locate bands of significant mismatch (:mod:`.locate`); for each band, strongest first,
fit the catalogue physics whose signature acts there (:mod:`.candidates`, :mod:`.name`); accept
the best candidate when it is significant by evidence and whitens the band, and start the next
round from the augmented fit. A round in which no band is explained ends the search; the bands
still flagged then are ``unexplained``, each with its shape (:mod:`.shape`). The result is a
frozen :class:`Diagnosis` whose :meth:`~Diagnosis.to_json_dict` is the ``diagnose --json`` schema.

Which candidate a band gets is :func:`.prefer.choose`: physical terms before generic patches (a
patch needs determined parameters, a step its own discontinuity, and the patch margin over the best
physical term, :func:`.prefer.patch_margin`), physical terms tried in pairs when none explains the
band alone or a patch leads, patches whose values move between rounds flagged or dropped
(:func:`.prefer.stability_review`), terms impossible in the
``setup`` not tried (:mod:`.prefer`). A finding's band is where the term changes the fit beyond the
noise (:func:`.prefer.change_band`), reported as broadband when wider than two decades.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .._procs import WallClock
from .._record import Record, Table
from ..errors import FitError
from ..estimation.checks import locate_resonance
from ..estimation.fitting import fit_admittance, fit_reusing
from ..estimation.results import FitResult
from ..evidence.fit_evidence import fit_log_evidence
from ..evidence.step_intervals import STEP_METHOD
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, TERMS, Model, parse_model_spec
from ..models.derived import mechanical_resonance
from .candidates import candidate_physics
from .locate import ALPHA, Band, Location, locate_mismatch
from .name import (
    Candidate,
    FitCache,
    await_task,
    base_task,
    log_evidence,
    max_log_likelihood,
    portable,
    rank_candidates,
)
from .prefer import (
    change_band,
    check_setup,
    choose,
    narrow_mode_note,
    setup_excludes,
    stability_review,
    two_impedance_maxima,
)
from .reconcile import final_comparison, healthy_start, kept_findings
from .sanity import back_off, defects, structure_note, structure_reason
from .shape import describe_shape, residual_shape

__all__ = ["Finding", "Diagnosis", "diagnose", "preferred_base_model", "BASELINE_CANDIDATES",
           "START_FAMILIES"]

#: base models compared by evidence when no starting model is given
BASELINE_CANDIDATES: tuple[str, ...] = ("I", "II", "III", "UD")
#: the starts every diagnosis searches from beside the given one (:mod:`.reconcile`): the coil models
#: a user starts from (the paper's UD and III, the NL ring ladder's demo start NL(5))
START_FAMILIES: tuple[str, ...] = ("UD", "III", "NL(5)")
#: bands examined per round (strongest first)
MAX_BANDS_PER_ROUND = 3
#: worker processes fitting the candidates of a band in parallel by default (at most one per core;
#: none inside a daemonic process, which may not have children): on the 2-core machine of
#: benchmarks/RESULTS.md, shared with other jobs (load 4.8), two workers diagnosed dayton_LS10-44.zma
#: in 29 s against 44 s in one process, with the same findings
DEFAULT_WORKERS = 2
# a final model whose R0 differs from the baseline's by more than this (relative) gets a warning: the
# paper's models put R0 4-9 % above a woofer's DC resistance when they absorb missing physics, and a
# negative-resistance shunt cancels most of R0, so a move of this size changes its stability margin
R0_MOVE_WARN = 0.05
#: the search's point density [points per decade of frequency] (:meth:`Measurement.thin`), about
#: 1/90 octave: a high-resolution log sweep (1/48-1/96 octave, 160-320 per decade) is searched whole,
#: a linear FFT export is thinned where it is denser (the LS10-44 run2 recordings: 1980 points at
#: 0.5 Hz, about 1000 per decade at 1 kHz, whose neighbouring residuals are nearly equal, cost five
#: times the time). The catalogue's narrowest lumped feature (Q about 50, a band of 2 %) gets six
#: points. At 200 per decade the truth-study recording (782 points, up to about 300 per decade)
#: lost a close call (3 nats) between a semi-inductance and an NL ring and came out worse against its
#: measured blocked impedance; at 300 and above it keeps the answer of all its points
SEARCH_PER_DECADE = 300.0


@dataclass(frozen=True)
class Finding:
    """One accepted explanation: the physics id, the band it explains, ``Δ log Z`` [nats], the band's
    χ² before and after, whether the data determine it, the parameters it adds and those that moved,
    the model after it, a plain-words verdict, and how its evidence was obtained
    (``evidence_method``: ``"laplace"``, ``"laplace_step"`` for a step term, or the fallback
    ``"laplace_subspace"`` of :mod:`.evidence`, which a warning then names)."""

    physics: str
    band: Band
    delta_log_evidence: float
    chi2_band_before: float
    chi2_band_after: float
    identifiable: bool
    identifiability: str
    device: bool
    parameters: dict
    model_spec: str
    explanation: str
    evidence_method: str = "laplace"
    evidence_note: str = ""
    #: the band the scan flagged [rad/s] (``band`` is where the term changes the fit beyond the noise)
    located_band: tuple = ()
    broadband: bool = False
    band_shape: str = ""

    def to_json_dict(self) -> dict:
        return {
            "physics": self.physics,
            "located_band_rad_s": list(self.located_band),
            "broadband": self.broadband,
            "band_shape": self.band_shape,
            "band_rad_s": [self.band.lo, self.band.hi],
            "band_hz": [self.band.lo / (2 * math.pi), self.band.hi / (2 * math.pi)],
            "delta_log_evidence": self.delta_log_evidence,
            "chi2_band_before": self.chi2_band_before,
            "chi2_band_after": self.chi2_band_after,
            "identifiable": self.identifiable,
            "parameters": self.parameters,
            "explanation": self.explanation,
            "band": dataclasses.asdict(self.band),
            "identifiability": self.identifiability,
            "device": self.device,
            "model_spec": self.model_spec,
            "evidence_method": self.evidence_method,
            "evidence_note": self.evidence_note,
        }

    @classmethod
    def from_json_dict(cls, d) -> Finding:
        b = dict(d["band"])
        band = Band(**{**b, "parts": tuple(b.get("parts", ()))})
        return cls(
            d["physics"],
            band,
            float(d["delta_log_evidence"]),
            float(d["chi2_band_before"]),
            float(d["chi2_band_after"]),
            bool(d["identifiable"]),
            d.get("identifiability", ""),
            bool(d.get("device", True)),
            dict(d.get("parameters") or {}),
            d.get("model_spec", ""),
            d.get("explanation", ""),
            d.get("evidence_method", "laplace"),
            d.get("evidence_note", ""),
            tuple(d.get("located_band_rad_s", ())),
            bool(d.get("broadband", False)),
            d.get("band_shape", ""),
        )


@dataclass(frozen=True, repr=False)
class Diagnosis(Record):
    """What :func:`diagnose` found.

    Attributes
    ----------
    source : the measurement's source.
    baseline_fit, final_fit : the starting model's and the final model's fits.
    findings : accepted explanations in the order found.
    unexplained : ``({"band_rad_s", "band_hz", "description", "shape"}, ...)`` bands no candidate
        explains.
    locations : the mismatch location of every round (JSON records).
    tried : every candidate tried per band (physics, Δ log Z, whitening, accepted).
    warnings : what makes the result less trustworthy.
    seconds : wall time.
    """

    source: str
    baseline_fit: FitResult
    final_fit: FitResult
    findings: tuple[Finding, ...]
    unexplained: tuple[dict, ...]
    locations: tuple[dict, ...] = ()
    tried: tuple[dict, ...] = ()
    warnings: tuple[str, ...] = ()
    seconds: float = 0.0
    final_location: Location | None = field(default=None, compare=False)
    baseline_location: Location | None = field(default=None, compare=False)
    #: joint-evidence records against second recordings (:func:`.joint.check_with`)
    joint: tuple[dict, ...] = ()
    #: the points the search used: ``{"n_points": recording's (after any excluded band), "used": the
    #: search's, "per_decade": the thinning's cap or None}`` (:data:`SEARCH_PER_DECADE`)
    search_points: dict = field(default_factory=dict)

    kind = "diagnosis"

    @property
    def baseline_model(self) -> str:
        return self.baseline_fit.model.label

    @property
    def final_model(self) -> str:
        return self.final_fit.model.label

    @property
    def budget_hit(self) -> bool:
        """Whether the time budget stopped the search (its warning, "time budget of … reached")."""
        return any("time budget" in w for w in self.warnings)

    @property
    def search_note(self) -> str:
        """"searched on N of the M points (at most P per decade of frequency)" when the search was
        thinned (:attr:`search_points`), else ``""``."""
        sp = self.search_points
        if not sp or sp.get("used") == sp.get("n_points"):
            return ""
        return (f"searched on {sp['used']} of the {sp['n_points']} points (at most {sp['per_decade']:g} "
                "per decade of frequency)")

    def to_json_dict(self) -> dict:
        """The ``bayes-emt diagnose --json`` record (its schema: the docs' Discovery page)."""
        return {
            "baseline_model": self.baseline_model,
            "final_model": self.final_model,
            "rms_rel_residual": {
                "baseline": self.baseline_fit.rms_rel_residual,
                "final": self.final_fit.rms_rel_residual,
            },
            "findings": [f.to_json_dict() for f in self.findings],
            "unexplained": [
                {"band_rad_s": u["band_rad_s"], "description": u["description"]} for u in self.unexplained
            ],
            "warnings": list(self.warnings),
            "source": self.source,
            "seconds": self.seconds,
            "baseline_fit": self.baseline_fit.to_json_dict(),
            "final_fit": self.final_fit.to_json_dict(),
            "unexplained_detail": list(self.unexplained),
            "locations": list(self.locations),
            "tried": list(self.tried),
            "joint": list(self.joint),
            "search_points": dict(self.search_points),
        }

    @classmethod
    def from_json_dict(cls, d) -> Diagnosis:
        """The diagnosis a :meth:`to_json_dict` record (``diagnose --json``, :meth:`save`) holds."""
        return cls(
            d.get("source", ""),
            FitResult.from_json_dict(d["baseline_fit"]),
            FitResult.from_json_dict(d["final_fit"]),
            tuple(Finding.from_json_dict(f) for f in d.get("findings", ())),
            tuple(d.get("unexplained_detail", d.get("unexplained", ()))),
            tuple(d.get("locations", ())),
            tuple(d.get("tried", ())),
            tuple(d.get("warnings", ())),
            float(d.get("seconds", 0.0)),
            joint=tuple(d.get("joint", ())),
            search_points=dict(d.get("search_points") or {}),
        )

    # ---- what a person reads -------------------------------------------------------------------
    def headline(self) -> str:
        names = ", ".join(f.physics for f in self.findings) or "nothing"
        return (
            f"{self.baseline_model} -> {self.final_model}: found {names}; rms relative residual "
            f"{100 * self.baseline_fit.rms_rel_residual:.3g} -> {100 * self.final_fit.rms_rel_residual:.3g} %"
        )

    def tables(self) -> list[Table]:
        rows = tuple(
            (
                f.physics,
                f.band.lo / (2 * math.pi),
                f.band.hi / (2 * math.pi),
                f.delta_log_evidence,
                f.chi2_band_before,
                f.chi2_band_after,
                "yes" if f.identifiable else "no",
                f.model_spec,
            )
            for f in self.findings
        )
        notes = (
            f"rms relative residual {100 * self.baseline_fit.rms_rel_residual:.4g} % ({self.baseline_model})"
            f" -> {100 * self.final_fit.rms_rel_residual:.4g} % ({self.final_model}); {self.seconds:.0f} s",
        )
        if self.search_note:
            notes += (f"{self.search_note}; the fits, log Z and chi2 are of those points",)
        out = [
            Table(
                f"{self.source}: discrepancy diagnosis",
                (
                    "physics",
                    "band from [Hz]",
                    "to [Hz]",
                    "delta log Z [nats]",
                    "band chi2 before",
                    "after",
                    "determined",
                    "model after",
                ),
                rows,
                notes,
            )
        ]
        moved = moved_parameters(self.baseline_fit, self.final_fit)
        if moved:
            units = {
                "R0": "ohm",
                "zeta": "1",
                "omega0": "rad/s",
                "phi": "N/(A kg^0.5)",
                "fs_hz": "Hz",
                "Qms": "1",
            }
            out.append(
                Table(
                    "plant parameters, start -> final",
                    ("parameter", "start", "final", "change [%]", "unit", f"beyond {MOVE_SE:g} s.e."),
                    tuple(
                        (
                            k,
                            v["before"],
                            v["after"],
                            None if v["relative_change"] is None else 100 * v["relative_change"],
                            units.get(k, ""),
                            {True: "yes", False: "no"}.get(v.get("beyond_stderr"), "-"),
                        )
                        for k, v in moved.items()
                    ),
                )
            )
        if self.unexplained:
            out.append(
                Table(
                    "unexplained bands",
                    ("band", "description"),
                    tuple(
                        (
                            " - ".join(f"{b / (2 * math.pi):.4g}" for b in u["band_rad_s"]) + " Hz",
                            u.get("description", ""),
                        )
                        for u in self.unexplained
                    ),
                )
            )
        for j in self.joint:
            out.append(_joint_table(self.source, j))
        if self.warnings:
            out.append(Table("warnings", ("message",), tuple((w,) for w in self.warnings)))
        return out

    def details(self) -> dict:
        """Everything behind the verdict (rounds, candidates, shapes, timings) for reports."""
        return {
            **self.to_json_dict(),
            "source": self.source,
            "locations": list(self.locations),
            "tried": list(self.tried),
            "unexplained_detail": list(self.unexplained),
            "seconds": self.seconds,
            "baseline_parameters": self.baseline_fit.parameters,
            "final_parameters": self.final_fit.parameters,
        }


def _joint_table(source: str, j: dict) -> Table:
    """One joint-evidence record (:mod:`.joint`) as a table: each term, which recording named it, the
    gain of one log evidence of both recordings with it shared [nats] (the verdict's number), the
    other recording's own log Z gain with it [nats], and whether both need it (with the same values)."""
    needed = {True: "yes", False: "no: flagged"}

    def verdict(t):  # a term the other needs with other values is another feature there
        v = needed.get(t["needed_by_other"], "-")
        if v == "yes" and t.get("values_agree") is False:
            return "with other values: flagged"
        if v == "yes" and "values_agree" in t and t["values_agree"] is None:
            return "yes (values not compared: a fit without covariance)"
        return v

    rows = tuple((t["physics"], "this", t.get("delta_log_z_joint"), t["delta_log_evidence_other"], verdict(t))
                 for t in j["terms"])
    notes = ()
    if "search" in j:
        sr = j["search"]
        first = {True: "yes: this search did not name it", False: "no: flagged"}
        rows += tuple((t["physics"], "the other only", None, t["delta_log_evidence_first"],
                       first.get(t["needed_by_first"], "-")) for t in sr["only_other"])
        notes = (f"the other recording diagnosed from the same start: {sr['baseline_model']} -> "
                 f"{sr['final_model']} ({', '.join(sr['findings']) or 'no finding'}; {sr['seconds']:.0f} s)",)
    dm = "" if j.get("delta_m_kg") is None else f", {j['delta_m_kg']:g} kg added"
    return Table(f"{source}: joint evidence with {j['source']}{dm}",
                 ("physics", "named by", "joint delta log Z [nats]",
                  "the other recording's delta log Z [nats]", "needed by both"),
                 rows, notes)


def preferred_base_model(meas: Measurement, names=BASELINE_CANDIDATES, *, cache: FitCache | None = None,
                         pool=None, clock=None,
                         deadline: float | None = None) -> tuple[FitResult, float, dict]:
    """The base model (of ``names``) with the largest Laplace log evidence: its fit, log Z and the
    log Z of every one tried ``{name: log_z}`` [nats]. ``cache``: a :class:`.name.FitCache` filled
    with every base model's fit and evidence (the eddy-current escalation from a base below UD then
    does not fit III or UD again); ``pool``: the models fitted in parallel (the same result), the
    workers' CPU time added to ``clock`` (a :class:`.name.CpuClock`). ``deadline``: on ``clock``
    (a :class:`bayes_emt._procs.WallClock`), the models not fitted by then are left out (the pool's
    running fits abandoned; without a pool the fit in progress finishes) and missing from the
    scores; a :class:`FitError` when none was."""
    cache = FitCache() if cache is None else cache
    best, scores, cut = None, {}, False
    if pool is not None:
        parts = portable(meas)
        futures = [pool.submit(base_task, parts, name) for name in names]
        for fut in futures:
            got = await_task(fut, pool, clock, deadline)
            if got is None:  # the time budget ran out: the fits still running are abandoned
                cut = True
                break
            fit, ev, cpu = got
            if hasattr(clock, "workers"):
                clock.workers += cpu
            if fit is not None:
                cache.fits.setdefault(fit.model.label, fit)
                cache.evidence.setdefault(fit.model.label, (fit, ev))
    for name in names:
        if (cut or (deadline is not None and clock() > deadline and scores)) and name not in cache.fits:
            continue
        try:
            fit = fit_reusing(meas, parse_model_spec(name), cache.fits)
        except (FitError, ValueError):
            continue
        lz = cache.evidence_of(meas, fit).log_z
        scores[name] = lz
        if math.isfinite(lz) and (best is None or lz > best[1]):
            best = (fit, lz)
    if best is None and (cut or (deadline is not None and clock() > deadline)):
        raise FitError(f"{meas.source}: the time budget ran out before any of the base models "
                       f"{', '.join(names)} was fitted: give more time (--time-budget) or the model to start "
                       "from (--model)")
    if best is None:
        raise FitError(f"{meas.source}: none of the base models {', '.join(names)} could be fitted")
    return best[0], best[1], scores


#: the share of ``diagnose``'s time budget left for the work after the search (the stability review,
#: the residual shapes of the unexplained bands): the search itself stops at the rest
BUDGET_RESERVE = 0.05


def _pool(workers: int | None):
    """A process pool of ``workers`` (``None``: :data:`DEFAULT_WORKERS`, at most the machine's cores;
    ``0``: one per core), or ``None`` for one worker or inside a daemonic process. Forked where the
    platform can (the workers share the imported package and the terms registered at run time);
    where it cannot, no pool unless ``workers`` asks for one. Its workers die with this process and
    a lost worker is a one-line error (:class:`bayes_emt._procs.ProcessPool`)."""
    import multiprocessing
    import os

    from .._procs import ProcessPool

    cores = os.cpu_count() or 1
    n = min(DEFAULT_WORKERS, cores) if workers is None else int(workers)
    if n < 0:
        raise ValueError(f"diagnose: workers must be >= 0, got {workers}")
    n = n or cores
    if n <= 1 or multiprocessing.current_process().daemon:
        return None
    methods = multiprocessing.get_all_start_methods()
    if "fork" not in methods and workers is None:
        return None  # spawned workers would not hold terms registered at run time
    ctx = multiprocessing.get_context("fork" if "fork" in methods else methods[0])
    return ProcessPool(n, step="the diagnosis", context=ctx)


def _resonance(model: Model, z: np.ndarray) -> np.ndarray:
    """``(P, 2)``: fs [Hz] and Qms of sampling-space rows ``z (P, k)`` by the Thiele–Small convention
    (:func:`~bayes_emt.models.derived.mechanical_resonance`: with suspension creep the resonance of
    the whole mechanical impedance and all its loss there; otherwise ω0/2π and 1/(2ζ))."""
    ws, qms, _ = mechanical_resonance(model, model.params.from_z(z))
    return np.column_stack([ws / (2 * math.pi), qms])


def _mechanics(fit: FitResult, with_se: bool = False) -> dict:
    """R0, ζ, ω0, φ, and fs [Hz] and Qms by the Thiele–Small convention (so that adding creep, which
    moves ζ to the viscous part of the loss alone, does not read as a jump of Qms); with ``with_se``
    ``{name: (value, standard error)}``, fs's and Qms's propagated through the fit's covariance."""
    p = fit.parameters
    out = {k: p[k] for k in ("R0", "zeta", "omega0", "phi") if k in p}
    res = "omega0" in p and "zeta" in p
    diff = res and with_se and fit.cov_z is not None
    if res:
        # the fit's point, and with errors its forward-difference neighbours, in one evaluation
        h = 1e-6 * np.maximum(1.0, np.abs(fit.z))
        rows = np.vstack([fit.z, fit.z + np.diag(h)]) if diff else fit.z[None, :]
        vals = _resonance(fit.model, rows)
        out["fs_hz"], out["Qms"] = (float(x) for x in vals[0])
    if not with_se:
        return out
    se = {}
    try:
        se.update({k: float(fit.stderr[k]) for k in ("R0", "zeta", "omega0", "phi") if k in p})
    except (KeyError, TypeError, ValueError):
        pass
    if diff:
        k = fit.z.size
        grad = (vals[1:] - vals[0]) / h[:, None]  # (k, 2)
        var = np.einsum("ia,ij,ja->a", grad, np.asarray(fit.cov_z, float).reshape(k, k), grad)
        se["fs_hz"], se["Qms"] = (float(math.sqrt(x)) if x >= 0 else float("nan") for x in var)
    return {k: (v, se.get(k, float("nan"))) for k, v in out.items()}


def _unexplained(meas, fit, bands) -> list[dict]:
    """The records of the bands ``fit`` leaves unexplained, each with its shape."""
    out = []
    for band in bands:
        shape = residual_shape(meas, fit.model, fit.theta, band)
        out.append(
            {
                "band_rad_s": [band.lo, band.hi],
                "band_hz": [band.lo / (2 * np.pi), band.hi / (2 * np.pi)],
                "parts": list(band.parts),
                "description": describe_shape(band, shape),
                "shape": shape,
            }
        )
    return out


def _compare_starts(meas, d: Diagnosis, rivals, cache, alpha, seed, say, pool=None, clock=None,
                    deadline=None, time_budget=None) -> Diagnosis:
    """The final comparison (:func:`.reconcile.final_comparison`) over the final models the searches
    from every start reached (``d``'s and ``rivals``'): the diagnosis whose final terms the winner
    holds is returned, its final fit replaced by the winner when that is another coil family or has
    fewer terms (its findings then those the winner holds, its unexplained bands located afresh), a
    line in its warnings saying what each start reached and what was kept. Its candidates are fitted
    on ``pool``; those not done by ``deadline`` (on ``clock``) are left out, and a warning names them."""
    diags = [d, *rivals]
    evidence = lambda f: cache.evidence_of(meas, f).log_z  # noqa: E731
    cmp = final_comparison(meas, [x.final_fit for x in diags], evidence, cache=cache, say=say, pool=pool,
                           clock=clock, deadline=deadline)
    origin = diags[cmp["origin"]]
    win = cmp["fit"]
    reached = "; ".join(f"from {x.baseline_model}: {x.final_model}" for x in diags)
    warn = [w for w in origin.warnings if not w.startswith("R0 moved")]
    if len(diags) > 1:
        warn.append(f"the searches from {len(diags)} starts reached: {reached}. " + (
            cmp["line"] or f"{win.model.label} has the largest evidence (log Z {cmp['log_z']:.1f})"))
    elif cmp["line"]:
        warn.append(cmp["line"])
    for x in rivals:
        warn.extend(f"the search from {x.baseline_model}: {w}" for w in x.warnings if "time budget" in w)
    if cmp["cut"]:
        warn.append(f"time budget of {time_budget:g} s reached during the final comparison: "
                    f"{', '.join(cmp['cut'])} not compared: the answer may depend on the start")
    out = dataclasses.replace(origin, warnings=tuple(warn))
    if win is not origin.final_fit:
        loc = locate_mismatch(meas, win.model, win.theta, alpha=alpha, seed=seed + len(origin.locations))
        out = dataclasses.replace(
            out, final_fit=win, findings=tuple(kept_findings(origin.findings, win)),
            unexplained=tuple(_unexplained(meas, win, loc.bands)), final_location=loc,
            locations=(*origin.locations, {"round": len(origin.locations), "model": win.model.label,
                                           **loc.to_json_dict()}))
    r0 = r0_move_warning(out.baseline_fit, out.final_fit)
    if r0:
        out = dataclasses.replace(out, warnings=(*out.warnings, r0))
    return out


#: a plant parameter's move counts as beyond its standard error when larger than this many of them
MOVE_SE = 2.0


def _sanity(meas, baseline, history, findings, fit, lz):
    """The sanity check of the final model (:mod:`.sanity`): ``None`` when it has no defect, else
    ``(findings, fit, log Z, line)`` of the best model the search reached without one (the latest in
    the order reached) and the one line saying what was refused and why."""
    def added(f):
        return [n for n in f.model.names if n not in baseline.model.names]

    hist = [(f, added(f)) for f, _, _ in history[:-1]] + [(fit, added(fit))]
    i, bad = back_off(hist)
    if not bad:
        return None
    if i is None:  # nothing to back off to: said, the fit kept
        return list(findings), fit, lz, (
            f"the final model {fit.model.label} is broken physics: {'; '.join(bad)}; no model the search "
            "reached is free of it (the start included): its values are not a driver's, do not use them")
    keep_fit, keep_lz, _ = history[i]
    kept = {id(h[2]) for h in history[1:i + 1]}
    dropped = [f.physics for f in findings if id(f) not in kept]
    line = (f"refused the final model {fit.model.label}: {'; '.join(bad)} (broken physics, not a "
            f"driver); backed off to {keep_fit.model.label}, the best model the search reached without "
            "that defect" + (f" (dropped: {', '.join(dropped)})" if dropped else ""))
    return [f for f in findings if id(f) in kept], keep_fit, keep_lz, line


def _finding(meas: Measurement, fit: FitResult, c: Candidate, located: Band, sigma_rel: float) -> Finding:
    """The :class:`Finding` of candidate ``c`` accepted for the located band ``located`` of ``fit``."""
    where = change_band(meas, fit, c.fit, sigma_rel)
    band = dataclasses.replace(located, lo=where["lo"], hi=where["hi"], i_lo=where["i_lo"],
                               i_hi=where["i_hi"])
    moved = moved_parameters(fit, c.fit)
    units = dict(zip(c.fit.model.names, c.fit.model.params.units, strict=True))
    params = {
        "added": {
            n: {"value": v, "stderr": s if math.isfinite(s) else None, "unit": units[n]}
            for n, (v, s) in c.added.items()
        },
        "moved": moved,
    }
    term = next((t for t in c.fit.model.augmentations if t.id in c.physics.split("+")), None)
    return Finding(
        c.physics,
        band,
        c.delta_log_z,
        c.chi2_band_before,
        c.chi2_band_after,
        c.identifiable,
        c.identifiability,
        True if term is None else term.device,
        params,
        c.fit.model.label,
        _explain(c, band, c.fit.model, moved)
        + ("" if term is None or term.device else "; an instrument or session effect")
        + (f"; {where['shape']}" if where["broadband"] else "")
        + ("; a generic patch" if c.patch else "")
        + (f"; {note}" if (note := narrow_mode_note(c.physics, c.fit)) else ""),
        c.evidence_method,
        c.evidence_note,
        (located.lo, located.hi),
        where["broadband"],
        where["shape"],
    )


def moved_parameters(before: FitResult, after: FitResult) -> dict:
    """``{name: {"before", "after", "relative_change", "stderr_before", "beyond_stderr"}}`` of the
    plant parameters (R0, ζ, ω0, φ̄ and fs [Hz] and Qms by the Thiele–Small convention,
    :func:`_mechanics`) [SI]: ``beyond_stderr``
    when the move exceeds :data:`MOVE_SE` standard errors of the ``before`` fit (``None``: no
    standard error)."""
    a, b = _mechanics(before, with_se=True), _mechanics(after)
    out = {}
    for k, (va, se) in a.items():
        if k not in b:
            continue
        ok = math.isfinite(se) and se > 0
        out[k] = {
            "before": va,
            "after": b[k],
            "relative_change": (b[k] - va) / va if va else None,
            "stderr_before": se if ok else None,
            "beyond_stderr": bool(abs(b[k] - va) > MOVE_SE * se) if ok else None,
        }
    return out


def r0_move_warning(before: FitResult, after: FitResult, limit: float = R0_MOVE_WARN) -> str | None:
    """A warning when R0 moves by more than ``limit`` (relative) from ``before`` to ``after``: the
    data then do not pin the DC resistance apart from the added physics. ``None`` otherwise."""
    d = moved_parameters(before, after).get("R0")
    if d is None or d["relative_change"] is None or abs(d["relative_change"]) <= limit:
        return None
    return (
        f"R0 moved {100 * d['relative_change']:+.1f} % ({d['before']:.4g} -> {d['after']:.4g} ohm) from "
        f"the baseline {before.model.label} to the final {after.model.label}: these data do not pin the "
        "DC resistance apart from the added physics; measure it with an ohmmeter and give the "
        "reading (`--re OHM`) before trusting R0-sensitive results (a negative-resistance "
        "shunt cancels most of R0)"
    )


def _fmt(v: float, unit: str) -> str:
    """``v`` with its unit, SI prefixes for F, H and Ω; dimensionless (unit ``1``) bare."""
    prefixes = [(1e-12, "p"), (1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1.0, ""), (1e3, "k")]
    if unit in ("F", "H", "Ω", "ohm") and v != 0:
        for scale, pre in reversed(prefixes):
            if abs(v) >= scale:
                return f"{v / scale:.3g} {pre}{unit}"
        return f"{v:.3g} {unit}"
    return f"{v:.4g}" if unit == "1" else f"{v:.4g} {unit}".strip()


def _explain(c: Candidate, band: Band, model: Model, moved: dict) -> str:
    units = dict(zip(model.names, model.params.units, strict=True))
    pars = ", ".join(
        f"{n} = {_fmt(v, units[n])} ± {_fmt(s, units[n])}"
        if math.isfinite(s)
        else f"{n} = {_fmt(v, units[n])}"
        for n, (v, s) in c.added.items()
    )
    what = c.fit.model.label if c.physics == EDDY_PHYSICS else c.physics
    lo, hi = band.lo / (2 * math.pi), band.hi / (2 * math.pi)
    head = f"{what} ({pars})" if pars else what
    shifts = ", ".join(
        f"{k} {100 * d['relative_change']:+.2f} %"
        + (f" (beyond {MOVE_SE:g} standard errors)" if d.get("beyond_stderr") else "")
        for k, d in moved.items()
        if k in ("R0", "Qms", "fs_hz")
        and d["relative_change"] is not None
    )
    holds = (
        "improves the fit and is determined by the data"
        if c.identifiable
        else "improves the fit but is not determined by the data: " + c.identifiability
    )
    parts = "/".join(band.parts)
    return (
        f"{head} explains the mismatch in the {parts} part(s) between {lo:.4g} and {hi:.4g} Hz; "
        f"log Z rises by {c.delta_log_z:.1f} nats ({c.strength}); the band's chi2 falls from "
        f"{c.chi2_band_before:.4g} to {c.chi2_band_after:.4g} ({c.n_band} residuals); {holds}"
        + (f"; moved: {shifts}" if shifts else "")
    )


def _structure(meas, bases, bands, sigma_rel, why, setup, say, warm, cache, pool, clock, deadline):
    """The structural terms (a second driver in parallel, :attr:`~bayes_emt.models.term.Term.structural`)
    tried when the search ends on the signature of more than one driver (``why``,
    :func:`.sanity.structure_reason`), on the broadest of the kept fit's unexplained ``bands``, added to
    each of ``bases``, ``[(fit, log Z, findings), ...]``: the model the search kept and, when it refused
    one, the refused model fitted afresh from the automatic start (a lumped driver whose resonance
    merged with a port's may be missing the pair's second resonance). ``(candidate, base, band,
    line)`` of the best by evidence among those accepted whose fit has no defect
    (:func:`.sanity.defects`), else ``None`` (the possibility is then only named)."""
    band = max(bands, key=lambda b: b.hi / b.lo)
    kept_fit, kept_lz, _ = bases[0]
    best = None
    for i, (fit, lz, found) in enumerate(bases):
        if i:  # the refused fit's values are broken: its model from the automatic start instead
            try:
                fit = fit_reusing(meas, fit.model, cache.fits)
            except (FitError, ValueError):
                continue
            lz = cache.evidence_of(meas, fit).log_z
            if not math.isfinite(lz):
                continue
        ids = [p for p in candidate_physics(band, fit.model, None, structure=True)
               if getattr(TERMS.get(p), "structural", False) and setup_excludes(p, setup, meas) is None]
        if not ids or (deadline is not None and clock() > deadline):
            continue
        say(f"{why}: trying {', '.join(ids)} on {fit.model.label}")
        ranked = rank_candidates(meas, fit, lz, band, sigma_rel, ids, progress=say, deadline=deadline,
                                 joint=False, warm=warm, cache=cache, pool=pool, clock=clock)
        pick, _ = choose(ranked, meas)
        if pick is None:
            say(f"  {', '.join(ids)} not accepted on {fit.model.label}"
                + (f" (delta log Z {ranked[0].delta_log_z:.1f} nats)" if ranked else ""))
            continue
        m = pick.fit.model
        bad = defects(pick.fit, [n for n in m.names if n not in m.base_model().names])
        if bad:
            say(f"  {pick.physics} on {fit.model.label} not kept: broken physics too ({'; '.join(bad)})")
            continue
        if best is None or pick.log_z > best[0].log_z:
            best = (pick, (fit, lz, found))
    if best is None or not best[0].log_z > kept_lz:
        return None
    pick, base = best
    return pick, base, band, (
        f"one lumped driver cannot explain these data ({why}); two drivers in parallel do: "
        f"{pick.fit.model.label}, log Z +{pick.log_z - kept_lz:.1f} nats over {kept_fit.model.label}, "
        "without a defect; its values are each driver's own (R0 is the first driver's, not the pair's); "
        "measure each driver alone to confirm")


def diagnose(
    meas: Measurement,
    model: Model | None = None,
    *,
    fit: FitResult | None = None,
    max_rounds: int = 4,
    alpha: float = ALPHA,
    seed: int = 0,
    progress=None,
    time_budget: float | None = 240.0,
    setup: str = "unknown",
    exclude_band=None,
    workers: int | None = None,
    warm: bool = True,
    per_decade: float | None = SEARCH_PER_DECADE,
    budget_start: float | None = None,
    starts=(),
) -> Diagnosis:
    """Locate, name and model what ``model`` leaves out of ``meas`` (module docstring).

    Parameters
    ----------
    meas : the measurement.
    model : the starting model; ``None``: ``fit``'s model, or without a fit the base model the
        evidence prefers (:func:`preferred_base_model`).
    fit : a least-squares fit of the starting model to ``meas`` to start from (it is not redone).
    max_rounds : at most this many accepted findings.
    alpha : the scan's family-wise false-alarm probability per round.
    seed : seeds the scan's calibration replicates.
    progress : optional ``callable(str)`` told what is being done (one line per candidate fitted,
        with its log Z and wall seconds); quiet by default.
    time_budget : wall-clock seconds from the call after which no further candidate is fitted: a
        candidate still running in a worker process then is abandoned (the workers are ended), the
        round in progress finishes with what it has, and a warning says what was cut; without a pool
        (``workers=1``) the candidate in progress finishes first. :data:`BUDGET_RESERVE` of it is kept
        for the work after the search. Wall time, so a busy machine stops the search earlier:
        ``None`` or ``0``: no limit, the same result on any machine.
    budget_start : the :func:`time.monotonic` instant ``time_budget`` counts from (default: this
        call; a command passes its own start, so that its imports count too).
    workers : processes fitting a band's candidates in parallel (``None``: :data:`DEFAULT_WORKERS`,
        at most one per core; ``0``: one per core; ``1``: none). The findings do not depend on it:
        every candidate is deterministic and the results are merged in the order they are listed.
    warm : start each catalogue term's fit from the current fit and polish it directly
        (:func:`.name.fit_candidate`); ``False``: the full fit from every start (slower; the same
        decisions unless the paper's intermediate steps reach a better valley).
    setup : ``"free-air"``, ``"sealed"``, ``"vented"``, ``"shaker"`` or ``"unknown"`` (default): terms
        impossible in the setup are not tried (a port needs a vented box); with ``"unknown"`` a term
        may need its data signature first — a port needs two |Z| maxima with a minimum between them
        (:func:`.prefer.two_impedance_maxima`: |Z| smoothed over 5 points has two interior maxima
        within a factor 10 in frequency, each at least 10 % above the minimum between them).
    exclude_band : ``[(f1_hz, f2_hz), ...]``: points left out (:meth:`Measurement.exclude_bands`),
        e.g. a narrow cone break-up an earlier diagnosis reported as an unmodelled narrow resonance.
    starts : the other starting models (specs or models) searched from as well (``()``, the default:
        the given start alone; :data:`START_FAMILIES` makes the answer independent of the start at
        about three times the cost, ``diagnose --all-starts``). A start whose fit is broken physics
        is replaced by the nearest healthy one (:func:`.reconcile.healthy_start`), a start already
        searched from is not searched again, and the answer is the final comparison of
        :mod:`.reconcile` over every search's final model: with :data:`START_FAMILIES` the same
        whichever start is given.
    per_decade : the search runs on at most this many points per decade of frequency
        (:meth:`Measurement.thin`, :data:`SEARCH_PER_DECADE`); ``None`` or ``0``: every point. The
        fits, log Z and band χ² of the result are then of those points (``search_points`` says how
        many); a ``fit`` of the whole recording is polished on them first.
    """
    check_setup(setup)
    meas = meas.exclude_bands(exclude_band)
    n_all = meas.n_points
    meas = meas.thin(per_decade)
    if fit is not None and meas.n_points != n_all and fit.n_points == n_all:
        fit = fit_admittance(meas, fit.model, initial=fit.theta, warm=True)
    search_points = {"n_points": n_all, "used": meas.n_points, "per_decade": per_decade or None}
    t0 = time.perf_counter()
    time_budget = time_budget or None
    clock = WallClock()
    start = clock() if budget_start is None else budget_start
    deadline = None if time_budget is None else start + (1 - BUDGET_RESERVE) * time_budget
    say = progress or (lambda msg: None)
    cache = FitCache()
    pool = _pool(workers)
    try:
        seen: set[str] = set()
        args = (max_rounds, alpha, seed, say, time_budget, setup, t0, clock, deadline, cache, pool, warm)
        d = _diagnose(meas, model, fit, *args, skip_starts=seen)
        rivals = []
        starts = [parse_model_spec(s) if isinstance(s, str) else s for s in starts or ()]
        left = [s.label for s in starts if s.label not in seen]
        for m in starts:
            s = m.label
            if s in seen:
                left = [x for x in left if x != s]
                continue
            if deadline is not None and clock() > deadline:
                d = dataclasses.replace(d, warnings=(*d.warnings, (
                    f"time budget of {time_budget:g} s reached: not searched from {', '.join(left)}, and the "
                    "final model not compared with theirs: the answer may depend on the start")))
                break
            left.remove(s)
            say(f"searching from {s} too: the answer is the final comparison of every start's")
            r = _diagnose(meas, m, None, *args, skip_starts=seen)
            if r is not None:
                rivals.append(r)
        if deadline is None or clock() <= deadline:
            d = _compare_starts(meas, d, rivals, cache, alpha, seed, say, pool, clock, deadline, time_budget)
        elif not left:
            d = dataclasses.replace(d, warnings=(*d.warnings, (
                f"time budget of {time_budget:g} s reached: the final models of the starts not compared: "
                "the answer may depend on the start")))
        return dataclasses.replace(d, search_points=search_points, seconds=time.perf_counter() - t0)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)


def _diagnose(meas, model, fit, max_rounds, alpha, seed, say, time_budget, setup, t0, clock, deadline,
              cache, pool, warm, skip_starts=None) -> Diagnosis | None:
    warn: list[str] = []
    if fit is not None:
        if model is not None and model.label != fit.model.label:
            raise ValueError(f"diagnose: the fit is of {fit.model.label}, the model given is {model.label}")
        if fit.n_points != meas.n_points:
            raise ValueError(
                f"diagnose: the fit used {fit.n_points} points, {meas.source} has {meas.n_points}"
            )
        model = fit.model
    if model is None:
        say("choosing the base model by evidence")
        fit, lz, scores = preferred_base_model(meas, cache=cache, pool=pool, clock=clock, deadline=deadline)
        if len(scores) < len(BASELINE_CANDIDATES) and deadline is not None and clock() > deadline:
            left = [n for n in BASELINE_CANDIDATES if n not in scores]
            warn.append(f"time budget of {time_budget:g} s reached while choosing the base model: "
                        f"{', '.join(left)} not compared (the start is the best of the others)")
        say(
            "base model "
            + fit.model.label
            + " (log Z: "
            + ", ".join(f"{k} {v:.1f}" for k, v in scores.items())
            + ")"
        )
    else:
        fit = fit_admittance(meas, model) if fit is None else fit
        fit, why = healthy_start(meas, fit, cache)
        if why:
            say(why)
            warn.append(why)
        ev0 = fit_log_evidence(meas, fit)
        lz = ev0.log_z
        if ev0.fallback and math.isfinite(lz):
            warn.append(
                f"the Laplace evidence of the starting model {fit.model.label} failed; its log Z is "
                f"Laplace on the identifiable subspace with the flat directions integrated ({ev0.note})"
            )
    if skip_starts is not None:
        if fit.model.label in skip_starts:
            return None  # a start another search of this diagnosis already ran from
        skip_starts.add(fit.model.label)
    if not math.isfinite(lz):
        lz = max_log_likelihood(meas, fit)
        warn.append(
            f"the Laplace evidence of the starting model {fit.model.label} and its fallback failed (a "
            "model far from the data); its maximum log-likelihood over the noise scales at the "
            "least-squares values stands in for it, so the first delta_log_evidence is approximate "
            "(not a bound)"
        )
    baseline = fit
    resonance = locate_resonance(meas)
    omega_r = None if resonance is None else resonance.omega
    findings, locations, tried = [], [], []
    history = [(fit, lz, None)]  # the start and each accepted model, for the sanity check
    # two |Z| maxima with a minimum between them: two mechanical resonances (a port, or a second
    # driver), so the structural terms join the mechanical candidates of every round
    two_maxima = two_impedance_maxima(meas)[0]
    setup_notes: list[str] = []
    loc0 = loc = None
    unexplained_bands: list[Band] = []
    for rnd in range(max_rounds + 1):
        say(f"round {rnd}: locating the mismatch of {fit.model.label}")
        loc = locate_mismatch(meas, fit.model, fit.theta, alpha=alpha, seed=seed + rnd)
        loc0 = loc0 or loc
        locations.append({"round": rnd, "model": fit.model.label, **loc.to_json_dict()})
        if not loc.bands or rnd == max_rounds:
            unexplained_bands = list(loc.bands)
            break
        accepted = None
        unexplained_bands = []
        if deadline is not None and clock() > deadline:
            left = ", ".join(f"{b.lo / (2 * math.pi):.4g}-{b.hi / (2 * math.pi):.4g} Hz" for b in loc.bands)
            warn.append(f"time budget of {time_budget:g} s reached: the bands left were not examined "
                        f"({left})")
            unexplained_bands = list(loc.bands)
            break
        for band in loc.bands[:MAX_BANDS_PER_ROUND]:
            ids = []
            for p in candidate_physics(band, fit.model, omega_r, structure=two_maxima):
                why = setup_excludes(p, setup, meas)
                if why is None:
                    ids.append(p)
                elif why not in setup_notes:
                    setup_notes.append(why)
                    say(why)
            say(f"band {band.lo:.4g}-{band.hi:.4g} rad/s: trying {', '.join(ids)}")
            ranked = rank_candidates(meas, fit, lz, band, loc.sigma_rel, ids, progress=say, deadline=deadline,
                                     warm=warm, cache=cache, pool=pool, clock=clock)
            tried.append(
                {
                    "round": rnd,
                    "band_rad_s": [band.lo, band.hi],
                    "candidates": [
                        {
                            "physics": c.physics,
                            "model": c.fit.model.label,
                            "delta_log_evidence": c.delta_log_z,
                            "whitening": c.whitening,
                            "identifiable": c.identifiable,
                            "accepted": c.accepted,
                            "implausible": c.implausible,
                            "evidence_method": c.evidence_method,
                            "evidence_note": c.evidence_note,
                            "patch": c.patch,
                            "patch_problem": c.patch_problem,
                        }
                        for c in ranked
                    ],
                }
            )
            pick, notes = choose(ranked, meas)
            tried[-1]["choice"] = notes
            if deadline is not None and clock() > deadline:
                warn.append(
                    f"time budget of {time_budget:g} s reached while trying candidates for the band "
                    f"{band.lo:.4g}-{band.hi:.4g} rad/s: not every candidate was fitted (without a result: "
                    + (", ".join(p for p in ids if p not in {c.physics for c in ranked}) or "none") + ")"
                )
            for c in ranked:
                if c.patch_problem and c.delta_log_z >= 5.0:
                    say(f"  {c.physics} not accepted: {c.patch_problem}")
            if pick is not None:
                accepted = (band, pick)
                for n in notes:
                    say("  " + n)
                # what the choice weighed (a patch within the margin of physics, a tie): named, not hidden
                warn.extend(
                    f"band {band.lo / (2 * math.pi):.4g}-{band.hi / (2 * math.pi):.4g} Hz: {n}"
                    for n in notes
                    if "cannot tell" in n or "patch" in n
                )
                break
            unexplained_bands.append(band)
        if accepted is None:
            unexplained_bands += list(loc.bands[MAX_BANDS_PER_ROUND:])
            break
        located, c = accepted
        findings.append(_finding(meas, fit, c, located, loc.sigma_rel))
        if c.evidence_method not in ("laplace", STEP_METHOD):
            warn.append(
                f"{c.physics}: its delta_log_evidence is not the Laplace screen's (which failed) but "
                f"the fallback '{c.evidence_method}' ({c.evidence_note})"
            )
        say(findings[-1].explanation)
        fit, lz = c.fit, c.log_z
        history.append((fit, lz, findings[-1]))
    # a patch whose values the rounds do not agree on is flagged, dropped when not needed
    findings, fit, lz, stab = stability_review(meas, findings, fit, lz, lambda m, v: fit_admittance(
        meas, m, initial=v), lambda f: log_evidence(meas, f))
    warn.extend(stab)
    reached = (fit, lz, list(findings))  # the final model before the sanity check
    refused = _sanity(meas, baseline, history, findings, fit, lz)
    if refused is not None:
        changed = refused[1] is not fit
        findings, fit, lz, line = refused
        say(line)
        warn.append(line)
    if refused is not None and changed:
        loc = locate_mismatch(meas, fit.model, fit.theta, alpha=alpha, seed=seed + len(locations))
        locations.append({"round": len(locations), "model": fit.model.label, **loc.to_json_dict()})
        unexplained_bands = list(loc.bands)
    unexplained = _unexplained(meas, fit, unexplained_bands)
    refused_line = refused is not None and refused[3]
    why = structure_reason(refused_line, unexplained, fit)
    grown = None
    if why and unexplained_bands and (deadline is None or clock() <= deadline):
        bases = [(fit, lz, list(findings))] + ([reached] if reached[0] is not fit else [])
        grown = _structure(meas, bases, unexplained_bands, loc.sigma_rel, why, setup, say, warm, cache,
                           pool, clock, deadline)
    if grown is not None:
        c, (base_fit, _, base_findings), band, line = grown
        say(line)
        warn.append(line)
        findings = [*base_findings, _finding(meas, base_fit, c, band, loc.sigma_rel)]
        say(findings[-1].explanation)
        left = max(max_rounds - len(findings), 0)
        sub = _diagnose(meas, None, c.fit, left, alpha, seed + len(locations), say, time_budget, setup, t0,
                        clock, deadline, cache, pool, warm)
        return dataclasses.replace(
            sub, baseline_fit=baseline, findings=(*findings, *sub.findings),
            locations=(*locations, *sub.locations), tried=(*tried, *sub.tried),
            warnings=(*warn, *(w for w in sub.warnings if not w.startswith("R0 moved"))),
            seconds=time.perf_counter() - t0, baseline_location=loc0)
    note = structure_note(refused_line, unexplained, fit)
    if note:
        warn.append(note)
    if len(findings) == max_rounds and loc is not None and loc.bands:
        warn.append(f"stopped after {max_rounds} findings with mismatch left")
    r0_warning = r0_move_warning(baseline, fit)
    if r0_warning:
        warn.append(r0_warning)
    if baseline.info.get("resonance_mismatch") or fit.info.get("resonance_mismatch"):
        warn.append("a fit put the resonance away from the impedance peak the data shows")
    for f in findings:
        if not f.identifiable:
            warn.append(f"{f.physics}: {f.identifiability}")
    return Diagnosis(
        meas.source,
        baseline,
        fit,
        tuple(findings),
        tuple(unexplained),
        tuple(locations),
        tuple(tried),
        tuple(warn),
        time.perf_counter() - t0,
        loc,
        loc0,
    )
