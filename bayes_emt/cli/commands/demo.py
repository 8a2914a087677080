"""``bayes-emt demo``: the whole chain on the bundled data, ending in one HTML report.

1. fit every coil model (automatic start + two-step least squares) and, in the full run, choose the
   NL ring count by Hankel singular values;
2. compare the models by evidence: each model's emcee posterior (checkpointed), bridge sampling on
   it and, in the full run, nested sampling with its prior repartitioned onto the draws (the second
   estimator, a few seconds per model), the Laplace screen at its mode beside;
3. keep the posterior of the model the evidence prefers (Bode bands, corner plot);
4. design the H∞-optimal RC shunt per model, each evaluated on the best-fitting model, and push the
   posterior through the shunt design for a robust choice (``shunt --posterior``);
5. diagnose the residuals of the second bundled recording, which hides a second mechanical mode
   (``diagnose``); the diagnosis is not told about it;
6. write ``report.html`` (``bayes-emt report`` rebuilds it from the saved outputs).

Every step calls a public verb of :mod:`bayes_emt.api` (``be.fit``, ``be.compare``, ``be.load``,
``be.design_shunt``, ``be.robust_shunt``, ``be.diagnose``) and writes what it returns; no step runs
another command. Exit status 0 when the chain completes (a shortfall, such as ``--quick``'s
unconverged chains, is a warning on top of the report); 1 when a step failed; 2 on a user error.
"""

from __future__ import annotations

import dataclasses
import math
import re
import sys
import threading
import time
import warnings
from pathlib import Path

from ..paths import check_outputs
from ._common import add_output_args, add_parser, int_at_least, print_table, print_warning_lines, seed
from ._demo_budget import MIN_STEP_S, SHARES, Budget, Heartbeat, budget_split
from ._demo_budget import budget_seconds as _budget_seconds

EXAMPLES = """\
bayes-emt demo --quick  (about 2 min: fewer models, short chains; the report says what it cut)
bayes-emt demo --out demo_run  (the whole chain, then open demo_run/report.html)
bayes-emt demo --data speaker.zma  (your own recording: fitted, sampled, shunted and diagnosed)
bayes-emt demo --data speaker.zma --concealed other.zma  (diagnose another recording than --data)
bayes-emt demo --skip diagnose --quiet
"""

FULL = {"models": ("I", "II", "III", "UD", "NL", "UL"), "hankel": True,
        "methods": ("laplace", "bridge", "nested"), "max_steps": 20000, "screen_steps": 500, "draws": 1000,
        "loo": True, "bridge_seeds": 2}
QUICK = {"models": ("I", "II", "NL"), "hankel": False, "methods": ("laplace", "bridge"), "max_steps": 300,
         "screen_steps": 0, "draws": 200, "loo": False, "bridge_seeds": 1}
#: wall seconds the robust shunt's choice may take in a demo run without a time budget (the rest of
#: the chain and the report are written whatever it does)
ROBUST_SHARE_S = 60.0
#: --time-budget's default with --data [s, wall clock]; the bundled demo runs without one unless given
DATA_BUDGET_S = 300.0
#: seconds without a printed line after which a redirected demo says which step is still running
HEARTBEAT_S = 5.0
#: steps --skip may leave out
SKIPPABLE = ("robust_shunt", "diagnose")
#: what the demo writes into its --out folder (besides fit_<MODEL>.json, evidence_runs/, diagnosis/)
OUTPUTS = ("run.json", "fits.json", "hankel.json", "comparison.json", "evidence.png", "posterior.nc",
           "posterior.json", "posterior_bode.png", "posterior_corner.png", "residuals.png", "shunts.json",
           "robust_shunt.json", "shunt_robust_gain.png", "shunt_robust_distributions.png",
           "shunt_robust_boundary.png", "diagnosis.json", "diagnosis_residuals.png", "report.html")
