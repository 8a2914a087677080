"""Shunt design under uncertainty: posterior draws through the H∞ design, the nominal design on
every draw, and one robust RC shunt with a bounded probability of instability.

Given draws of one model's posterior, or an evidence-weighted mixture of several models'
(:mod:`bayes_emt.shunt.draws`):

1. **Per draw** the H∞-optimal ``(Rs, Cs)`` and its attenuation (batched Newton on the equal-peak
   conditions, :mod:`bayes_emt.shunt.batch.design`): their distributions.
2. **Nominal**: :func:`~bayes_emt.shunt.design_rc_shunt` at a point estimate (the posterior
   median of the heaviest model, or a fit), evaluated on every draw: attenuation [dB] and stability
   (threshold per draw, :mod:`bayes_emt.shunt.batch.plant`).
3. **Robust**: one ``(Rs, Cs)`` minimising a risk measure of the attenuation over the design half
   of the draws subject to ``P(unstable) ≤ ε`` (:mod:`bayes_emt.shunt.saa`).
4. **Report on the held-back half** (draws the choice never saw): attenuation median and 90 %
   interval, ``P(unstable)`` with an exact Clopper–Pearson interval (draw count scaled by the
   posterior's ESS fraction when below one), the risk, the regret against each draw's own optimum;
   stability margins in Ω and the R0 at which each draw would go unstable; Spearman rank
   correlations of parameters with Rs, Cs and the attenuation; and in words why the robust Rs moved.

The stability margin ``Rs − Rs_instability`` is also the amount R0 may drift *down*: R0 enters the
terminal impedance additively and does not move the frequencies where the loop reactance vanishes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .._json import strict_json
from ..models import Model
from .batch.design import cs_bound, design_draws
from .batch.peaks import rc_peaks_batch
from .batch.plant import SPAN, BatchPlant, SampledShunt
from .bound import instability_bound
from .design import design_rc_shunt, evaluate_rc_shunt
from .draws import DrawGroup, split_halves
from .qfactor import resonance_q
from .receptance import rc_impedance, receptance
from .report import describe_r0, exact_checks, explain_move, sensitivity
from .risk import RISKS, RiskKind, clopper_pearson, quantiles, risk_value, summary
from .saa import DrawPool, choose_robust
from .safety import check_margin, r0_uncertainty

__all__ = ["ShuntOnDraws", "RobustShunt", "design_robust_shunt"]


@dataclass(frozen=True, eq=False)
class ShuntOnDraws:
    """One RC shunt evaluated on every draw (pooled order: group after group).

    Attributes
    ----------
    name : ``"nominal"`` or ``"robust"``. Rs, Cs : [Ω], [F].
    attenuation : ``(n,)`` [dB], +inf where unstable. margin : ``(n,)`` ``Rs − threshold`` [Ω].
    stable : ``(n,)``. source : where the shunt came from (one line).
    resonance : ``(reduction [dB], frequency [Hz])`` ``(n,)`` each of the resonance peak (the largest
        peak other than the design band's low edge; reduction re the open-terminal peak).
    """

    name: str
    Rs: float
    Cs: float
    attenuation: np.ndarray
    margin: np.ndarray
    stable: np.ndarray
    source: str = ""
    resonance: tuple = ()


@dataclass(frozen=True, eq=False)
class RobustShunt:
    """Result of :func:`design_robust_shunt` (module docstring); :meth:`to_json_dict` is the
    ``bayes-emt shunt --posterior`` JSON.

    Attributes
    ----------
    groups : the draws, one :class:`DrawGroup` per model. group : ``(n,)`` group of each pooled draw.
    held : ``(n,)`` True for held-back draws (the report's), False for the design half.
    nominal, robust : :class:`ShuntOnDraws`.
    optimum_Rs, optimum_Cs, optimum_attenuation : ``(n,)`` each draw's own H∞ optimum [Ω, F, dB].
    optimum_fallback : ``(n,)`` draws designed by :func:`design_rc_shunt` instead of the batch.
    risk, alpha, epsilon, confidence, seed : the settings. report : the JSON-ready summary.
    boundary : ``{"Cs": (m,), "<label>": {"median": (m,), "max": (m,)}}`` thresholds [Ω] over a Cs
        grid [F] (for the stability-boundary plot; empty when not asked for).
    warnings : things that make a number less trustworthy than it looks.
    """

    groups: tuple
    group: np.ndarray
    held: np.ndarray
    nominal: ShuntOnDraws
    robust: ShuntOnDraws
    optimum_Rs: np.ndarray
    optimum_Cs: np.ndarray
    optimum_attenuation: np.ndarray
    optimum_fallback: np.ndarray
    risk: str
    alpha: float
    epsilon: float
    confidence: float
    seed: int
    report: dict = field(default_factory=dict)
    boundary: dict = field(default_factory=dict)
    warnings: tuple = ()

    def to_json_dict(self) -> dict:
        return {**self.report, "warnings": list(self.warnings)}


def refuse_undefined(model: Model, theta, where: str = "") -> None:
    """Raise a one-line ``ValueError`` when the shunt problem is not defined for ``model`` at
    ``theta``: no mechanical resonance (damping ratio ζ ≥ 1/√2: the open-terminal receptance has no
    peak for a shunt to lower) or no finite resonance frequency."""
    zeta, omega0, _ = (float(v) for v in model.mechanics(np.asarray(theta, float)))
    at = f" ({where})" if where else ""
    if not (math.isfinite(omega0) and omega0 > 0):
        raise ValueError(f"model {model.label}{at}: no mechanical resonance (omega0 = {omega0:.4g} rad/s), "
                         "so there is no peak for a shunt to damp")
    if not zeta < 1 / math.sqrt(2):
        raise ValueError(f"model {model.label}{at}: damping ratio {zeta:.3g} >= 1/sqrt(2), the open-terminal "
                         "receptance has no resonant peak, so there is nothing for a shunt to damp")


def _ticker(progress, what: str, every: float = 2.0):
    """``callable(done, total)`` passing ``"what: done/total"`` to ``progress`` at most every
    ``every`` seconds (and at the end); None without ``progress``."""
    if progress is None:
        return None
    last = [time.perf_counter()]

    def tick(done, total):
        now = time.perf_counter()
        if now - last[0] >= every or done == total:
            last[0] = now
            progress(f"{what}: {done}" + ("" if total is None else f"/{total}"))

    return tick


def _margin_summary(m) -> dict:
    q = quantiles(m, [0.05, 0.5])
    return {"min": float(np.min(m)), "q05": float(q[0]), "median": float(q[1])}


def _on_draws(plants, name, Rs, Cs, source) -> ShuntOnDraws:
    pool = DrawPool([(bp, np.arange(bp.n)) for bp in plants])
    ev = pool.evaluate(Rs, Cs)
    return ShuntOnDraws(name, float(Rs), float(Cs), ev.attenuation, ev.margin, ev.stable, source,
                        _resonance(plants, Rs, Cs))


def _resonance(plants, Rs, Cs):
    """``(reduction [dB], frequency [Hz])`` per draw of the resonance peak: the largest peak of
    ``|m·G|`` within ``f0/3 .. 40 f0`` (a negative-resistance shunt moves a loudspeaker's resonance
    up to 6.5 f0: SB Acoustics MW13TX midrange; below f0/3 lie the shunt's electrical resonances), re
    the open-terminal peak (a loudspeaker's figure: how much the shunt lowers its resonance, and where
    the resonance went). Where no peak is left there (the resonance damped away) the reduction is
    that of the largest response within ``f0/3 .. 40 f0`` (on a grid of 800 log-spaced points) and
    the frequency NaN."""
    red, freq = [], []
    for bp in plants:
        pb = rc_peaks_batch(bp, Rs, Cs, wide=False)
        v = pb.value.copy()
        v[:, -1] = np.nan  # the band-edge slot
        near = (pb.omega > bp.omega0[:, None] / 3) & (pb.omega < SPAN * bp.omega0[:, None])
        v = np.where(np.isfinite(v) & near, v, -np.inf)  # a peak within f0/3 .. 40 f0 (else: none left)
        k = np.argmax(v, axis=1)
        top = v[np.arange(bp.n), k]
        flat = np.flatnonzero(~np.isfinite(top))
        if flat.size:
            w0 = bp.omega0[flat]
            w = np.geomspace(w0.min() / 3, w0.max() * SPAN, 800)
            g = np.abs(receptance(bp.model, bp.thetas[flat], w, lambda s: rc_impedance(s, Rs, Cs)))
            inside = (w[None, :] >= w0[:, None] / 3) & (w[None, :] <= SPAN * w0[:, None])
            top = top.copy()
            top[flat] = np.max(np.where(inside, g, 0.0), axis=1)
        red.append(-20 * np.log10(np.maximum(top, 1e-300) / bp.open_peak))
        freq.append(np.where(np.isfinite(v[np.arange(bp.n), k]), pb.omega[np.arange(bp.n), k] / (2 * math.pi),
                             np.nan))
    return np.concatenate(red), np.concatenate(freq)


def _design_report(on: ShuntOnDraws, res_parts, risk, alpha, confidence, eff) -> dict:
    held, group, labels, opt_att, design = res_parts
    a = on.attenuation[held]
    k, n = int(np.count_nonzero(~on.stable[held])), int(np.count_nonzero(held))
    lo, hi = clopper_pearson(k * eff, n * eff, confidence)
    per_model = {}
    for g, label in enumerate(labels):
        sel = held & (group == g)
        if not sel.any():
            continue
        kg, ng = int(np.count_nonzero(~on.stable[sel])), int(np.count_nonzero(sel))
        per_model[label] = {"attenuation_db": summary(on.attenuation[sel]), "p_unstable": kg / ng,
                            "p_unstable_ci": list(clopper_pearson(kg * eff, ng * eff, confidence)),
                            "n_draws": ng, "margin_ohm": _margin_summary(on.margin[group == g])}
    return {"Rs": on.Rs, "Cs": on.Cs, "attenuation_db": summary(a), "p_unstable": k / n,
            "p_unstable_ci": [lo, hi], "n_unstable": k, "n_draws": n,
            "risk_db": risk_value(a, risk, alpha),
            "risk_design_half_db": risk_value(on.attenuation[~held & design], risk, alpha),
            "regret_db": summary(a - opt_att[held]),
            "margin_ohm": _margin_summary(on.margin), "per_model": per_model, "source": on.source,
            "resonance_peak_reduction_db": _finite_summary(on.resonance[0][held & on.stable]),
            "resonance_hz": _finite_summary(on.resonance[1][held & on.stable])}


def _q_report(groups, halves, on: ShuntOnDraws, held, group) -> dict:
    """The shunted resonance's Q (Qts', :mod:`bayes_emt.shunt.qfactor`) and frequency [Hz] over the
    stable held-back draws: ``{"qts_damped": summary, "damped_resonance_hz": summary}``."""
    qs, fs = [], []
    for gi, (g, (_, h)) in enumerate(zip(groups, halves, strict=True)):
        ok = on.stable[held & (group == gi)]
        q, f = resonance_q(g.model, g.thetas[h[ok]], (on.Rs, on.Cs))
        qs.append(q), fs.append(f)
    return {"qts_damped": _finite_summary(np.concatenate(qs)),
            "damped_resonance_hz": _finite_summary(np.concatenate(fs))}


def _driver_report(groups, halves) -> dict:
    """The driver without a shunt, over the held-back draws: Qts and its resonance [Hz] with a
    zero-impedance source (an amplifier), Qms (open terminals) and fs = ω0/2π [Hz]."""
    qts, fts, qms, fs = [], [], [], []
    for g, (_, h) in zip(groups, halves, strict=True):
        q, f = resonance_q(g.model, g.thetas[h])
        qts.append(q), fts.append(f)
        qms.append(resonance_q(g.model, g.thetas[h], open_terminals=True)[0])
        fs.append(np.asarray(g.model.mechanics(g.thetas[h])[1], float) / (2 * math.pi))
    cat = np.concatenate
    return {"qts": _finite_summary(cat(qts)), "resonance_hz": _finite_summary(cat(fts)),
            "qms": _finite_summary(cat(qms)), "fs_hz": _finite_summary(cat(fs)),
            "definition": "Q = w_r |d Re D/dw| / (2 Im D) at the resonance w_r where Re D falls through "
                          "zero, D = mech + phi^2 s/(Ze + Zx): Small's Qts for Zx = 0 and a resistive "
                          "coil; Qms with the terminals open"}


def _finite_summary(x) -> dict:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return summary(x) if x.size else {"median": None, "q05": None, "q95": None}


def _safety(groups, nom_model, nom_theta, nom, on_rob, ohmmeter, widened: bool = False) -> dict:
    """Each shunt's stability margin at the nominal point against the R0 uncertainty of the draws
    (:mod:`bayes_emt.shunt.safety`); ``widened``: the draws' R0 carry the spread to the plateau
    reading (:mod:`bayes_emt.shunt.r0_spread`), so their interval is the total one."""
    R0 = float(nom_theta[nom_model.params.index("R0")])
    pooled, medians = [], []
    for g in groups:
        if "R0" in g.model.params.names and g.n:
            r = g.thetas[:, g.model.params.index("R0")]
            pooled.append(r)
            medians.append(float(np.median(r)))
    sources = r0_uncertainty(R0=R0, draws=np.concatenate(pooled) if pooled else None,
                             models=medians if len(medians) > 1 else None, ohmmeter=ohmmeter)
    if widened and "posterior_interval" in sources:
        sources["total_interval"] = sources.pop("posterior_interval")
    out = {"nominal": check_margin(nom.Rs, nom.Cs, nom.Rs_instability, R0, sources, what="the nominal shunt")}
    if math.isfinite(on_rob.Rs) and math.isfinite(on_rob.Cs):
        ev = evaluate_rc_shunt(nom_model, nom_theta, on_rob.Rs, on_rob.Cs)
        out["robust"] = check_margin(on_rob.Rs, on_rob.Cs, ev.Rs_instability, R0, sources,
                                     what="the robust shunt")
    return out


_SPARE_CHUNK = 500  # spare draws per BatchPlant while checking stability


def _unseen_stability(groups, plants, halves, shunts, sampled) -> list[dict]:
    """Per shunt ``(Rs, Cs)``: model label → ``(N,)`` stability of the draws the robust choice never
    saw (the held-back half and every kept draw the mixture did not pick)."""
    out = [{} for _ in shunts]
    for g, bp, (_, held) in zip(groups, plants, halves, strict=True):
        spare = g.spare if g.spare is not None and g.available >= g.n else np.empty((0, g.model.ndim))
        parts = [[] for _ in shunts]
        for a in range(0, spare.shape[0], _SPARE_CHUNK):
            sp = BatchPlant(g.model, spare[a : a + _SPARE_CHUNK], sampled=sampled, peaks=False)
            for k, (rs, cs) in enumerate(shunts):
                parts[k].append(sp.crossings(cs, Rs=rs).stable(rs))
        for k, (rs, cs) in enumerate(shunts):
            st = bp.crossings(cs, held, Rs=rs).stable(rs)
            out[k][g.label] = np.concatenate([st, *parts[k]])
    return out


def _boundary(plants, groups, Cs_values, points, Rs_ref) -> dict:
    lo, hi = 0.7 * min(Cs_values), 1.4 * max(Cs_values)
    cs = np.geomspace(lo, hi, points)
    out = {"Cs": cs}
    for bp, g in zip(plants, groups, strict=True):
        if bp.n == 0:
            continue
        thr = np.array([bp.threshold(c, Rs=Rs_ref) for c in cs])
        q = np.quantile(thr, [0.5, 0.95], axis=1)
        out[g.label] = {"median": q[0], "q95": q[1], "max": thr.max(axis=1)}
    return out


def design_robust_shunt(groups: Sequence[DrawGroup], *, nominal: tuple[Model, np.ndarray, str] | None = None,
                        risk: RiskKind = "cvar", alpha: float = 0.9, epsilon: float = 1e-3,
                        confidence: float = 0.95, seed: int = 0, sampled: SampledShunt | None = None,
                        ess_fraction: float = 1.0, boundary_points: int = 0,
                        notes: Sequence[str] = (), ohmmeter_tolerance: float | None = None,
                        progress=None, time_budget: float | None = None,
                        r0_spread: Sequence = ()) -> RobustShunt:
    """Shunt design under uncertainty (module docstring).

    Parameters
    ----------
    groups : draws per model (:func:`~bayes_emt.shunt.draws.sample_mixture`); at least 2 in all.
    nominal : ``(model, theta, description)`` of the point estimate the nominal shunt is designed
        for; default the median of the heaviest group's draws.
    risk : ``"cvar"`` (mean of the worst ``1 − alpha`` of the attenuations), ``"mean"`` or ``"worst"``.
    alpha : the CVaR level. epsilon : the bound on P(unstable) (per model).
    confidence : of the Clopper–Pearson interval. seed : the split into design and held-back halves.
    sampled : a digital realisation whose delay enters every draw's stability threshold (the final
        designs are then checked exactly on the draws nearest the boundary).
    ess_fraction : effective sample size per draw (≤ 1), scaling the draw counts of the interval.
    boundary_points : Cs grid points of the stability-boundary data for plots (0: none).
    notes : warnings from reading the draws, carried into the result.
    ohmmeter_tolerance : [Ω] of a DC measurement of R0, compared with the stability margins too.
    progress : optional ``callable(str)`` told when each stage starts and, every 2 s, how far the
        long stages are (``shunt --posterior`` prints these on stderr).
    time_budget : [wall s] for the robust choice (the slow stage); past it the best shunt so far is
        kept and a warning says so (``demo`` gives the step its share of the run).
    r0_spread : the :class:`~bayes_emt.shunt.r0_spread.R0Spread` each group's R0 draws were widened
        by (:func:`~bayes_emt.shunt.r0_spread.widen_r0`), reported and named in the margin check.

    Both shunts carry ``stability_margin_ohm`` (``Rs −`` the instability threshold at the nominal
    point) and the R0 uncertainty it is compared with (half the pooled draws' 90 % interval of R0,
    the other models' median R0, the ohmmeter tolerance: :mod:`bayes_emt.shunt.safety`), in
    ``report[name]`` and ``report["safety"][name]``; a margin below it adds a warning
    ``[stability_margin_below_uncertainty] ...``.
    """
    t_start = time.perf_counter()

    def stage(text):
        if progress is not None:
            progress(f"{text} ({time.perf_counter() - t_start:.1f} s)")

    if risk not in RISKS:
        raise ValueError(f"unknown risk measure {risk!r}; choose one of {', '.join(RISKS)}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    if not 0.0 <= epsilon < 1.0:
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}")
    groups = [g for g in groups if g.n > 0]
    if sum(g.n for g in groups) < 2:
        raise ValueError("need at least 2 draws")
    warns = [w for w in notes if w]
    timing = {}
    labels = [g.label for g in groups]
    if len(set(labels)) != len(labels):
        raise ValueError(f"each model may appear once in a mixture, got {labels}")
    heavy = max(range(len(groups)), key=lambda i: (groups[i].weight, -i))
    if nominal is None:
        g = groups[heavy]
        nominal = (g.model, np.median(g.thetas, axis=0), f"posterior median of {g.label}")
    nom_model, nom_theta, nom_src = nominal
    refuse_undefined(nom_model, np.asarray(nom_theta, float), nom_src)
    t = time.perf_counter()
    stage(f"nominal design ({nom_src}) and {sum(g.n for g in groups)} draws' plants")
    nom = design_rc_shunt(nom_model, np.asarray(nom_theta, float))
    plants = [BatchPlant(g.model, g.thetas, sampled=sampled) for g in groups]
    timing["prepare_s"] = time.perf_counter() - t
    # each draw's own optimum, warm-started from its model's median design
    t = time.perf_counter()
    opt_rs, opt_cs, opt_att, opt_fb, opt_margin, iters = [], [], [], [], [], 0
    nom_R0 = float(nom_theta[nom_model.params.index("R0")])
    for g, bp in zip(groups, plants, strict=True):
        stage(f"each of the {g.n} {g.label} draws' own optimal shunt")
        if g.model == nom_model:
            start, r0 = (nom.Rs, nom.Cs), nom_R0
        else:
            med = np.median(g.thetas, axis=0)
            d = design_rc_shunt(g.model, med)
            start, r0 = (d.Rs, d.Cs), float(med[g.model.params.index("R0")])
        opt = design_draws(bp, start, R0_start=r0, progress=_ticker(progress, f"{g.label} draws designed"))
        opt_rs.append(opt.Rs), opt_cs.append(opt.Cs), opt_att.append(opt.attenuation_db)
        opt_fb.append(opt.fallback), opt_margin.append(opt.margin)
        iters = max(iters, opt.iterations)
    opt_rs, opt_cs, opt_att, opt_fb, opt_margin = (
        np.concatenate(v) for v in (opt_rs, opt_cs, opt_att, opt_fb, opt_margin))
    timing["per_draw_designs_s"] = time.perf_counter() - t
    group = np.concatenate([np.full(g.n, i) for i, g in enumerate(groups)])
    halves = split_halves(groups, seed=seed)
    held = np.zeros(group.size, bool)
    off = np.cumsum([0] + [g.n for g in groups])
    for i, (_, h) in enumerate(halves):
        held[off[i] + h] = True
    design = ~held
    t = time.perf_counter()
    stage("the nominal shunt on every draw; choosing the robust shunt on the design half")
    on_nom = _on_draws(plants, "nominal", nom.Rs, nom.Cs, f"design_rc_shunt at the {nom_src}")
    pool = DrawPool([(bp, d) for bp, (d, _) in zip(plants, halves, strict=True)])
    starts = [(nom.Rs, nom.Cs), (float(np.median(opt_rs[design])), float(np.median(opt_cs[design])))]
    # the Cs bound of single designs (1e3/(L_eq w0^2)), at the median draw of the tightest model
    cs_max = float(min(np.exp(np.median(cs_bound(bp))) for bp in plants))
    starts = [(r, min(c, cs_max)) for r, c in starts]
    tick = _ticker(progress, "choosing the robust shunt")
    choice = choose_robust(pool, starts, risk=risk, alpha=alpha, epsilon=epsilon, cs_max=cs_max,
                           time_budget=time_budget, tick=None if tick is None else (lambda m: tick(m, None)))
    if choice.info.get("time_budget_reached"):
        warns.append(f"the robust choice stopped at its time budget ({time_budget:g} s): the robust shunt is "
                     "the best found by then, not a converged optimum")
    on_rob = _on_draws(plants, "robust", choice.Rs, choice.Cs,
                       f"{risk} of the attenuation over the {int(design.sum())} design draws, "
                       f"P(unstable) <= {epsilon:g} per model")
    timing["robust_choice_s"] = time.perf_counter() - t
    t = time.perf_counter()
    stage("report on the held-back half: intervals, exact stability checks, R0, sensitivities")
    parts = (held, group, labels, opt_att, design)
    rep_nom = _design_report(on_nom, parts, risk, alpha, confidence, ess_fraction)
    rep_rob = _design_report(on_rob, parts, risk, alpha, confidence, ess_fraction)
    for rep, on in ((rep_nom, on_nom), (rep_rob, on_rob)):
        rep.update(_q_report(groups, halves, on, held, group))
    driver = _driver_report(groups, halves)
    checks = exact_checks(plants, groups, group, [on_nom, on_rob], sampled)
    for name, c in checks.items():
        rep = rep_nom if name == "nominal" else rep_rob
        rep["stability_check"] = c
        if c.get("disagree"):
            warns.append(f"{name}: the exact stability check disagrees with the threshold on "
                         f"{c['disagree']} of {c['checked']} draws checked near the boundary")
    r0 = describe_r0(groups, group, plants, on_nom, on_rob)
    warns.extend(r0.pop("warnings"))
    safety = _safety(groups, nom_model, np.asarray(nom_theta, float), nom, on_rob, ohmmeter_tolerance,
                     widened=any(s.tau_ohm > 0 for s in r0_spread))
    for name, chk in safety.items():
        rep = rep_nom if name == "nominal" else rep_rob
        rep.update({"stability_margin_ohm": chk.stability_margin_ohm,
                    "r0_uncertainty_ohm": chk.r0_uncertainty_ohm, "r0_uncertainty": dict(chk.r0_uncertainty)})
        warns.extend(f"[{w['code']}] {name}: {w['message']}" for w in chk.warnings)
        warns.extend(f"{name}: {n}" for n in chk.notes if "no R0 uncertainty" not in n)
    delta = max(float(np.diff(quantiles(opt_rs[design], [0.05, 0.95]))[0]) / 2, 1e-5)
    steep = {"delta_ohm": delta}
    for key, sign in (("loss_down_db", -1.0), ("loss_up_db", 1.0)):
        regret = []
        for i, (bp, (d, _)) in enumerate(zip(plants, halves, strict=True)):
            j = off[i] + d
            pb = rc_peaks_batch(bp, opt_rs[j] + sign * delta, opt_cs[j], d)
            regret.append(20 * np.log10(pb.hinf / bp.open_peak[d]) - opt_att[j])
        steep[key] = float(np.median(np.concatenate(regret)))
    why = explain_move(on_nom, on_rob, design, risk, steep, opt_margin)
    sens = sensitivity(groups, group, opt_rs, opt_cs, opt_att, on_nom.attenuation)
    timing["report_s"] = time.perf_counter() - t
    boundary = {}
    if boundary_points:
        boundary = _boundary(plants, groups, list(opt_cs) + [nom.Cs, choice.Cs], boundary_points, choice.Rs)
    n_held = int(held.sum())
    t = time.perf_counter()
    stage("P(unstable) <= epsilon: both shunts on every kept draw the robust choice never saw")
    avail = {g.label: g.available for g in groups}
    for rep, st in zip((rep_nom, rep_rob), _unseen_stability(groups, plants, halves,
                                                             [(nom.Rs, nom.Cs), (choice.Rs, choice.Cs)],
                                                             sampled), strict=True):
        rep["p_unstable_bound"] = instability_bound(st, epsilon, confidence, ess_fraction, avail)
    timing["p_unstable_bound_s"] = time.perf_counter() - t
    bnd = rep_rob["p_unstable_bound"]
    if any(g.available < g.n for g in groups):
        bnd["shown"] = False
        warns.append("[p_unstable_not_shown] robust: draws were repeated (more asked than the posterior "
                     "keeps), so the held-back draws are not independent of the design's and no bound on "
                     "P(unstable) is claimed")
    elif not bnd["shown"]:
        worst = max(bnd["per_model"].items(), key=lambda kv: kv[1]["upper_bound"])
        label, pm = worst
        need = bnd["draws_needed"]
        need_txt = ("no finite number of draws shows epsilon = 0" if need is None else
                    f"showing epsilon = {epsilon:g} needs {need} such draws with none unstable")
        n_used = int(np.count_nonzero(design & (group == labels.index(label))))
        tail = ("" if need is None or pm["n_unstable"] else
                f" (the posterior keeps {pm['draws_available']} draws, {n_used} of them used for the design: "
                "sample a longer chain, or ask a larger --epsilon)")
        warns.append(f"[p_unstable_not_shown] robust: {pm['n_unstable']} of the {pm['n_checked']} {label} "
                     "draws the choice never saw are unstable, which bounds P(unstable) by "
                     f"{pm['upper_bound']:.3g} ({confidence:.0%} one-sided), not by epsilon = {epsilon:g}: "
                     f"{need_txt}{tail}")
    if rep_rob["risk_db"] is not None and rep_nom["risk_db"] is not None and \
            rep_rob["risk_db"] > rep_nom["risk_db"]:
        warns.append(f"on the held-back draws the robust shunt's {risk} ({rep_rob['risk_db']:.4f} dB) is "
                     f"worse than the nominal's ({rep_nom['risk_db']:.4f} dB): the gain on the design half "
                     "did not carry over (too few draws for this risk measure, or a posterior this tight "
                     "leaves nothing to gain)")
    if opt_fb.any():
        warns.append(f"{int(opt_fb.sum())} of {opt_fb.size} per-draw optima came from design_rc_shunt "
                     "(the batched Newton did not settle on an equal-peak optimum there)")
    timing["total_s"] = time.perf_counter() - t_start
    stage("done")
    report = {
        "nominal": rep_nom, "robust": rep_rob, "driver": driver,
        "per_draw": {"Rs": summary(opt_rs), "Cs": summary(opt_cs), "attenuation_db": summary(opt_att),
                     "n_fallback": int(opt_fb.sum()), "newton_iterations": iters},
        "n_draws": int(group.size), "n_design": int(design.sum()), "n_held_back": n_held,
        "models": [g.to_json_dict() for g in groups],
        "risk": risk, "alpha": alpha, "epsilon": epsilon, "confidence": confidence, "seed": seed,
        "ess_fraction": ess_fraction,
        "p_unstable_interval": f"Clopper-Pearson exact binomial, {confidence:.0%}, on the held-back draws",
        "nominal_design": {"Rs": nom.Rs, "Cs": nom.Cs, "attenuation_db": nom.attenuation_db,
                           "model": nom_model.label, "source": nom_src},
        "robust_choice": choice.info, "why": why, "r0": r0, "sensitivity": sens,
        "safety": {k: v.to_json_dict() for k, v in safety.items()},
        "r0_spread": [s.to_json_dict() for s in r0_spread],
        "implementation": None if sampled is None else sampled.to_json_dict(),
        "units": {"Rs": "ohm", "Cs": "F", "attenuation_db": "dB", "margin_ohm": "ohm", "R0": "ohm",
                  "regret_db": "dB (>= 0: worse than the draw's own optimum)", "risk_db": "dB"},
        "timing": timing}
    return RobustShunt(tuple(groups), group, held, on_nom, on_rob, opt_rs, opt_cs, opt_att, opt_fb, risk,
                       alpha, epsilon, confidence, seed, strict_json(report), boundary, tuple(warns))
