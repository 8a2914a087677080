"""Model comparison by evidence: each candidate's log Z from independent estimators, then Bayes
factors, PSIS-LOO beside them and prior sensitivity.

Per model spec (resolved by :func:`bayes_emt.api.as_model`, never by name here):

1. least-squares fit (:func:`~bayes_emt.estimation.fitting.fit_admittance`);
2. the emcee posterior (:func:`~bayes_emt.inference.sampling.sample_likelihood`, started from the
   fit, checkpointed);
3. bridge sampling on its draws (:mod:`.bridge`: both half-splits × ``bridge_seeds`` seeds);
4. Laplace at the posterior mode (:mod:`.laplace`), a fast screen started from the best draw
   (from the fit when the posterior is not sampled);
5. nested sampling (:mod:`.nested`, checkpointed; ``nested_repeats`` seeds), by default with its
   prior repartitioned onto a heavy-tailed fit of the emcee draws (:mod:`.repartition`: the same
   log Z with an information of a few nats; from the prior, the NL models' runs missed the
   posterior by hundreds of nats), or from the model's prior (``nested_prior="prior"``);
6. PSIS-LOO (:mod:`.loo`) and the evidence with every prior width doubled (:mod:`.sensitivity`).

Every sampled estimate is checked against the evidence lower bound of the emcee draws
(:mod:`.bound`, Jensen's inequality, valid whether or not the chain converged): one more than
five standard errors below it is wrong, flagged and left out of the combined log Z (a nested
run whose live points never reached the posterior: NL(5) on NL(2) data, 13000 nats low).
A model whose nested and bridge estimates differ by more than 1 nat is flagged in its warnings
(and so is a Laplace screen that is off by more than 1 nat: a non-Gaussian posterior), as is a
posterior that missed its convergence rule, and (``nested_prior="prior"`` only: a repartitioned
run searches around the draws) a nested run that reached a likelihood more
than 10 nats above every emcee draw: the emcee posterior, started from the least-squares fit,
then sits in a secondary mode. (Seen on the bundled NL(5) data with model I: the global mode
uses the mechanical branch at ω0 ≈ 2.6e4 rad/s, ζ at its upper bound, to mimic eddy-current
losses over the many high-frequency points, 1541 nats above the physical mode at 50.8 rad/s.)

Resuming: every finished model is written to the results JSON at once (atomically) with a key of
its data, model, priors, settings and seed; a re-run with the same JSON path skips models whose
key matches, and an interrupted model continues from its emcee and dynesty checkpoints in the
work folder.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_text
from ..errors import ConvergenceWarning
from ..estimation.fitting import fit_admittance
from ..inference.likelihood import Likelihood, measurement_sha256
from ..inference.sampling import SamplerSettings, sample_likelihood
from ..measurement import Measurement
from ..models import Model
from .bound import below_bound, evidence_lower_bound
from .bridge import bridge_evidence
from .fit_evidence import fit_log_evidence
from .laplace import laplace_evidence
from .loo import psis_loo
from .nested import NestedSettings, run_nested
from .records import DISAGREEMENT_NATS, Comparison, ModelEvidence, combine_methods
from .repartition import Repartition, RepartitionedTarget
from .sensitivity import widened_log_evidence
from .warp import Warp

__all__ = ["CompareSettings", "model_evidence", "compare_models", "load_results"]

MODE_GAP_NATS = 10.0  # nested's best log-likelihood above emcee's best: another mode
NESTED_CUT_NOTE = "nested sampling not run"
LOO_CUT_NOTE = "PSIS-LOO not computed"


@dataclass(frozen=True)
class CompareSettings:
    """Knobs of :func:`compare_models`.

    Attributes
    ----------
    seed : seeds every stochastic step (emcee, bridge proposals, nested sampling).
    methods : which estimators run (``laplace``, ``bridge``, ``nested``); bridge implies emcee.
    nested : :class:`~bayes_emt.evidence.nested.NestedSettings`.
    nested_repeats : independent nested runs (seeds ``seed, seed + 1, ...``), spread reported.
    nested_prior : ``"posterior"``: nested sampling with the prior repartitioned onto the emcee
        draws (:mod:`.repartition`; needs ``bridge``, else it falls back to the prior, with a
        warning); ``"prior"``: from the prior itself (module docstring).
    sampler : :class:`~bayes_emt.inference.sampling.SamplerSettings` of the emcee posterior.
    bridge_seeds : proposal seeds per half-split.
    loo : compute PSIS-LOO; sensitivity : compute the doubled-width evidence.
    """

    seed: int = 0
    methods: tuple[str, ...] = ("laplace", "bridge", "nested")
    nested: NestedSettings = field(default_factory=NestedSettings)
    nested_repeats: int = 1
    nested_prior: str = "posterior"
    sampler: SamplerSettings = field(default_factory=SamplerSettings)
    bridge_seeds: int = 2
    loo: bool = True
    sensitivity: bool = True

    def __post_init__(self):
        unknown = set(self.methods) - {"laplace", "bridge", "nested"}
        if unknown or not self.methods:
            raise ValueError(f"unknown evidence method(s) {sorted(unknown)}; "
                             "choose from laplace, bridge, nested")
        if self.nested_prior not in ("posterior", "prior"):
            raise ValueError(f"unknown nested_prior {self.nested_prior!r}; choose posterior or prior")
        if self.nested_repeats < 1 or self.bridge_seeds < 1:
            raise ValueError("nested_repeats and bridge_seeds must be at least 1")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["methods"] = list(self.methods)
        return d


def _key(lik: Likelihood, settings: CompareSettings) -> str:
    ident = {**lik.identity(), "settings": settings.to_dict()}
    return hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()


def _stem(model: Model) -> str:
    return "".join(c if c.isalnum() else "_" for c in model.label)


def _laplace(lik: Likelihood, fit, post=None) -> tuple[dict, int]:
    """Laplace from the posterior draws when there are some (start: the best draw, scale and warp
    from the draws), else from the least-squares fit (noise coordinates warped: their posterior
    may press against a prior bound, which the fit cannot tell)."""
    if post is not None:
        zs = lik.params.to_z(post.flat())
        z0 = zs[int(np.argmax(post.log_prob.reshape(-1)))]
        scale = np.cov(zs, rowvar=False)
        warp = Warp.near_bounds(lik.params, zs.min(axis=0), zs.max(axis=0), zs.std(axis=0), n_sd=3.0)
        res = laplace_evidence(lik.log_posterior_z, lik.params, z0, scale, warp=warp)
        return res.to_json_dict(), res.n_calls
    ev = fit_log_evidence(lik.meas, fit, lik=lik)
    return ev.to_json_dict(), ev.n_calls


def model_evidence(meas: Measurement, model: Model, name: str | None = None, *,
                   settings: CompareSettings = CompareSettings(), workdir: str | Path | None = None,
                   progress=False, deadline: float | None = None) -> ModelEvidence:
    """The evidence of one model (module docstring, steps 1-6).

    Parameters
    ----------
    meas : the measurement.
    model : the model (its priors are the comparison's priors).
    name : the spec the user gave (default ``model.label``).
    settings : :class:`CompareSettings`.
    workdir : folder for the posterior (netCDF), the nested run (netCDF + JSON) and both
        checkpoints; ``None`` keeps everything in memory (no resume).
    progress : progress bars (``True``), or a ``callable(str)`` told how the samplers proceed every
        few seconds (for redirected output).
    deadline : a :func:`time.monotonic` instant: the emcee chain stops at it (its message says so,
        :func:`~bayes_emt.inference.sampling.run_ensemble`); nested sampling, the cross-check, and
        PSIS-LOO are not started after it (a note says so).
    """
    name = name or model.label
    lik = Likelihood(model, meas)
    key = _key(lik, settings)
    notes: list[str] = []
    seconds: dict[str, float] = {}
    calls: dict[str, int] = {}
    by_method: dict[str, dict] = {}
    work = None if workdir is None else Path(workdir)
    posterior_file = ""
    if work is not None:
        work.mkdir(parents=True, exist_ok=True)
    stem = _stem(model) + "_" + key[:8]

    tell = progress if callable(progress) else (lambda msg: None)
    tell(f"{name}: least-squares fit, then the emcee posterior")
    t = time.perf_counter()
    fit = fit_admittance(meas, model)
    seconds["fit"] = time.perf_counter() - t
    converged = True
    post = None
    if "bridge" in settings.methods:
        t = time.perf_counter()
        ckpt = None if work is None else work / f"{stem}_emcee.h5"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            post = sample_likelihood(lik, fit=fit, seed=settings.seed, checkpoint=ckpt,
                                     resume=ckpt is not None and ckpt.exists(),
                                     overwrite=False, progress=progress, settings=settings.sampler,
                                     deadline=deadline)
        converged = bool(post.converged)
        if not converged:
            notes.append(f"emcee posterior not converged ({post.message}): bridge and LOO are not trusted")
        notes += [str(w.message) for w in caught if not issubclass(w.category, ConvergenceWarning)]
        seconds["emcee"] = time.perf_counter() - t
        calls["emcee"] = int(post.n_steps * post.n_walkers)
        if work is not None:
            posterior_file = str(post.save(work / f"{stem}_posterior.nc"))
        tell(f"{name}: bridge sampling on {len(post.draws)} draws")
        t = time.perf_counter()
        draws_z = lik.params.to_z(post.draws)
        br = bridge_evidence(lik.log_posterior_z, lik.params, draws_z, seed=settings.seed,
                             log_density_draws=post.log_prob, n_seeds=settings.bridge_seeds,
                             tau_floor=max(1.0, float(np.max(post.tau)) / post.thin))
        by_method["bridge"] = br.to_json_dict()
        notes += list(br.warnings)
        seconds["bridge"] = time.perf_counter() - t
        calls["bridge"] = br.n_calls

    if "laplace" in settings.methods:
        tell(f"{name}: Laplace screen")
        t = time.perf_counter()
        try:
            by_method["laplace"], calls["laplace"] = _laplace(lik, fit, post)
            if not by_method["laplace"]["ok"]:
                notes.append(f"Laplace screen: {by_method['laplace']['message']}")
        except (ValueError, np.linalg.LinAlgError) as exc:
            notes.append(f"Laplace screen failed: {exc}")
        seconds["laplace"] = time.perf_counter() - t

    nested = "nested" in settings.methods
    if nested and deadline is not None and time.monotonic() >= deadline:
        nested = False
        notes.append(f"{NESTED_CUT_NOTE}: the time budget ran out (the evidence is bridge sampling's alone)")
    if nested:
        tell(f"{name}: nested sampling")
        t = time.perf_counter()
        runs = []
        target = lik
        if settings.nested_prior == "posterior":
            if post is None:
                notes.append("nested sampling ran from the prior: its repartitioned prior needs the emcee "
                             "draws, which only the bridge method makes")
            else:
                try:
                    target = RepartitionedTarget(lik, Repartition.from_draws(lik.params, draws_z))
                except (ValueError, np.linalg.LinAlgError) as exc:
                    notes.append(f"nested sampling ran from the prior: the emcee draws cannot place its "
                                 f"repartitioned prior ({exc})")
        # a repartitioned run's checkpoint is named by its proposal prior: draws that differ (an
        # emcee run resumed elsewhere) start a new run instead of being refused
        tag = "" if target is lik else "_" + target.repartition.sha256()[:8]
        for r in range(settings.nested_repeats):
            ckpt = None if work is None else work / f"{stem}_nested{r}{tag}.dynesty"
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ConvergenceWarning)
                run = run_nested(target, seed=settings.seed + r, settings=settings.nested, checkpoint=ckpt,
                                 resume=ckpt is not None and ckpt.exists(), progress=progress)
            notes += [str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning)]
            if work is not None:
                run.save(work / f"{stem}_nested{r}.nc")
            runs.append(run)
        vals = np.array([r.log_z for r in runs])
        errs = np.array([r.log_z_err for r in runs])
        w = 1.0 / errs**2
        by_method["nested"] = {
            "method": "nested", "log_evidence": float(np.sum(w * vals) / np.sum(w)),
            "err": float(np.sqrt(1.0 / np.sum(w))),
            "spread": float(np.std(vals, ddof=1)) if len(runs) > 1 else None,
            "information_nats": float(np.mean([r.information for r in runs])),
            "n_calls": int(sum(r.n_calls for r in runs)),
            "n_evaluations": int(sum(r.n_evaluations for r in runs)),
            "prior": "repartitioned" if target is not lik else "prior",
            "repeats": [r.to_json_dict() for r in runs]}
        seconds["nested"] = time.perf_counter() - t
        calls["nested"] = int(sum(r.n_evaluations for r in runs))
        if post is not None and target is lik:  # a repartitioned run's log_l is log(L pi / pi~)
            notes += _missed_mode(runs, post, lik)

    bound = {}
    if post is not None:
        bound, bound_notes = _check_against_bound(by_method, lik.log_posterior_z, draws_z, settings.seed)
        notes += bound_notes
        if bound:
            calls["lower_bound"] = bound["n_calls"]
    log_z, err = combine_methods(by_method)
    notes += _disagreements(by_method)

    elpd = se = None
    widened: dict = {}
    if post is not None:
        loo = settings.loo
        if loo and deadline is not None and time.monotonic() >= deadline:
            loo = False
            notes.append(f"{LOO_CUT_NOTE}: the time budget ran out")
        if loo:
            tell(f"{name}: PSIS-LOO")
            t = time.perf_counter()
            elpd, se, loo_notes = psis_loo(post)
            notes += loo_notes
            seconds["loo"] = time.perf_counter() - t
        if settings.sensitivity and math.isfinite(log_z):
            lz2, sens_notes = widened_log_evidence(log_z, lik.params, lik.params.to_z(post.flat()))
            widened = {"log_evidence": lz2, "delta": lz2 - log_z, "units": "nats"}
            notes += sens_notes
    return ModelEvidence(name, model.label, model.rings, lik.ndim, by_method, log_z, err, elpd, se, widened,
                         {k: float(v) for k, v in seconds.items()}, calls, converged, key, tuple(notes),
                         bound, posterior_file)


def _missed_mode(runs, post, lik) -> list[str]:
    """A warning when nested sampling reached a likelihood the emcee posterior never came near:
    the posterior (and bridge, Laplace, LOO) then describe a secondary mode."""
    best_run = max(runs, key=lambda r: float(np.max(r.log_l)))
    i = int(np.argmax(best_run.log_l))
    gap = float(best_run.log_l[i]) - float(np.max(post.log_lik))
    if not gap > MODE_GAP_NATS:
        return []
    where = ", ".join(f"{n} = {v:.4g} {u}" for n, v, u in zip(lik.params.names, best_run.samples[i],
                                                               lik.params.units, strict=True))
    return [f"nested sampling found a log-likelihood {gap:.1f} nats above every emcee draw: the emcee "
            f"posterior (started from the least-squares fit) misses the dominant mode, near {where}"]


def _check_against_bound(by_method: dict, log_density_z, draws_z, seed: int) -> tuple[dict, list[str]]:
    """The evidence lower bound of ``log_density_z`` from the emcee draws ``draws_z`` (sampling
    space; :mod:`.bound`), as a JSON dict, and warnings;
    an estimate of ``by_method`` far below it is marked ``excluded`` (:func:`~.records.combine_methods`
    leaves it out)."""
    bound = evidence_lower_bound(log_density_z, draws_z, seed=seed)
    if bound is None:
        return {}, []
    out = []
    for name in ("nested", "bridge"):
        m = by_method.get(name)
        if m is None:
            continue
        sigmas = below_bound(m.get("log_evidence"), m.get("err"), bound)
        if sigmas is None:
            continue
        m["excluded"] = (f"{bound.log_evidence - m['log_evidence']:.2f} nats ({sigmas:.1f} standard errors) "
                         f"below the evidence lower bound {bound.log_evidence:.2f} +- {bound.err:.2f}")
        why = " (its live points missed the posterior mass the emcee draws found)" if name == "nested" else ""
        out.append(f"{name} log Z {m['log_evidence']:.2f} nats is {m['excluded']} from the emcee draws: it "
                   f"is wrong{why} and is left out of the combined log Z")
    return bound.to_json_dict(), out


def _disagreements(by_method: dict) -> list[str]:
    out = []
    n, b, lap = (by_method.get(m, {}).get("log_evidence") for m in ("nested", "bridge", "laplace"))
    if n is not None and b is not None and abs(n - b) > DISAGREEMENT_NATS:
        sig = math.hypot(by_method["nested"]["err"] or 0.0, by_method["bridge"]["err"] or 0.0)
        out.append(f"estimators disagree: nested {n:.2f} vs bridge {b:.2f} nats "
                   f"(|difference| {abs(n - b):.2f} > {DISAGREEMENT_NATS:g} nat; "
                   f"{abs(n - b) / sig if sig > 0 else math.inf:.1f} combined standard errors)")
    ref = b if b is not None else n
    if lap is not None and ref is not None and abs(lap - ref) > DISAGREEMENT_NATS:
        out.append(f"Laplace screen {lap:.2f} differs from the sampled estimate {ref:.2f} nats by more "
                   f"than {DISAGREEMENT_NATS:g} nat (non-Gaussian posterior)")
    return out


def load_results(path: str | Path) -> dict[str, ModelEvidence]:
    """Finished models of a results JSON written by :func:`compare_models`, by key (for resuming)."""
    path = Path(path)
    if not path.exists():
        return {}
    try:
        data = json.loads(path.read_text())
        return {m["key"]: ModelEvidence.from_json_dict(m) for m in data.get("models", []) if m.get("key")}
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a bayes_emt comparison file, cannot resume from it ({exc})") from None


def compare_models(meas: Measurement, specs: Sequence[tuple[str, Model]], *,
                   settings: CompareSettings = CompareSettings(), results: str | Path | None = None,
                   workdir: str | Path | None = None, progress: bool = False,
                   rings_info: dict | None = None,
                   on_model: Callable[[ModelEvidence, bool], None] | None = None,
                   deadline: float | None = None) -> Comparison:
    """Evidence of every ``(name, model)`` candidate and the comparison between them.

    Parameters
    ----------
    meas : the measurement.
    specs : ``(name, model)`` pairs, the models built by :func:`bayes_emt.api.as_model`.
    settings : :class:`CompareSettings`.
    results : JSON path written after every model (resume: models whose key matches are skipped).
    workdir : folder for posteriors, nested runs and checkpoints (default: beside ``results``).
    rings_info : ring-count comparison to include (:func:`bayes_emt.evidence.rings.ring_choice`).
    on_model : called with each finished model and whether it was reused from ``results``.
    deadline : a :func:`time.monotonic` instant by which every model should be done: each model in
        turn gets an equal share of the time left when it starts (a model done early leaves its
        rest to the next), passed to :func:`model_evidence`.
    """
    if workdir is None and results is not None:
        workdir = Path(results).with_name(Path(results).stem + "_runs")
    done = {} if results is None else load_results(results)
    models: list[ModelEvidence] = []

    def record(extra_rings=None) -> Comparison:
        return Comparison(tuple(models), meas.source, measurement_sha256(meas), meas.n_points,
                          extra_rings if extra_rings is not None else (rings_info or {}),
                          settings.to_dict(), ())

    for i, (name, model) in enumerate(specs):
        key = _key(Likelihood(model, meas), settings)
        reused = key in done
        now = time.monotonic()
        share = None if deadline is None else now + (deadline - now) / (len(specs) - i)
        m = done[key] if reused else model_evidence(meas, model, name, settings=settings, workdir=workdir,
                                                     progress=progress, deadline=share)
        models.append(m)
        if results is not None:
            atomic_write_text(results, json.dumps(record().to_json_dict(), indent=2))
        if on_model is not None:
            on_model(m, reused)
    return record()