#: models whose least-squares residual exceeds this multiple of the best one's get a short chain only
SCREEN_FACTOR = 3.0
FULL_CUTS = (
    f"Models whose least-squares rms residual is more than {SCREEN_FACTOR:g} x the best model's get a "
    "500-step emcee chain only, not one run to convergence: their log Z (thousands of nats below on the "
    "bundled data) is then flagged as not converged; the verdict does not hinge on it.",
    "Nested sampling runs with its prior repartitioned onto the emcee draws (bayes-emt compare's "
    "default); the run from the model's own prior (--nested-prior prior), the only one that can find a "
    "mode the chain missed, is left to bayes-emt compare.",
)
QUICK_CUTS = (
    "--quick fits models I, II and NL only (III, UD and UL are left out).",
    "--quick does not choose the NL ring count by Hankel singular values (an NL(7) fit); n = 5 is used.",
    "--quick runs each model's emcee chain for 300 steps only (the full run: up to 20000, to convergence): "
    "far too few to converge, so the evidence (bridge sampling on those chains), the posterior and "
    "everything drawn from it (bands, robust shunt) are flagged as not converged.",
    "--quick pushes 200 posterior draws (not 1000) through the robust shunt design.",
    "--quick lets the diagnosis stop after its first finding (--max-rounds 1): it does not check that "
    "nothing else is left.",
    "--quick computes no PSIS-LOO and one bridge-sampling proposal seed per half-split (not two).",
)


