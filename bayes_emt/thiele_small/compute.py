"""``thiele_small(...)``: the loudspeaker engineer's bench workflow (free air, added mass, added
volume) with credible intervals and the spread across coil models.

Methods
-------
* **free air** (one recording): fs, Re, Le, Qms, Qes, Qts, EBP; with a known Mms or Bl also Bl,
  Mms, Cms, Kms, Rms, and with Sd Vas, η0, SPL.
* **added mass** (the free-air recording plus one or more recordings with known masses Δm
  glued to the cone): one joint posterior of ``(Mms, c, k, Bl, R0, coil...)`` over all
  recordings (:mod:`bayes_emt.added_mass.multi`), the "dual added mass" of Speakerbench
  (https://speakerbench.com/manual/) and REW when two masses are given.
* **added volume** (the free-air recording plus one in a sealed test box of known net volume
  Vb): ``Vas = Vb ((fc Qec)/(fs Qes) − 1)`` (the classic closed-box method: R. H. Small,
  "Closed-box loudspeaker systems, Part I", JAES 20(10), 1972; the same formula in V. Dickason,
  *The Loudspeaker Design Cookbook*), fc and Qec from the box recording's fit, fs and Qes
  from free air; then with Sd: Cms = Vas/(ρ c² Sd²), Mms = 1/(ωs² Cms), Bl = √(ωs Mms Re/Qes).
  The two recordings are independent: their posteriors' draws are paired at random.

Uncertainty: the posterior's median and 5–95 % quantiles of each quantity (emcee, the
stopping rule of :mod:`bayes_emt.inference.sampling`, with the T/S budget
:data:`TS_SAMPLER`); ``fast=True`` replaces the posterior by the least-squares fit's Gaussian
approximation in sampling space (its covariance, i.e. the standard errors and correlations),
pushed through the relations by 4000 draws, and says so in the warnings.

``model_spread``: each quantity's range of the least-squares point values over the candidate
models (``models_for_spread``; default the eddy-current coil models II, III and UD with the main
model's physics terms, plus the main model itself) that pass three tests, in this order:

1. *adequate*: rms relative residual within a factor :data:`ADEQUATE_RMS_FACTOR` of the best
   candidate's;
2. *determined*: every parameter has a finite standard error no larger than its value (log
   parameters: ``sd(log x) ≤ 1``) and none ends within 0.1 % of its prior support's width of an edge
   (the rules of :mod:`bayes_emt.estimation.adequacy`'s ``not_identifiable`` and
   ``parameter_at_bound``). A degenerate fit fails here: on the LS10-44 free-air recording the
   Bessel model III ends at α = 100 s, its prior's upper edge, where it is a pure semi-inductor
   whose α the data cannot see, and R0 = 2.94 ± 19.9 Ω trades against it;
3. *probable*: posterior model probability ``P_i = Z_i / Σ Z_j`` (equal prior odds over the
   candidates left after 1–2) at least :data:`SPREAD_MIN_PROBABILITY`, with ``log Z`` the Laplace
   approximation at the least-squares fit (:func:`~bayes_emt.evidence.fit_evidence.fit_log_evidence`
   for one recording; the joint likelihood of all recordings for added mass; the sum of the two
   recordings' for added volume). With an ohmmeter reading, log Z is that of the data with the
   reading as a Normal prior on R0 (Bayes' rule) whichever mode the estimates use: the reading
   informs every candidate alike. A candidate whose Laplace evidence fails is kept (no evidence to
   weigh it by) and listed under ``no_evidence``.

This is the spread "weighted by evidence": a model the evidence rules out carries no weight, the
others count whatever their probability (a range, not a mixture). With the main model alone left
the spread is that model's value alone (``[v, v]``: the evidence leaves no other); when the main
model itself is left out, the spread shows the values of the
models that are left (one value possibly) and a ``better_model`` warning names the most probable.
Every candidate's rms, undetermined parameters, log Z, probability and verdict are in
``inputs["model_spread"]``, and the rule in words in ``inputs["model_spread_method"]``. On real
recordings with thousands of points the evidence usually leaves one model (differences of
hundreds of nats when the rms differs by a few per cent), so the spread says that the coil models
disagree only when the data cannot tell them apart.

An ohmmeter reading ``re=(R, sd)`` [Ω] gives Re: by default (mode ``"cut"``,
:mod:`bayes_emt.estimation.meter`) R0 follows the reading alone and every other parameter is
estimated at it, in the fits and the posteriors; with ``(R, sd, "prior")`` it is a Normal prior on
R0 combined with the data (a penalty for least squares).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..estimation.meter import as_meter
from ..estimation.plateau import plateau_note
from ..measurement import Measurement
from ..models import Model, parse_model_spec
from .curve import fit_curve
from .definitional import (
    DEFINITIONAL_METHOD,
    add_definitional,
    curve_residual_structure,
    half_width_sd,
    small_on_curve,
)
from .from_results import LAPLACE_DRAWS, from_fit, from_posterior, laplace_theta
from .mixture import MIXTURE_METHOD, mixture_weights, weighted_quantiles
from .plausibility import check_inputs, check_result, setup_warnings
from .relations import NAMES, UNITS, free_air, with_mass, with_sd
from .result import ThieleSmall
from .spread import (
    ADEQUATE_RMS_FACTOR,
    DEFAULT_SPREAD_BASES,
    MODEL_SPREAD_METHOD,
    SPREAD_MIN_PROBABILITY,
    rank_key,
    select_spread_models,
    spread_models,
    undetermined,
)

__all__ = ["thiele_small", "from_fit", "from_posterior", "evidence_supported_model", "AUTO_CANDIDATES",
           "AUTO_TERMS", "TS_SAMPLER", "ADEQUATE_RMS_FACTOR", "DEFAULT_SPREAD_BASES",
           "SPREAD_MIN_PROBABILITY", "MODEL_SPREAD_METHOD", "undetermined",
           "select_spread_models"]

#: the candidates of the evidence-supported default model (``model=None``): the coil models, then
#: the catalogue terms of :data:`AUTO_TERMS` on the most probable of them
AUTO_CANDIDATES = DEFAULT_SPREAD_BASES
#: physics terms tried on the most probable coil model (a lossy coil beyond the model's eddy
#: currents; the suspension's viscoelastic creep below resonance)
AUTO_TERMS = ("semi_inductance", "suspension_creep")
_NOISE_SHORT = {"correlated": "with the model-discrepancy likelihood", "white": "white likelihood"}
#: what each noise kind means, in the result's inputs
NOISE_DESCRIPTION = {
    "correlated": "instrument noise plus a model discrepancy correlated over log-frequency "
                  "(Ornstein-Uhlenbeck, size and correlation length inferred): intervals that include the "
                  "model's misfit",
    "white": "independent errors at every frequency: the intervals if the model were exact"}


def _ts_sampler():
    from ..inference.sampling import SamplerSettings

    return SamplerSettings(max_steps=3000, ess_target=400.0, min_tau_multiple=25.0, max_draws=2000,
                           tau_margin=True)


#: the sampler settings of a T/S posterior (a smaller ESS target than ``sample``'s 1000: quantiles
#: of 5 % and 95 % from 400 effective draws move by about 0.1 posterior standard deviations; a τ
#: still moving passes when the length and ESS targets hold with τ enlarged by its last change,
#: ``tau_margin``)
TS_SAMPLER = None  # built lazily by _ts_sampler (inference is imported on use)


def _measurement(x, where: str, read_options: dict | None, f_range_hz, exclude_band=None) -> Measurement:
    if isinstance(x, Measurement):
        meas = x
    elif isinstance(x, str | Path):
        from ..io import read_measurement

        meas = read_measurement(x, **(read_options or {}))
    else:
        raise TypeError(f"{where}: expected a Measurement or a file path, got {type(x).__name__}")
    if f_range_hz is not None:
        lo, hi = f_range_hz
        meas = meas.select(None if lo is None else 2 * math.pi * lo, None if hi is None else 2 * math.pi * hi)
    return meas.exclude_bands(exclude_band)


def _volume_of(box) -> float | None:
    try:
        return float(box[1])
    except (TypeError, ValueError, IndexError):
        return None  # the shape is refused below, with its own message


def _model(model) -> Model | None:
    if model is None or (isinstance(model, str) and model.strip().lower() == "auto"):
        return None
    return parse_model_spec(model) if isinstance(model, str) else model


@dataclass
class _Inputs:
    meas: Measurement
    loaded: list[tuple[Measurement, float]]
    box: tuple[Measurement, float] | None
    sd: float | None
    re: tuple[float, float] | None
    mms: float | None
    bl: float | None
    rho: float
    c: float
    seed: int
    settings: object
    evidence: bool = True  # compute each model's Laplace evidence (only needed for the model spread)
    curve: dict | None = None  # the main model's fitted free-air curve (curve.fit_curve)
    noise: str = "white"  # the likelihood's noise (bayes_emt.inference.discrepancy)
    fits: dict = field(default_factory=dict)  # id(recording) -> {model label: FitResult} (_fit)
    bounded: bool = False  # candidates' evidences resolved by _resolve_pending (ranking the candidates)


def _fit(meas: Measurement, model: Model, re, fits: dict | None):
    """``fit_admittance(meas, model, re=re)``, each fit of one recording made once per ``ts`` call:
    the candidates, the main model's posterior, the plateau reading and the nested fits their
    starts need (NL's UL surrogate, a term's base model) share ``fits[id(meas)]``
    (:func:`~bayes_emt.estimation.fitting.fit_reusing`: the result does not depend on it). A model
    with a physics term is fitted warm (``warm=True``: from the fit without the term and the term's
    starts straight to the polish; the paper's steps 1-2 only hand on a start)."""
    from ..estimation.fitting import fit_admittance, fit_reusing

    warm = bool(model.augmentations)
    if fits is None:
        return fit_admittance(meas, model, re=re, warm=warm)
    reuse = fits.setdefault(id(meas), {})
    if re is None:
        return fit_reusing(meas, model, reuse, warm=warm)
    return fit_admittance(meas, model, re=re, reuse=reuse, warm=warm)


def _complete(ts: dict, model: Model, theta, inp: _Inputs, mms=None) -> dict:
    """Mass-dependent quantities from ``mms`` (per row), a known Mms or a known Bl; then Sd."""
    if mms is None and inp.mms is not None:
        mms = inp.mms
    if mms is None and inp.bl is not None:
        phi = np.atleast_2d(theta)[:, model.params.index("phi")]
        mms = inp.bl**2 / phi**2
    if mms is not None:
        ts = with_mass(ts, model, theta, mms)
        if inp.sd is not None:
            ts = with_sd(ts, inp.sd, inp.rho, inp.c)
    return ts


def _single_evidence(meas, fit, prior_model, noise: str = "white") -> float:
    from ..evidence.fit_evidence import fit_log_evidence
    from ..inference.likelihood import Likelihood

    try:
        ev = fit_log_evidence(meas, fit, lik=Likelihood(prior_model, meas, noise=noise))
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return float("nan")
    return float(ev.log_z)


#: a candidate whose largest log-likelihood is more than this many nats below the best evidence so
#: far has a posterior model probability below exp(-25) ~ 1.4e-11 whatever its evidence (the evidence
#: is never above the largest likelihood: ``Z = ∫ L π ≤ max L`` for a prior that integrates to one,
#: the noise scales' included): its evidence's subspace fallback is not run (_resolve_pending)
EVIDENCE_SKIP_NATS = 25.0


def _bounded_evidence(meas, fit, prior_model, noise: str, below: float | None) -> tuple[float, float | None]:
    """``(log Z, None)`` as :func:`_single_evidence`, or ``(nan, upper)`` when the Laplace screen
    failed and the likelihood's maximum ``upper`` [nats] is below ``below``
    (:func:`~bayes_emt.evidence.fit_evidence.fit_log_evidence`'s ``below``)."""
    from ..evidence.fit_evidence import fit_log_evidence
    from ..inference.likelihood import Likelihood

    try:
        ev = fit_log_evidence(meas, fit, lik=Likelihood(prior_model, meas, noise=noise), below=below)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return float("nan"), None
    if ev.method == "bounded":
        return float("nan"), float(ev.upper)
    return float(ev.log_z), None


def _joint_evidence(runs, mfit, prior_model, noise: str = "white") -> float:
    """Log Z of the joint added-mass likelihood (each run's noise scales sampled), started at the
    joint least-squares fit: :func:`~bayes_emt.evidence.joint.joint_log_evidence` (Laplace, and its
    subspace fallback where the Hessian is not positive definite at the mode: without it a coil
    model whose screen failed had no evidence and ranked below every worse one that had, e.g. III
    with a 6 % residual chosen over UD and NL(3) with 1.8 % and 1.4 % on a simulated NL(3) +
    creep driver with a 10 g added mass, Re then 11 % off)."""
    from ..added_mass.multi import MultiMassLikelihood, MultiMassModel
    from ..evidence.joint import joint_log_evidence

    lik = MultiMassLikelihood(MultiMassModel(prior_model, mfit.joint.deltas), tuple(runs), noise)
    return float(joint_log_evidence(lik, mfit).log_z)


def _estimate(model: Model, method: str, inp: _Inputs, mode: str, warns: list):
    """``(ts arrays, ts at the least-squares point, spread record)`` of one model: ``mode``
    ``"point"`` (least squares only; the arrays are then that point), ``"laplace"`` or
    ``"posterior"``. The spread record: ``{"model", "rms", "undetermined", "log_z"}``."""
    from ..added_mass.multi import MultiMassModel, fit_multi_mass, sample_multi_mass
    from ..estimation.meter import conflict_warning
    from ..inference.meter_cut import cut_posterior, held_fit
    from ..inference.sampling import sample_posterior

    rng = np.random.default_rng(inp.seed)
    meter = inp.re
    prior_model = model if meter is None else model.with_priors({"R0": meter.prior()}, where="re")

    def single(meas, label):
        fit = _fit(meas, model, inp.re, inp.fits)
        warns.extend({"code": w["code"], "message": w["message"], "model": model.label, "run": label}
                     for w in fit.warnings)
        point = fit.theta[None, :]
        if mode == "point":
            theta = point
        elif mode == "component":  # a mixture component: Laplace at the posterior mode, same likelihood
            from ..inference.likelihood import Likelihood
            from .mixture import laplace_draws

            lik = Likelihood(prior_model, meas, noise=inp.noise)
            theta, why = laplace_draws(lik, fit, LAPLACE_DRAWS, rng)
            if theta is None:
                warns.append({"code": "mixture_component_failed", "model": model.label, "run": label,
                              "short": "no Gaussian approximation for the model mixture",
                              "message": f"{model.label} left out of the model mixture: {why}"})
                theta = point
        elif mode == "laplace":
            if fit.cov_z is None:
                raise DataFormatError(f"{meas.source}: the fit of {model.label} has no covariance (singular "
                                      "Jacobian): fast intervals are not available; drop fast")
            params = fit.model.params
            theta = None
            if inp.noise == "correlated":  # the Gaussian approximation of the correlated posterior
                from ..inference.likelihood import Likelihood
                from .mixture import laplace_draws

                theta, why = laplace_draws(Likelihood(prior_model, meas, noise="correlated"), fit,
                                           LAPLACE_DRAWS, rng)
                if theta is None:
                    warns.append({"code": "fast_white", "model": model.label, "run": label,
                                  "short": "fast intervals from the white fit's covariance",
                                  "message": f"no Gaussian approximation of the correlated posterior of "
                                             f"{model.label} ({why}): the fast intervals are the "
                                             "least-squares fit's, as if the model were exact"})
            if theta is None:
                theta = laplace_theta(params, params.to_z(fit.theta), fit.cov_z, LAPLACE_DRAWS, rng)
        else:
            cut = meter is not None and meter.cut
            post = sample_posterior(meas, prior_model, fit=held_fit(fit, meter) if cut else fit,
                                    seed=inp.seed, settings=inp.settings, progress=False, noise=inp.noise)
            if cut:
                post = cut_posterior(post, fit, meter, inp.seed)
            if not post.converged:
                warns.append({"code": "not_converged", "model": model.label, "run": label,
                              "short": f"the {label} posterior did not meet the stopping rule",
                              "message": f"the {label} posterior did not meet the stopping rule: "
                                         f"{post.message}"})
            theta = post.theta()
        if mode in ("posterior", "laplace") and label == "free air":  # the main model's curve only
            inp.curve = fit_curve(fit.model, theta, meas, fit.rms_rel_residual, inp.seed)
        und = undetermined(fit.model.params, fit.theta, fit.cov_z)
        rec = {"rms": fit.rms_rel_residual, "draws": mode != "point" and theta is not point,
               "undetermined": und, "log_z": float("nan")}
        if inp.evidence and und and method == "free_air" and mode in ("component", "point"):
            # a candidate whose parameters are not all determined carries no weight and ranks
            # below every determined one: its evidence is computed only if every candidate is so
            # (_resolve_deferred)
            rec["deferred_evidence"] = lambda: _single_evidence(meas, fit, prior_model, inp.noise)
        elif inp.evidence and inp.bounded and method == "free_air" and mode in ("component", "point"):
            # ranking the candidates: the evidence only where the likelihood's maximum leaves the
            # candidate a chance (_resolve_pending)
            rec["pending_evidence"] = lambda below: _bounded_evidence(meas, fit, prior_model, inp.noise,
                                                                      below)
        elif inp.evidence:
            rec["log_z"] = _single_evidence(meas, fit, prior_model, inp.noise)
        return fit.model, theta, point, rec

    if method == "free_air":
        bound, theta, point, rec = single(inp.meas, "free air")
        return (_complete(free_air(bound, theta), bound, theta, inp),
                _complete(free_air(bound, point), bound, point, inp), {"model": model.label, **rec})
    if method == "added_mass":
        runs = [inp.meas] + [m for m, _ in inp.loaded]
        deltas = [d for _, d in inp.loaded]
        mfit = fit_multi_mass(runs, deltas, model, re=inp.re)
        jm = mfit.joint
        re = mfit.re or {}
        if "conflict_sd" in re:
            w = conflict_warning(model.label, re["R0_data"], re["R0_data_sd"], meter, re["conflict_sd"])
            if w is not None:
                warns.append({**w, "model": model.label, "run": "free air"})
        if mfit.consistency["p_value"] < 1e-3:
            warns.append({"code": "runs_inconsistent", "model": model.label,
                          "short": f"the recordings disagree (F = {mfit.consistency['F']:.3g}): Mms, Bl "
                                   "intervals are lower bounds",
                          "message": f"the {len(runs)} recordings do not share one set of parameters within "
                                     f"their scatter (F = {mfit.consistency['F']:.3g}, p = "
                                     f"{mfit.consistency['p_value']:.2g}): Mms and Bl carry that mismatch; "
                                     "treat their intervals as lower bounds"})
        if mode == "point" or (mode == "component" and inp.noise != "white"):
            # (a joint component would be the white fit's Gaussian: the point values only)
            x = mfit.theta[None, :]
        elif mode == "component":  # a mixture component: the joint fit's Gaussian approximation
            x = mfit.theta[None, :]
            cov = mfit.cov_z
            why = ("the joint fit has no covariance" if cov is None or not np.all(np.isfinite(cov))
                   else "the joint fit's covariance is not positive semi-definite"
                   if np.linalg.eigvalsh(0.5 * (cov + cov.T))[0] < -1e-9 * np.abs(np.diag(cov)).max()
                   else "")
            if why:
                warns.append({"code": "mixture_component_failed", "model": model.label, "run": "joint",
                              "short": "no Gaussian approximation for the model mixture",
                              "message": f"{model.label} left out of the model mixture: {why}"})
            else:
                x = laplace_theta(jm.params, jm.params.to_z(mfit.theta), 0.5 * (cov + cov.T), LAPLACE_DRAWS,
                                  rng)
        elif mode == "laplace":
            if mfit.cov_z is None:
                raise DataFormatError(f"the joint fit of {model.label} has no covariance: drop fast")
            x = laplace_theta(jm.params, jm.params.to_z(mfit.theta), mfit.cov_z, LAPLACE_DRAWS, rng)
        else:
            pm = MultiMassModel(prior_model, jm.deltas).model
            x, info = sample_multi_mass(runs, deltas, pm, fit=mfit, seed=inp.seed, settings=inp.settings,
                                        meter=meter, noise=inp.noise)
            if not info["converged"]:
                warns.append({"code": "not_converged", "model": model.label,
                              "short": "the joint posterior did not meet the stopping rule",
                              "message": "the joint posterior did not meet the stopping rule: "
                                         f"{info['message']}"})
        if mode in ("posterior", "laplace"):  # the main model's curve only
            inp.curve = fit_curve(model, jm.thetas(x)[0], inp.meas, float(mfit.rms_rel_residual[0]), inp.seed)
        out = []
        for xx in (x, mfit.theta[None, :]):
            theta = jm.thetas(xx)[0]
            out.append(_complete(free_air(model, theta), model, theta, inp, mms=xx[:, 0]))
        rec = {"model": model.label, "rms": float(np.sqrt(np.mean(np.square(mfit.rms_rel_residual)))),
               "draws": x.shape[0] > 1,
               "undetermined": undetermined(jm.params, mfit.theta, mfit.cov_z),
               "log_z": _joint_evidence(runs, mfit, prior_model, inp.noise) if inp.evidence else float("nan")}
        return out[0], out[1], rec
    # added volume
    bound, theta, point, rec_b = single(inp.meas, "free air")
    box_meas, vb = inp.box
    bbound, theta_c, point_c, rec_c = single(box_meas, "box")
    n = min(len(theta), len(theta_c))
    if mode != "point":
        theta = theta[rng.permutation(len(theta))[:n]]
        theta_c = theta_c[rng.permutation(len(theta_c))[:n]]
    rec = {"model": model.label, "rms": float(np.sqrt((rec_b["rms"] ** 2 + rec_c["rms"] ** 2) / 2)),
           "undetermined": sorted(set(rec_b["undetermined"]) | set(rec_c["undetermined"])),
           "log_z": rec_b["log_z"] + rec_c["log_z"]}
    return (_volume(bound, bbound, theta, theta_c, vb, inp, warns, model),
            _volume(bound, bbound, point, point_c, vb, inp, [], model), rec)


def _volume(bound, bbound, theta, theta_c, vb, inp, warns, model):
    """T/S of the added-volume method from paired free-air and box draws."""
    ts = free_air(bound, theta)
    tc = free_air(bbound, theta_c)
    vas = vb * (tc["fs"] * tc["Qes"] / (ts["fs"] * ts["Qes"]) - 1.0)
    if np.median(vas) <= 0:
        warns.append({"code": "box_no_stiffer", "model": model.label,
                      "short": "box resonance not above free air's: Vas not positive",
                      "message": "the box recording's resonance is not above free air's: Vas from the "
                                 "added-volume formula is not positive (is the box sealed, is Vb right?)"})
    if inp.sd is not None:
        cms = vas / (inp.rho * inp.c**2 * inp.sd**2)
        mms = 1.0 / ((2 * math.pi * ts["fs"]) ** 2 * cms)
        ts = with_sd(with_mass(ts, bound, theta, mms), inp.sd, inp.rho, inp.c)
    else:
        ts = {**ts, "Vas": vas}
    return ts


def _with_auto_terms(label: str) -> list[Model]:
    """The coil model ``label`` with each of :data:`AUTO_TERMS` (none when it holds a term already)."""
    return [] if "+" in label else [parse_model_spec(f"{label}+{t}") for t in AUTO_TERMS]


def _terms_on_best_coils(records) -> list[Model]:
    """:func:`_with_auto_terms` of the coil models (no physics term) the terms are tried on: the best
    by :func:`~.spread.rank_key`, and every determined one whose evidence could not be computed
    (non-finite) that fits better than it. A failed evidence is no evidence against a model: on a
    simulated NL(3)+creep driver with an added mass, NL(3)'s joint Laplace evidence failed (Hessian
    not positive definite, the fallback's importance sampling unconfirmed), UD+creep won with weight
    1 and Re was 4.9 % off, while NL(3)+creep's evidence was 1455 nats higher."""
    coils = [r for r in records if "+" not in r["model"]]
    if not coils:
        return []
    best = max(coils, key=rank_key)
    out = [best["model"]] + [r["model"] for r in coils
                             if r is not best and not r["undetermined"] and not math.isfinite(r["log_z"])
                             and "log_z_upper" not in r and r["rms"] < best["rms"]]
    return [m for label in out for m in _with_auto_terms(label)]


def _fit_candidates(models, method, inp, cand_mode, warns, comps, rank: bool = True) -> list[str]:
    """Fit (and, for the mixture, approximate) each of ``models`` into ``comps[label] = (draws,
    point values, record)``; a candidate that fails is reported in ``warns``. Returns the labels of
    ``comps`` ranked by :func:`~.spread.rank_key`, best first (``rank``: with the deferred
    evidences of undetermined candidates computed when no candidate is determined)."""
    for cand in models:
        if cand.label in comps:
            continue
        cw: list[dict] = []
        try:
            comps[cand.label] = _estimate(cand, method, inp, cand_mode, cw)
        except Exception as exc:  # noqa: BLE001 - a candidate that cannot be fitted is reported, not fatal
            warns.append({"code": "spread_model_failed", "model": cand.label,
                          "short": "could not be fitted for the model spread",
                          "message": f"candidate {cand.label} for the model spread could not be "
                                     f"fitted: {exc}"})
            continue
        warns.extend(w for w in cw if w["code"] == "mixture_component_failed")
    _resolve_pending(comps)
    if rank:
        _resolve_deferred(comps)
    return sorted(comps, key=lambda m: rank_key(comps[m][2]), reverse=True)


def _resolve_pending(comps: dict) -> None:
    """The evidences of the determined candidates fitted while ranking (``pending_evidence`` of
    :func:`_estimate`), best fit (least rms) first. Where the Laplace screen fails, the subspace
    fallback is run only when the likelihood's maximum (at the posterior mode, the priors being
    uniform in sampling space) is within :data:`EVIDENCE_SKIP_NATS` of the best evidence computed
    so far: below it the candidate's posterior model probability is under ``exp(-25)`` whatever its
    evidence, and its record holds ``log_z`` nan and ``log_z_upper``, that maximum (on a 260-point
    woofer recording the fallbacks of II and III, of weight below 1e-200, took 0.12 of 3.0 CPU s)."""
    pend = sorted((c[2] for c in comps.values() if "pending_evidence" in c[2]), key=lambda r: r["rms"])
    leader = max((c[2]["log_z"] for c in comps.values()
                  if not c[2]["undetermined"] and math.isfinite(c[2]["log_z"])), default=-math.inf)
    for r in pend:
        get = r.pop("pending_evidence")
        r["log_z"], upper = get(leader - EVIDENCE_SKIP_NATS if math.isfinite(leader) else None)
        if upper is not None:
            r["log_z_upper"] = upper
        elif math.isfinite(r["log_z"]):
            leader = max(leader, r["log_z"])


def _resolve_deferred(comps: dict) -> None:
    """The evidence of the undetermined candidates (deferred by ``_estimate``) when no candidate is
    determined: the ranking (:func:`~.spread.rank_key`) then compares them by it."""
    if any(not c[2]["undetermined"] for c in comps.values()):
        return
    for c in comps.values():
        get = c[2].pop("deferred_evidence", None)
        if get is not None:
            c[2]["log_z"] = get()


def evidence_supported_model(meas: Measurement, *, noise: str = "white",
                             candidates: Sequence | None = None) -> tuple[Model, dict[str, float]]:
    """The model the evidence supports for one recording: the most probable (Laplace evidence under
    the ``noise`` likelihood, equal prior odds, parameters determined) of ``candidates`` (default
    :data:`AUTO_CANDIDATES`) and of the best of them with each of :data:`AUTO_TERMS`. Returns the
    model and every candidate's posterior probability (``nan``-evidence candidates left out)."""
    from .mixture import mixture_weights

    inp = _Inputs(meas, [], None, None, None, None, None, 1.18, 343.0, 0, None, noise=noise)
    comps: dict[str, tuple] = {}
    warns: list[dict] = []
    pool = [parse_model_spec(m) if isinstance(m, str) else m for m in (candidates or AUTO_CANDIDATES)]
    inp.bounded = True
    ranked = _fit_candidates(pool, "free_air", inp, "point", warns, comps)
    if not ranked:
        raise DataFormatError(f"{meas.source}: none of the candidate models could be fitted")
    _fit_candidates(_terms_on_best_coils([c[2] for c in comps.values()]), "free_air", inp, "point", warns,
                    comps)
    best = max(comps, key=lambda m: rank_key(comps[m][2]))
    det = {m: c[2] for m, c in comps.items() if not c[2]["undetermined"]}
    # a candidate whose likelihood's maximum is far below the best evidence: probability below 1e-10
    probs = mixture_weights({m: r["log_z"] for m, r in det.items()},
                            bounded={m for m, r in det.items() if "log_z_upper" in r})
    return parse_model_spec(best), probs


def thiele_small(data, model=None, *, loaded: Sequence[tuple] = (), box: tuple | None = None,
                 sd: float | None = None, re=None, mms: float | None = None, bl: float | None = None,
                 air_density: float = 1.18, sound_speed: float = 343.0, fast: bool = False, seed: int = 0,
                 models_for_spread: Sequence | None = None, f_range_hz: tuple | None = None,
                 exclude_band: Sequence | None = None,
                 read_options: dict | None = None, settings=None, noise: str = "white",
                 intervals: str = "total", plateau: bool = True) -> ThieleSmall:
    """Thiele–Small parameters with 90 % intervals and model spread (module docstring).

    Parameters
    ----------
    data : the free-air recording (a :class:`~bayes_emt.measurement.Measurement` or a file path).
    model : model spec or :class:`~bayes_emt.models.Model`; ``None`` (default) or ``"auto"``: the
        model the evidence supports among :data:`AUTO_CANDIDATES` and :data:`AUTO_TERMS` on the most
        probable of them (``models_for_spread`` replaces the candidate list).
    loaded : ``[(recording, delta_m_kg), ...]``: added-mass recordings (method ``added_mass``).
    box : ``(recording, volume_m3)``: a sealed test box of known net volume (``added_volume``).
    sd : effective cone area Sd [m²] (Vas, η0, SPL; needed by ``added_volume`` for Cms, Mms, Bl).
        Every quantity here (masses, volume, Sd, mms, bl, air) may instead be a string with a unit,
        ``"85cm2"``, ``"8.017g"``, ``"20L"`` (:mod:`bayes_emt.units`); a bare number is SI.
    re : ohmmeter reading of the DC resistance: ohms (1 % sd), ``(ohms, sd)`` or ``(ohms, sd, mode)``
        with mode ``"cut"`` (default) or ``"prior"`` (:mod:`bayes_emt.estimation.meter`).
    mms, bl : a known moving mass [kg] or force factor [T m] (free air only; not both).
    air_density, sound_speed : ρ [kg/m³] and c [m/s].
    fast : intervals from the fit's Gaussian approximation instead of the posterior.
    seed : seed of the sampler (and of the fast draws).
    models_for_spread : candidate model specs for ``model_spread`` (default II, III, UD with the
        main model's physics terms; ``[]``: none).
    f_range_hz : ``(f_min, f_max)`` [Hz] band used from every recording (``None``: all).
    exclude_band : ``[(f1_hz, f2_hz), ...]``: points left out of every recording
        (:meth:`~bayes_emt.measurement.Measurement.exclude_bands`: a cone break-up, a surround dip).
    read_options : keyword arguments of :func:`~bayes_emt.io.read_measurement` for file paths.
    settings : :class:`~bayes_emt.inference.sampling.SamplerSettings` (default the T/S budget).
    noise : ``"white"`` (default: independent errors, the intervals if the model were exact; the
        evidence-weighted model mixture carries the model-form uncertainty) or ``"correlated"``
        (instrument noise plus a model discrepancy correlated over log-frequency,
        :mod:`bayes_emt.inference.discrepancy`; slower, and on the truth corpus no better covered).
    intervals : ``"total"`` (default): ``ci90`` includes the definitional uncertainty, the spread
        between the model and Small's model-free method (and, for Re, the plateau reading and the
        fit's R0) (:mod:`.definitional`), Small's own bias on the model's curve counted only when the
        main model's free-air residual is structured (otherwise as ``"misfit"``); ``"misfit"``: only
        the part of that spread the model's own curve does not explain; ``"model"``: the model
        mixture's posterior alone, the intervals if the model were exact (``ci90_model`` of the
        others).
    plateau : read Re off the recording's low-frequency plateau when the reader kept one (a bench
        that sweeps from ~1 Hz; :mod:`.plateau`) and no ``re`` is given: Small's model-free column
        uses it, and it is the second method for Re's definitional uncertainty (the fit's R0 stays
        the model's, fitted).

    Returns
    -------
    ThieleSmall
    """
    from ..units import as_si

    # quantities may carry a unit ("85cm2", "8.017g", "20L"); a bare number is SI
    sd, mms = as_si(sd, "area", "sd"), as_si(mms, "mass", "mms")
    bl = as_si(bl, "force_factor", "bl")
    air_density = as_si(air_density, "density", "air_density")
    sound_speed = as_si(sound_speed, "speed", "sound_speed")
    loaded = [(item[0], as_si(item[1], "mass", f"loaded[{i}] delta_m"))
              if isinstance(item, tuple | list) and len(item) == 2 else item for i, item in enumerate(loaded)]
    if box is not None and isinstance(box, tuple | list) and len(box) == 2:
        box = (box[0], as_si(box[1], "volume", "box volume"))
    if exclude_band:
        exclude_band = [tuple(as_si(x, "frequency", "exclude_band", bare="Hz") for x in b)
                        for b in exclude_band]
    if mms is not None and bl is not None:
        raise ValueError("give a known mms or a known bl, not both")
    if loaded and box is not None:
        raise ValueError("give added masses (loaded) or a test box (box), not both: one method at a time")
    if (loaded or box is not None) and (mms is not None or bl is not None):
        raise ValueError("a known mms or bl is for free air only; added mass or volume measure them")
    for name, v in (("sd", sd), ("mms", mms), ("bl", bl), ("air_density", air_density),
                    ("sound_speed", sound_speed)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive number, got {v!r}")
    if intervals not in ("total", "misfit", "model"):
        raise ValueError(f"intervals must be 'total', 'misfit' or 'model', got {intervals!r}")
    re_t = as_meter(re)
    main = _model(model)
    check_inputs(sd=sd, mms=mms, bl=bl, box_volume=None if box is None else _volume_of(box),
                 deltas=[float(it[1]) for it in loaded
                         if isinstance(it, tuple | list) and len(it) == 2 and isinstance(it[1], int | float)])
    meas = _measurement(data, "data", read_options, f_range_hz, exclude_band)
    lm = []
    for i, item in enumerate(loaded):
        try:
            rec, dm = item
        except (TypeError, ValueError):
            raise ValueError(f"loaded[{i}] must be (recording, delta_m_kg), got {item!r}") from None
        if not (math.isfinite(float(dm)) and float(dm) != 0):
            raise ValueError(f"loaded[{i}]: the added mass must be a non-zero number of kg, got {dm!r}")
        lm.append((_measurement(rec, f"loaded[{i}]", read_options, f_range_hz, exclude_band), float(dm)))
    bx = None
    if box is not None:
        try:
            rec, vb = box
        except (TypeError, ValueError):
            raise ValueError(f"box must be (recording, volume_m3), got {box!r}") from None
        if not (math.isfinite(float(vb)) and float(vb) > 0):
            raise ValueError(f"box volume must be a positive number of m^3, got {vb!r}")
        bx = (_measurement(rec, "box", read_options, f_range_hz, exclude_band), float(vb))
    method = "added_mass" if lm else "added_volume" if bx else "free_air"
    plat = None
    fits: dict = {}
    if plateau and re_t is None and meas.meta.get("low_band"):
        plat = _plateau(meas, main, fits)
    if noise not in ("correlated", "white"):
        raise ValueError(f"noise must be 'correlated' or 'white', got {noise!r}")
    inp = _Inputs(meas, lm, bx, sd, re_t, mms, bl, float(air_density), float(sound_speed), int(seed),
                  settings if settings is not None else _ts_sampler(), noise=noise, fits=fits)
    warns: list[dict] = []
    mode = "laplace" if fast else "posterior"
    # a mixture component per candidate (free air, added masses; not with fast), else its point values only
    cand_mode = "component" if method in ("free_air", "added_mass") and not fast else "point"
    auto = main is None
    comps: dict[str, tuple] = {}
    if auto:  # the model the evidence supports: rank the candidates first, sample the most probable
        pool = [parse_model_spec(m) for m in (models_for_spread or AUTO_CANDIDATES)]
        inp.evidence = True
        inp.bounded = True  # an evidence only where the likelihood leaves the candidate a chance
        ranked = _fit_candidates(pool, method, inp, cand_mode, warns, comps)
        if not ranked:
            names = ", ".join(m.label for m in pool)
            raise DataFormatError(f"{meas.source}: none of the candidate models {names} could be fitted")
        _fit_candidates(_terms_on_best_coils([c[2] for c in comps.values()]), method, inp, cand_mode, warns,
                        comps)
        inp.bounded = False
        main = parse_model_spec(max(comps, key=lambda m: rank_key(comps[m][2])))
        candidates = [parse_model_spec(m) for m in comps if m != main.label]
    else:
        candidates = spread_models(main, models_for_spread, _model, AUTO_TERMS)
        inp.evidence = bool(candidates)
    inp.evidence = inp.evidence and not auto  # auto: the main model's evidence is already known
    draws, point_main, rec_main = _estimate(main, method, inp, mode, warns)
    inp.evidence = True

    # model spread: point values of the adequate, determined, probable candidates (module docstring)
    records, points, comp_draws = [rec_main], {rec_main["model"]: point_main}, {rec_main["model"]: draws}
    if auto:
        rec_main["log_z"] = comps[main.label][2]["log_z"]
    pending, extend = list(candidates), not auto and models_for_spread is None
    while pending:
        cand = pending.pop(0)
        if cand.label not in comps:  # a spread candidate: its rank is not needed
            _fit_candidates([cand], method, inp, cand_mode, warns, comps, rank=False)
        if cand.label in comps:
            cd, pv, rec = comps[cand.label]
            records.append(rec)
            points[rec["model"]] = pv
            if rec.get("draws"):
                comp_draws[rec["model"]] = cd
        if not pending and extend:  # as the default does: the physics terms on the best coil models too
            extend = False
            tried = {r["model"] for r in records}  # the main model's own are among the candidates already
            pending = [m for m in _terms_on_best_coils(records) if m.label not in tried]
    records = select_spread_models(records)
    included = [points[r["model"]] for r in records if r["included"]]
    # the mixture: the main model's posterior and the determined candidates' components, by evidence
    lz = {r["model"]: r["log_z"] for r in records
          if r["model"] in comp_draws and (r["determined"] or r is records[0])}
    # a candidate whose evidence is bounded far below the leader's (_resolve_pending) weighs 0
    weights = mixture_weights(lz, bounded={r["model"] for r in records if "log_z_upper" in r})
    if main.label not in weights:
        weights = {main.label: 1.0}
    if not included:  # no candidate is adequate and determined (the best fit left a parameter
        # undetermined): the spread is over the models the mixture weighs, never empty
        for r in records:
            if weights.get(r["model"], 0.0) >= SPREAD_MIN_PROBABILITY:
                r["included"] = True
                included.append(points[r["model"]])
    def prob(r):  # the mixture's weight, else the spread's evidence probability
        return weights.get(r["model"], r["probability"] if r["probability"] is not None else 0.0)

    better = [r for r in records[1:] if prob(r) >= 0.5]
    if better:
        b = better[0]
        pb = prob(b)
        warns.append({"code": "better_model", "short": f"{b['model']} is more probable than {main.label} "
                      f"(P = {pb:.3g}): the intervals are the model mixture's; {main.label} alone under "
                      "model_only", "message": f"the candidate {b['model']} explains the data better than "
                      f"{main.label}: posterior model probability {pb:.3g} (Laplace evidence, equal prior "
                      f"odds, {_NOISE_SHORT[noise]}); value and ci90 are the evidence-weighted mixture over "
                      f"{', '.join(weights)} (the model spread shows the probable candidates' values), and "
                      f"{main.label}'s own values are under model_only; "
                      "--model " + b["model"] + " samples that model"})

    params, pooled = {}, {}
    for name in NAMES:
        if name not in draws:
            continue
        v = np.asarray(draws[name], float)
        v = v[np.isfinite(v)]
        if v.size == 0:
            continue
        lo, med, hi = np.quantile(v, [0.05, 0.5, 0.95])
        vals = [float(np.asarray(pv[name]).ravel()[0]) for pv in included if name in pv]
        vals = [x for x in vals if math.isfinite(x)]
        mv, mw = [], []
        for m, w in weights.items():
            x = np.asarray(comp_draws[m].get(name, np.nan), float).ravel()
            if x.size and np.any(np.isfinite(x)):
                mv.append(x)
                mw.append(np.full(x.size, w / x.size))
        pooled[name] = (np.concatenate(mv), np.concatenate(mw)) if len(mv) > 1 else (v, None)
        mlo, mmed, mhi = (weighted_quantiles(*pooled[name], [0.05, 0.5, 0.95])
                          if len(mv) > 1 else (lo, med, hi))
        params[name] = {"value": float(mmed), "ci90": [float(mlo), float(mhi)], "unit": UNITS[name],
                        # never empty because a filter left no model: then the mixture's models
                        "model_spread": [min(vals), max(vals)] if vals else None,
                        "model_only": {"model": main.label, "value": float(med),
                                       "ci90": [float(lo), float(hi)]}}
    warns += check_result(params, method=method, sd=sd, mms=mms, bl=bl, deltas=[d for _, d in lm])
    warns += setup_warnings(meas, None if bx is None else bx[0])
    if not meas.phase_absent and "fs" in params:  # is the phase the minimum-phase partner of |Z|?
        from .bode import phase_departure_note

        warns += phase_departure_note(inp.curve, params["fs"]["value"])
    if fast:
        how = ("the Gaussian (Laplace) approximation of the posterior at its mode"
               if noise == "correlated" and method == "free_air"
               else "the least-squares fit's Gaussian approximation (its covariance)")
        warns.append({"code": "fast_intervals", "short": "intervals from a Gaussian approximation (--fast), "
                      "not the posterior", "message": f"intervals from {how}, delta method by 4000 draws, "
                      "not from the posterior: they can be too narrow where the posterior is skewed or the "
                      "fit is poor"})
    if "lambda_creep" in main.names:
        warns.append({"code": "creep_convention", "short": "fs, Qms by the LOG-creep convention (fs at zero "
                      "mechanical reactance); see the JSON",
                      "message": "suspension creep: fs is where the mechanical reactance vanishes and Qms "
                      "includes the creep loss at fs (Knudsen & Jensen LOG model, as Klippel LPM and "
                      "Speakerbench report them); zeta and omega0 stay model parameters; "
                      "Qms_viscous is the viscous part alone"})
    if meas.phase_absent:
        from ..io.phase import PHASE_ABSENT_NOTE

        warns.append({"code": "phase_absent", "short": "no phase: fitted on log|Z| alone (see the JSON)",
                      "message": PHASE_ABSENT_NOTE})
    inputs = {"data": meas.source, "f_range_hz": [float(meas.f_hz[0]), float(meas.f_hz[-1])],
              "phase": "absent" if meas.phase_absent else "measured",
              "exclude_band_hz": [[float(a), float(b)] for a, b in (exclude_band or ())],
              "loaded": [{"data": m.source, "delta_m_kg": d} for m, d in lm],
              "box": None if bx is None else {"data": bx[0].source, "volume_m3": bx[1]},
              "sd_m2": sd,
              "re": None if re_t is None else {"ohm": re_t.value, "sd_ohm": re_t.sd, "mode": re_t.mode},
              "plateau": None if plat is None else plat.to_json_dict(),
              "mms_kg": mms, "bl_tm": bl, "air_density_kg_m3": inp.rho, "sound_speed_m_s": inp.c,
              "uncertainty": "laplace" if fast else "posterior", "seed": int(seed),
              "noise": noise, "noise_model": NOISE_DESCRIPTION[noise],
              "model_spread_method": MODEL_SPREAD_METHOD,
              "model_choice": "evidence" if auto else "requested",
              "mixture": {"method": MIXTURE_METHOD if len(weights) > 1 else "the main model alone (no "
                          "other candidate has a component and an evidence)", "weights": weights},
              "model_spread": {
                  "candidates": [r["model"] for r in records],
                  "included": [r["model"] for r in records if r["included"]],
                  "no_evidence": [r["model"] for r in records if r["included"] and r["probability"] is None],
                  "models": [{"model": r["model"], "rms_rel_residual": r["rms"], "adequate": r["adequate"],
                              "undetermined": list(r["undetermined"]),
                              "log_evidence": r["log_z"] if math.isfinite(r["log_z"]) else None,
                              "log_evidence_upper_bound": r.get("log_z_upper"),
                              "probability": r["probability"], "included": r["included"],
                              "values": _point_values(points[r["model"]])}
                             for r in records]}}
    # the reference columns: Small's model-free values off the curve, the bench's own fit (references.py)
    from .references import bench_comparison, bench_model_free_notes, disagreements, model_free_record

    mf = model_free_record(meas, params, main.label, re_meter=re_t if plat is None else plat.meter,
                           loaded=lm, seed=int(seed), use_phase=meas.meta.get("phase") != "absent",
                           re_meter_source="ohmmeter reading" if plat is None else "low-frequency plateau")
    warns += disagreements(params, mf, spread_included=intervals == "total")
    warns += bench_model_free_notes(meas, mf, meas.meta.get("bench_fit"), seed=int(seed),
                                    use_phase=meas.meta.get("phase") != "absent")
    if plat is not None:
        warns.append(plateau_note(plat))
    inputs["intervals"] = intervals
    if intervals in ("total", "misfit"):
        small = small_on_curve(inp.curve, _mf_re(mf), use_phase=meas.meta.get("phase") != "absent",
                               seed=int(seed))
        mfp = (mf or {}).get("parameters") or {}
        shift = {n: (float(mfp[n]["value"]), half_width_sd(mfp[n].get("ci90")))
                 for n in ("Mms", "Cms", "Bl") if n in mfp and mfp[n].get("value") is not None}
        # Small's own bias on the model's curve is a spread of the measurand's definition only when
        # the model does not describe the driver (definitional.py): the fit's residual test decides
        structure = curve_residual_structure(inp.curve) if intervals == "total" else None
        corrected = intervals == "misfit" or (structure is not None and not structure["structured"])
        why = "" if structure is None else (
            f"the main model's residual is structured (runs test z = {structure['runs_z']:.1f}, up to "
            f"{structure['rho_max']:.3g} times the noise): the model does not define the quantity alone"
            if structure["structured"] else
            f"the main model describes the curve to its noise (runs test z = {structure['runs_z']:.1f}, at "
            f"most {structure['rho_max']:.3g} times the noise): Small's own bias on that curve is that "
            "method's error, not a spread of the quantity")
        warns += add_definitional(params, pooled, small, plat, int(seed), corrected=corrected,
                                  mass_shift=shift, why=why)
        inputs["intervals_method"] = DEFINITIONAL_METHOD
        inputs["intervals_residual"] = structure
    return ThieleSmall(model=main.label, method=method, parameters=params, inputs=inputs,
                       warnings=tuple(_dedupe(warns)), model_free=mf, curve=inp.curve,
                       bench_fit=bench_comparison(params, meas.meta.get("bench_fit")))


def _plateau(meas: Measurement, main: Model | None, fits: dict | None = None):
    """The low-frequency plateau's Re reading (:mod:`bayes_emt.estimation.plateau`) from a
    least-squares fit of ``main`` (UD when the model is chosen by evidence; the fit is kept in
    ``fits`` for the candidates, :func:`_fit`), or None (no rows below fs/8, or the fit failed)."""
    from ..estimation.plateau import plateau_reading

    model = main if main is not None else parse_model_spec("UD")
    try:
        fit = _fit(meas, model, None, fits)
        fs = float(np.asarray(free_air(fit.model, fit.theta[None, :])["fs"]).ravel()[0])
    except Exception:  # noqa: BLE001 - no reading then; the main fit reports its own failure
        return None
    return plateau_reading(meas, fit.model, fit.theta, fs)


def _mf_re(mf: dict) -> tuple[float, float]:
    """The Re ``(value, sd)`` [Ω] the model-free column used (from its record)."""
    q = (mf or {}).get("parameters", {}).get("Re")
    if not q:
        return (float("nan"), 0.0)
    return float(q["value"]), half_width_sd(q.get("ci90"))


def _point_values(ts: dict) -> dict:
    """A candidate's T/S values at its least-squares point (SI; finite ones only)."""
    out = {}
    for name in NAMES:
        if name in ts:
            v = float(np.asarray(ts[name], float).ravel()[0])
            if math.isfinite(v):
                out[name] = v
    return out


def _dedupe(warns: list[dict]) -> list[dict]:
    """One record per (code, message) with the models it concerns merged into ``models``."""
    out: dict[tuple, dict] = {}
    for w in warns:
        key = (w["code"], w["message"])
        if key in out:
            if w.get("model") and w["model"] not in out[key]["models"]:
                out[key]["models"].append(w["model"])
            continue
        rec = {k: v for k, v in w.items() if k != "model"}
        rec["models"] = [w["model"]] if w.get("model") else []
        out[key] = rec
    return list(out.values())