def register(sub) -> None:
    p = add_parser(sub, "demo", help="the whole chain on the bundled data, ending in report.html",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("--out", default="bayes_emt_demo", help="output folder (default ./bayes_emt_demo)")
    p.add_argument("--quick", action="store_true", help="≈ 50 CPU s: models I, II and NL only, 300-step "
                   "chains, no Hankel ring choice, 200 draws for the robust shunt (the report says what "
                   "was cut)")
    p.add_argument("--data", default=None, help="measurement file instead of the bundled paper_bench.csv")
    p.add_argument("--freq-unit", choices=["hz", "rad/s"], default=None,
                   help="frequency column unit of --data and --concealed, when the file does not say")
    p.add_argument("--phase-unit", choices=["deg", "rad"], default=None,
                   help="phase column unit of --data and --concealed, when the file does not say")
    p.add_argument("--concealed", default=None, metavar="FILE",
                   help="recording to diagnose (default: --data when given, else the bundled "
                   "concealed_bench.csv)")
    p.add_argument("--seed", type=seed, default=0,
                   help="seed of every stochastic step, a non-negative integer (default 0)")
    p.add_argument("--max-steps", type=int_at_least(1), default=None,
                   help="emcee step budget per model (default 20000; --quick 300)")
    p.add_argument("--time-budget", type=_budget_seconds, default=None, metavar="SECONDS",
                   help="wall-clock seconds for the whole run, shared between its steps "
                   f"({budget_split().replace('%', '%%')}); "
                   "a step that reaches the end of its share stops with what it has, says so in one line "
                   "and in the report's warnings, and the report is always written. Default "
                   f"{DATA_BUDGET_S:g} s with --data, none on the bundled data; 0 = none")
    p.add_argument("--skip", default=None, metavar="STEPS",
                   help=f"comma-separated steps to leave out ({', '.join(SKIPPABLE)}); the report says so")
    add_output_args(p, progress=True)
    p.set_defaults(func=run)


class _Demo:
    """The demo's state: output folder, printing, and the step log that becomes run.json."""

    def __init__(self, args, budget: float | None = None):
        self.args = args
        self.out = Path(args.out)
        self.steps: list[dict] = []
        self.warnings: list[str] = []
        self.cuts: list[str] = []
        self.t0 = time.perf_counter()
        self.budget = Budget(budget)
        self._lock = threading.Lock()
        self._said = self._stage_t0 = time.monotonic()
        self.stage = "start"

    def say(self, text: str = "") -> None:
        if not self.args.quiet:
            with self._lock:
                print(text, flush=True)
                self._said = time.monotonic()

    def heartbeat(self) -> Heartbeat:
        """While it is entered, a line names the step still running whenever a redirected run
        printed nothing for :data:`HEARTBEAT_S` seconds (none on a terminal or with --quiet)."""
        on = not (self.args.quiet or sys.stderr.isatty())
        return Heartbeat(lambda: self._said, lambda: (self.stage, self._stage_t0), self.say, HEARTBEAT_S, on)

    def cut(self, step: str, what: str) -> None:
        """A step the time budget cut: one line now, a warning and an entry of what the run did not do."""
        share = self.budget.share(step)
        text = (f"{step}: cut by the time budget ({self.budget.total:g} s, this step's share "
                f"{share:.0f} s): {what}")
        self.say(f"[{step}] {text}")
        self.warnings.append(text)
        self.cuts.append(text)

    def progress(self):
        """What the samplers get as ``progress``: bars on a terminal, else a line every few seconds
        (False with --quiet)."""
        if self.args.quiet:
            return False
        if sys.stderr.isatty():
            return True
        return lambda msg: self.say("  " + msg)

    def section(self, title: str) -> None:
        self.stage, self._stage_t0 = title.split(":")[0].split(" (")[0], time.monotonic()
        self.say(f"\n== {title} " + "=" * max(0, 70 - len(title)))

    def step(self, name: str, status: str, detail: str = "", seconds: float | None = None) -> None:
        self.steps.append({"name": name, "status": status, "detail": detail,
                           "seconds": None if seconds is None else round(seconds, 2)})
        if status != "ran":
            self.say(f"[{name}] {status}: {detail}")

    def failed(self, name: str, exc: BaseException, t: float) -> None:
        msg = _one_line(exc)
        self.step(name, "failed", msg, time.perf_counter() - t)
        self.warnings.append(f"{name} failed: {msg}")


def _recording_summary(meas, role: str) -> dict:
    from ...models import model_from_dict

    wm = meas.meta.get("written_meta", {})
    sim = None
    if wm.get("simulated"):
        sim = f"{wm.get('model')} (rings {wm.get('rings')}), seed {wm.get('seed')}"
        try:
            hidden = [t for t in model_from_dict({**wm, "parameters": wm.get("priors")}).terms
                      if getattr(t, "augmentation", False)]
        except (ValueError, TypeError, KeyError):
            hidden = []
        if hidden:
            sim += ("; hides " + ", ".join(f"{t.id} ({t.description})" for t in hidden)
                    + " (not told to the diagnosis)")
    return {"source": str(meas.source), "role": role, "n_points": int(meas.n_points),
            "omega_min": float(meas.omega[0]), "omega_max": float(meas.omega[-1]),
            "f_min_hz": float(meas.f_hz[0]), "f_max_hz": float(meas.f_hz[-1]),
            "simulated_from": sim, "noise_rel": wm.get("noise_rel")}


def run(args) -> int:
    from ... import api as be
    from ...io.paramfile import write_json
    from ...report import build_report

    skip = {x.strip() for x in (args.skip or "").split(",") if x.strip()}
    if skip - set(SKIPPABLE):
        raise ValueError(f"--skip {args.skip}: unknown step(s) {', '.join(sorted(skip - set(SKIPPABLE)))}; "
                         f"choose from {', '.join(SKIPPABLE)}")
    cfg = dict(QUICK if args.quick else FULL)
    if args.max_steps is not None:
        cfg["max_steps"] = args.max_steps
        cfg["screen_steps"] = min(cfg["screen_steps"], args.max_steps)
    budget = DATA_BUDGET_S if args.time_budget is None and args.data else args.time_budget
    d = _Demo(args, budget or None)
    out = d.out
    check_outputs(inputs=[("--data", args.data), ("--concealed", args.concealed)],
                  folders=[("--out", out, OUTPUTS)])
    out.mkdir(parents=True, exist_ok=True)
    units = {"freq_unit": getattr(args, "freq_unit", None), "phase_unit": getattr(args, "phase_unit", None)}
    meas = be.read(args.data, **units) if args.data else be.load_paper_bench()
    # the user's own recording is the one diagnosed unless another is named: the bundled concealed-effect
    # recording belongs to the bundled demo
    concealed = (be.read(args.concealed, **units) if args.concealed
                 else meas if args.data else be.load_concealed_bench())
    truth = meas.meta.get("written_meta", {}).get("truth") if not args.data else None
    roles = "main chain: fits, evidence, posterior, shunts"
    run_rec = {"title": "bayes_emt demo" + (" (--quick)" if args.quick else ""), "quick": bool(args.quick),
               "seed": args.seed, "cut": list(QUICK_CUTS) if args.quick else list(FULL_CUTS),
               "data": ([_recording_summary(meas, roles + ", diagnosis")] if concealed is meas else
                        [_recording_summary(meas, roles), _recording_summary(concealed, "diagnosis")]),
               "diagnosed": str(concealed.source), "truth": truth,
               "time_budget_s": d.budget.total, "budget_shares": dict(SHARES) if d.budget.total else None}
    if d.budget.total:
        d.say(f"time budget: {d.budget.total:g} s wall clock ({budget_split(d.budget.total)}); a step that "
              "reaches the end of its share stops there and says so")
    if args.quick:
        d.say("--quick: " + " ".join(QUICK_CUTS))

    d.section("data")
    for r in run_rec["data"]:
        d.say(f"{r['source']} ({r['role']}): {r['n_points']} points, "
              f"{r['f_min_hz']:.4g}..{r['f_max_hz']:.4g} Hz "
              f"({r['omega_min']:.4g}..{r['omega_max']:.4g} rad/s)")

    with d.heartbeat():
        fits = _fits(d, meas, cfg, truth)
        _hankel(d, meas, cfg)
        preferred, cmp = _evidence(d, meas, fits, cfg)
        post = _posterior(d, cmp, preferred, fits)
        _shunts(d, fits, preferred)
        if "robust_shunt" in skip:
            d.step("robust_shunt", "skipped", "--skip robust_shunt was given")
        else:
            _robust(d, post, fits.get(preferred), cfg, d.out / f"fit_{preferred}.json")
        if "diagnose" in skip:
            d.step("diagnose", "skipped", "--skip diagnose was given")
        else:
            _diagnose(d, concealed, preferred)

        unconverged = [s for s in d.steps if s["name"] == "sample" and "NOT CONVERGED" in s["detail"]]
        if unconverged:
            d.warnings.append("the preferred model's posterior did not converge"
                              + (" (--quick runs 300-step chains: expected; the full demo runs them to "
                                 "convergence)" if args.quick else "") + ": its intervals, the evidence and "
                              "the robust shunt drawn from it are not to be trusted")
        run_rec["cut"] += d.cuts
        run_rec.update(steps=d.steps, warnings=d.warnings, total_seconds=time.perf_counter() - d.t0,
                       preferred_model=preferred)
        write_json(out / "run.json", run_rec)
        d.stage, d._stage_t0 = "writing the report", time.monotonic()
        d.say("writing the report ...")
        report = build_report(out)
    d.section("outputs")
    for f in sorted(out.iterdir()):
        if f.is_file():
            d.say(f"  {f.resolve()}  ({f.stat().st_size / 1024:.0f} kB)")
    total = time.perf_counter() - d.t0
    print(f"report: {report.resolve()}  (demo took {total:.0f} s)")
    for w in d.warnings:
        d.say(f"warning: {w}")
    if any(s["status"] == "failed" for s in d.steps):
        d.say("a step failed (see the warnings on top of the report): exit code 1")
        return 1
    if unconverged:
        d.say("the preferred model's posterior did not converge: exit code 1")
        return 1
    return 0


def _fits(d: _Demo, meas, cfg, truth) -> dict:
    from ... import api as be
    from ...io.paramfile import write_json
    from ...plotting import save_figure
    from ...plotting.residuals import plot_residuals

    d.section("least-squares fits: automatic initial estimate + two-step least squares")
    fits, rows, t_all = {}, [], time.perf_counter()
    models = list(cfg["models"])
    for i, name in enumerate(_progress(d, models, "fits")):
        if fits and d.budget.over("fit"):
            d.cut("fit", f"{', '.join(models[i:])} not fitted (nor compared, nor designed for)")
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = be.fit(meas, name)
        fits[name] = fit
        if not d.args.quiet and not sys.stderr.isatty():
            d.say(f"  {fit.model.label}: rms rel. residual {100 * fit.rms_rel_residual:.3f} % "
                  f"({fit.info['seconds']:.1f} s)")
        p = fit.parameters
        rows.append((fit.model.label, f"{100 * fit.rms_rel_residual:.3f}", f"{p['zeta']:.4g}",
                     f"{p['omega0']:.4g}", f"{p['phi']:.4g}", f"{p['R0']:.4g}", f"{fit.info['seconds']:.1f}"))
        if not fit.success:
            d.warnings.append(f"fit of {name}: the optimiser did not converge ({fit.message})")
    if not d.args.quiet:
        print_table(rows, ("model", "rms rel. resid. [%]", "zeta [1]", "omega0 [rad/s]",
                           "phi [N/(A kg^.5)]", "R0 [ohm]", "time [s]"))
        print_warning_lines([{**w, "model": f.model.label} for f in fits.values() for w in f.warnings])
    write_json(d.out / "fits.json", {k: f.to_json_dict() for k, f in fits.items()})
    for k, f in fits.items():
        f.save(d.out / f"fit_{k}.json")
    save_figure(plot_residuals(meas, {k: (f.model, f.theta) for k, f in fits.items()},
                               title=f"{meas.source}: relative residuals of every fit"),
                d.out / "residuals.png", dpi=100)
    d.step("fit", "ran", f"{len(fits)} models", time.perf_counter() - t_all)
    gen = meas.meta.get("written_meta", {}).get("model")
    for fit in (f for f in fits.values() if truth and f.model.spec == gen):
        bad = [n for n, v in fit.parameters.items() if n in truth and fit.stderr[n] > 0
               and abs(v - truth[n]) > 4 * fit.stderr[n]]
        d.say(f"{fit.model.label} (the generating model) against the truth it was simulated from: "
              + ("every parameter within 4 standard errors" if not bad
                 else f"off by > 4 s.e.: {', '.join(bad)}"))
    return fits


def _hankel(d: _Demo, meas, cfg) -> int:
    from ...estimation.hankel import select_rings
    from ...io.paramfile import write_json

    if not cfg["hankel"]:
        d.step("hankel", "skipped", "--quick: NL ring count not chosen by Hankel singular values; n = 5 used")
        return 5
    if d.budget.over("hankel"):
        d.cut("hankel", "the NL ring count was not checked by Hankel singular values (an NL(7) fit); "
              "n = 5 used")
        d.step("hankel", "skipped", "cut by the time budget; n = 5 used")
        return 5
    d.section("NL ring count by Hankel singular values (fit with 7 rings)")
    d.say("  fitting NL(7) ...")
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rc = select_rings(meas, 7)
    d.say("HSV [S]: " + ", ".join(f"{h:.3g}" for h in rc.hsv) + f"; chosen: n = {rc.rings} rings")
    write_json(d.out / "hankel.json", rc.to_json_dict())
    d.step("hankel", "ran", f"n = {rc.rings}", time.perf_counter() - t)
    if rc.rings != 5:
        d.warnings.append(f"Hankel singular values chose n = {rc.rings} rings; the demo's NL stays at n = 5")
    return rc.rings


def _evidence(d: _Demo, meas, fits, cfg):
    """Evidence of every fitted model (``be.compare``: bridge sampling on its emcee posterior, the
    Laplace screen beside, nested sampling in the full run); models far worse than the best by their
    least-squares residual get a short chain only. Returns the preferred model's name and the
    comparison (``None`` when every evidence computation failed)."""
    from ... import api as be
    from ...plotting import save_figure
    from ...plotting.evidence import plot_evidence

    best_rms = min(f.rms_rel_residual for f in fits.values())
    screened = [n for n, f in fits.items()
                if cfg["screen_steps"] and f.rms_rel_residual > SCREEN_FACTOR * best_rms]
    d.section("model comparison by evidence (bridge sampling on each model's emcee posterior, Laplace "
              "screen beside)")
    if screened:
        d.say(f"  {', '.join(screened)}: least-squares residual > {SCREEN_FACTOR:g} x the best one's: a "
              f"{cfg['screen_steps']}-step chain only (their log Z is far below; the verdict does not hinge "
              "on its accuracy)")
    t = time.perf_counter()
    work = d.out / "evidence_runs"

    def show(m, reused):
        lz = ("nan" if not math.isfinite(m.log_evidence)
              else f"{m.log_evidence:.1f} +- {m.log_evidence_err:.1f}")
        d.say(f"  {m.name}: log Z = {lz} nats ({'reused' if reused else f'{m.seconds_total:.0f} s'})")

    parts, failed = [], []
    for group, steps, tag in ((screened, cfg["screen_steps"], "screen"),
                              ([n for n in fits if n not in screened], cfg["max_steps"], "full")):
        if not group:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                parts.append(be.compare(meas, group, seed=d.args.seed, methods=cfg["methods"], loo=cfg["loo"],
                                        max_steps=steps, results=work / f"comparison_{tag}.json",
                                        workdir=work, progress=d.progress(), on_model=show,
                                        deadline=d.budget.deadline("evidence")))
        except Exception as exc:  # noqa: BLE001 - an estimator failure must not lose the run
            msg = _one_line(exc)
            d.warnings.append(f"evidence of {', '.join(group)} failed ({msg}): those models are missing from "
                              "the comparison")
            d.say(f"  evidence of {', '.join(group)} FAILED: {msg}")
            failed += group
    by_rms = min(fits, key=lambda k: fits[k].rms_rel_residual)
    if not parts:
        d.step("compare", "failed", "every evidence computation failed (see the warnings)",
               time.perf_counter() - t)
        return by_rms, None
    cmp = parts[0].merged(*parts[1:])
    _evidence_cuts(d, cmp)
    order = {n: i for i, n in enumerate(fits)}
    cmp = dataclasses.replace(cmp, models=tuple(sorted(cmp.models, key=lambda m: order.get(m.name, 99))),
                              settings={"seed": d.args.seed, "methods": list(cfg["methods"]),
                                        "max_steps": cfg["max_steps"], "screen_steps": cfg["screen_steps"],
                                        "screened": screened})
    cmp.save(d.out / "comparison.json")
    save_figure(plot_evidence(cmp), d.out / "evidence.png", dpi=100)
    if failed:  # the evidence cannot rank a model it did not compute: fall back to the residuals
        d.say(f"preferred: {by_rms} (smallest least-squares residual; the evidence of {', '.join(failed)} "
              "failed)")
        d.step("compare", "failed", f"evidence failed for {', '.join(failed)}; preferred model by "
               "least-squares residual", time.perf_counter() - t)
        return by_rms, cmp
    best = cmp.best or by_rms
    d.say(f"preferred: {best} ({cmp.to_json_dict()['best_verdict'] or 'no verdict'})")
    d.step("compare", "ran", f"{', '.join(cfg['methods'])} for {', '.join(fits)}", time.perf_counter() - t)
    return best, cmp


def _evidence_cuts(d: _Demo, cmp) -> None:
    """Name what the time budget cut in the evidence step: chains stopped before their rule,
    nested sampling not run."""
    from ...evidence.compare import LOO_CUT_NOTE, NESTED_CUT_NOTE

    stopped = {m.name: re.search(r"stopped by the time budget at step (\d+)", w)[1]
               for m in cmp.models for w in m.warnings if "stopped by the time budget at step" in w}
    if stopped:
        d.cut("evidence", "emcee stopped before its convergence rule for " + ", ".join(
            f"{name} (step {step})" for name, step in stopped.items())
            + ": their bridge-sampling log Z and the posterior drawn from them are not converged")
    no_nested = [m.name for m in cmp.models if any(w.startswith(NESTED_CUT_NOTE) for w in m.warnings)]
    if no_nested:
        d.cut("evidence", f"no nested-sampling cross-check of {', '.join(no_nested)} (log Z by bridge "
              "sampling alone)")
    no_loo = [m.name for m in cmp.models if any(w.startswith(LOO_CUT_NOTE) for w in m.warnings)]
    if no_loo:
        d.cut("evidence", f"no PSIS-LOO of {', '.join(no_loo)}")


def _posterior(d: _Demo, cmp, preferred: str, fits):
    """The preferred model's posterior (the emcee run its evidence used, ``be.load``): summary,
    netCDF, figures; its JSON carries the preferred fit's warnings (the walkers start from that fit)
    and ``not_converged`` when the chain missed its rule."""
    from ... import api as be
    from ...io.paramfile import write_json
    from ...plotting import save_figure
    from ...plotting.posterior import plot_bode_bands, plot_corner
    from ...report.figures import corner_names

    rec = None if cmp is None else next((m for m in cmp.models if m.name == preferred), None)
    if rec is None or not rec.posterior_file:
        d.step("sample", "failed", f"no posterior of {preferred} was saved by the evidence step")
        return None
    d.section(f"posterior of {preferred} by emcee (seed {d.args.seed})")
    t = time.perf_counter()
    post = be.load(rec.posterior_file)
    state = ("converged" if post.converged else "NOT CONVERGED: " + post.message)
    d.say(f"{state}: {post.n_steps} steps x {post.n_walkers} walkers, tau_max {max(post.tau):.0f}")
    post.save(d.out / "posterior.nc")
    warns = list(fits[preferred].warnings) if preferred in fits else []
    if not post.converged:
        warns.append({"code": "not_converged", "message": post.message})
    write_json(d.out / "posterior.json", {**post.to_json_dict(), "warnings": warns})
    save_figure(plot_bode_bands(post), d.out / "posterior_bode.png", dpi=100)
    save_figure(plot_corner(post, names=corner_names(post)), d.out / "posterior_corner.png", dpi=80)
    d.step("sample", "ran", f"{post.model.label}: {state}", time.perf_counter() - t)
    return post


def _shunts(d: _Demo, fits, preferred: str | None = None) -> None:
    from ... import api as be
    from ...io.paramfile import write_json
    from ...shunt import evaluate_rc_shunt

    best = min(fits, key=lambda k: fits[k].rms_rel_residual)
    d.section(f"optimal RC shunt per model; each evaluated on the best-fitting model ({best})")
    t = time.perf_counter()
    rows, designs = [], {}
    ref = fits[best]
    # the preferred and the best-fitting model's designs first: a time budget cuts the others
    order = sorted(fits, key=lambda k: (k != preferred, k != best))
    for i, name in enumerate(order):
        fit = fits[name]
        if designs and d.budget.over("shunt"):
            d.cut("shunt", f"no RC shunt designed for {', '.join(order[i:])} (designed: "
                  f"{', '.join(designs)})")
            break
        d.say(f"  designing the RC shunt of {fit.model.label} ...")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            dsg = be.design_shunt(fit)
            ev = evaluate_rc_shunt(ref.model, ref.theta, dsg.Rs, dsg.Cs)
        designs[name] = {**dsg.to_json_dict(), f"evaluated_on_{best}": ev.to_json_dict()}
        rows.append((fit.model.label, f"{dsg.Rs:.4f}", f"{dsg.Cs:.4g}", f"{dsg.attenuation_db:.2f}",
                     f"{ev.attenuation_db:.2f}" if ev.stable else "UNSTABLE", f"{ev.stability_margin:.3f}"))
    rows = [rows[list(designs).index(k)] for k in fits if k in designs]  # back in the fits' order
    designs = {k: designs[k] for k in fits if k in designs}
    if not d.args.quiet:
        print_table(rows, ("design model", "Rs [ohm]", "Cs [F]", "own model [dB]", f"on {best} [dB]",
                           f"margin on {best} [ohm]"))
    write_json(d.out / "shunts.json", designs)
    d.step("shunt", "ran", f"{len(designs)} designs", time.perf_counter() - t)


def _robust(d: _Demo, post, fit, cfg, fit_file=None) -> None:
    """The robust shunt over the preferred posterior's draws. Without a time budget, here, its choice
    limited to :data:`ROBUST_SHARE_S`. With one, in a worker process (reading the saved posterior
    and fit) that is ended at the step's deadline: every draw's own design, before the choice, cannot
    be stopped from within (one draw whose batched design does not settle is designed alone, seconds
    each); the step is then named as cut and the rest of the run goes on."""
    if post is None:
        d.step("robust_shunt", "skipped", "no posterior")
        return
    d.section(f"robust RC shunt over {cfg['draws']} posterior draws of {post.model.label}")
    t = time.perf_counter()
    progress = not getattr(d.args, "quiet", False)
    try:
        if d.budget.total is None:
            summary, warns = _robust_design(d.out, post, fit, cfg["draws"], d.args.seed, ROBUST_SHARE_S,
                                            progress)
        else:
            left = d.budget.left("robust_shunt", MIN_STEP_S)
            # the choice gets what the per-draw designs leave, less the few seconds of saving and figures
            choice = max(1.0, left - ROBUST_SAVE_S)
            from ..._procs import ProcessPool

            with ProcessPool(1, step="the robust shunt") as pool:
                task = pool.submit(_robust_worker, str(d.out), str(d.out / "posterior.nc"),
                                   None if fit_file is None else str(fit_file), cfg["draws"], d.args.seed,
                                   choice, progress)
                try:
                    summary, warns = task.result(timeout=left)
                except TimeoutError:
                    pool.stop_workers()
                    d.cut("robust_shunt", f"not finished in the {left:.0f} s left to it (every posterior "
                          "draw's own design comes first, some draws one at a time): no robust shunt in this "
                          "run; bayes-emt shunt --posterior on the saved posterior.nc designs it")
                    d.step("robust_shunt", "skipped", "cut by the time budget: not finished in its share",
                           time.perf_counter() - t)
                    return
    except Exception as exc:  # noqa: BLE001 - a feature step that fails must not lose the rest of the run
        d.failed("robust_shunt", exc, t)
        return
    d.say(summary)
    d.step("robust_shunt", "ran", f"{cfg['draws']} draws", time.perf_counter() - t)
    # its own time budget's warning (``shunt.robust``: "the robust choice stopped at its time budget")
    budget_notes = [w for w in warns if "stopped at its time budget" in w]
    if d.budget.total is not None and budget_notes:
        d.cut("robust_shunt", "its choice stopped early: " + budget_notes[0].splitlines()[0])


#: seconds a budgeted robust-shunt step keeps for saving its result and figures after the choice
ROBUST_SAVE_S = 8.0


def _robust_design(out, post, fit, n_draws: int, seed: int, choice_budget: float, progress: bool):
    """``be.robust_shunt`` on ``post``, saved with its figures into ``out``; its summary and warnings."""
    from ... import api as be
    from ...plotting import save_figure
    from ...plotting.robust_shunt import (
        plot_attenuation_distributions,
        plot_gain_bands,
        plot_stability_boundary,
    )

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = be.robust_shunt(post, nominal=fit, n_draws=n_draws, seed=seed, boundary_points=24,
                              progress=progress, time_budget=choice_budget)
    res.save(Path(out) / "robust_shunt.json")
    for name, plot in (("shunt_robust_gain.png", plot_gain_bands),
                       ("shunt_robust_distributions.png", plot_attenuation_distributions),
                       ("shunt_robust_boundary.png", plot_stability_boundary)):
        save_figure(plot(res.detail), Path(out) / name, dpi=100)
    return res.summary(), [str(w) for w in res.warnings]


def _robust_worker(out: str, post_file: str, fit_file: str | None, n_draws: int, seed: int,
                   choice_budget: float, progress: bool):
    """:func:`_robust_design` in a worker process, from the saved posterior and fit."""
    from ... import api as be

    post = be.load(post_file)
    fit = be.load(fit_file) if fit_file and Path(fit_file).exists() else None
    return _robust_design(out, post, fit, n_draws, seed, choice_budget, progress)


def _diagnose(d: _Demo, meas, model: str) -> None:
    """Diagnose ``meas`` (the bundled concealed-effect recording, ``--data`` or ``--concealed``),
    starting from ``model`` (the one the evidence preferred on the main recording, the same device),
    and draw its residuals with the flagged bands."""
    from ... import api as be
    from ...plotting import save_figure
    from ...plotting.discovery import plot_bode_overlay
    from ...plotting.discovery import plot_residuals as plot_diagnosis
    from ...plotting.residuals import plot_residuals

    d.section(f"discrepancy diagnosis of {meas.source}")
    t = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = be.fit(meas, model)
            # without a demo budget, none: the diagnosis must not depend on how fast or busy the machine
            # is (under load the default 240 s ran out before second_resonance was tried)
            share = d.budget.left("diagnose", MIN_STEP_S)
            diag = be.diagnose(meas, fit=fit, seed=d.args.seed, max_rounds=1 if d.args.quick else 4,
                               time_budget=share,
                               progress=None if d.args.quiet else (lambda msg: d.say("  " + msg)))
        diag.save(d.out / "diagnosis.json")
        folder = d.out / "diagnosis"
        folder.mkdir(exist_ok=True)
        save_figure(plot_diagnosis(diag, meas), folder / "residuals.png")
        save_figure(plot_bode_overlay(diag, meas), folder / "bode.png")
    except Exception as exc:  # noqa: BLE001 - a feature step that fails must not lose the rest of the run
        d.failed("diagnose", exc, t)
        return
    d.step("diagnose", "ran", str(meas.source), time.perf_counter() - t)
    if share is not None and diag.budget_hit:
        w = next(w for w in diag.warnings if "time budget" in w)
        d.cut("diagnose", f"its search stopped after the {share:.0f} s left to it: {w.splitlines()[0]}")
    if diag.search_note:
        d.say(f"  {diag.search_note}")
    for f in diag.findings:
        d.say(f"  finding: {f.explanation}")
    if not diag.findings:
        d.say("  no significant mismatch found")
    # the final comparison over coil families may keep another model than the search from `model` reached
    for w in diag.warnings:
        if w.startswith("final comparison"):
            d.say("  " + w)
    d.say(f"  final model: {diag.final_model} (the search started from {diag.baseline_model})")
    bands = [(f.band.lo / (2 * math.pi), f.band.hi / (2 * math.pi), f"{f.physics} (found)")
             for f in diag.findings]
    bands += [(u["band_rad_s"][0] / (2 * math.pi), u["band_rad_s"][1] / (2 * math.pi), "unexplained")
              for u in diag.unexplained if u.get("band_rad_s")]
    save_figure(plot_residuals(meas, {f"{fit.model.label} fit": (fit.model, fit.theta)}, bands_hz=bands,
                               title=f"{meas.source}: residuals of the {fit.model.label} fit"
                                     + ("; flagged bands shaded" if bands else "")),
                d.out / "diagnosis_residuals.png", dpi=100)


def _one_line(exc: BaseException) -> str:
    first = (str(exc).strip().splitlines() or [""])[0]
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__


def _progress(d: _Demo, items, desc: str):
    """A progress bar over ``items`` on stderr (none with --quiet or when stderr is not a terminal)."""
    if d.args.quiet or not sys.stderr.isatty():
        return items
    from tqdm.auto import tqdm

    return tqdm(items, desc=desc, leave=False)
