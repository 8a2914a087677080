"""The words and checks around a robust shunt: why its Rs moved, how its stability depends on R0,
which parameters drive the design, and exact stability checks of the draws nearest the boundary.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from .batch.plant import SampledShunt
from .implementation import sampled_loop_max_pole
from .risk import quantiles, spearman, summary
from .stability import assess_stability

__all__ = ["explain_move", "describe_r0", "sensitivity", "exact_checks"]

_NEAREST = 5  # draws nearest the boundary checked exactly per design


def _m(a) -> dict:
    q = quantiles(a, [0.05, 0.5])
    return {"min": float(np.min(a)), "q05": float(q[0]), "median": float(q[1])}


def explain_move(nom, rob, design, risk, steep: dict, own_margin) -> dict:
    """Why the robust Rs differs from the nominal one, in terms of the stability boundary.

    A draw is on the *boundary side* of the nominal shunt when the shunt leaves it less margin to
    its instability threshold than the draw's own optimum does (``own_margin``, [Ω] per draw):
    its loop is less damped than its own design would make it, and its peak rises steeply. When
    the nominal shunt's worst 10 % hold boundary-side draws more often than the draws at large (by
    more than two binomial standard errors), the boundary is what a risk measure over draws
    answers by moving Rs up. ``steep`` holds ``delta_ohm`` (half the 90 % spread of the
    draws' own optimal Rs) and the median regret [dB] of moving each draw's own optimum by that
    much down (``loss_down_db``) and up (``loss_up_db``). Everything is on the design half."""
    d_rs, d_lcs = rob.Rs - nom.Rs, math.log(rob.Cs / nom.Cs)
    mn, mr = nom.margin[design], rob.margin[design]
    an, ar = nom.attenuation[design], rob.attenuation[design]
    side = "less negative" if d_rs > 0 else ("more negative" if d_rs < 0 else "unchanged")
    qn, qr = quantiles(an, [0.5, 0.95]), quantiles(ar, [0.5, 0.95])
    worst = an >= quantiles(an, [0.9])[0]
    closer = mn < own_margin[design]
    f_all, f_worst = float(np.mean(closer)), float(np.mean(closer[worst]))
    down, up, delta = steep["loss_down_db"], steep["loss_up_db"], steep["delta_ohm"]
    # the worst draws are boundary-side ones more often than chance: two binomial standard errors
    n_worst = int(np.count_nonzero(worst))
    enriched = f_worst - f_all > 2 * math.sqrt(max(f_all * (1 - f_all), 1e-12) / max(n_worst, 1))
    boundary = d_rs > 0 and enriched
    text = (f"The robust Rs is {abs(d_rs) * 1e3:.3f} mOhm {side} than the nominal "
            f"({nom.Rs:.5f} -> {rob.Rs:.5f} ohm; Cs {nom.Cs:.5g} -> {rob.Cs:.5g} F). Every draw has its "
            "own instability threshold in Rs (minus the real part of the terminal impedance where the "
            "loop reactance vanishes; a lower R0 raises it one for one); the nominal shunt sits "
            f"{np.median(mn):.4f} ohm above the median draw's threshold and {np.min(mn):.4f} ohm above the "
            f"nearest. It leaves {100 * f_all:.0f} % of the draws less margin than their own optimum "
            f"would, but {100 * f_worst:.0f} % of its worst 10 %. The draws' own optimal Rs spread over "
            f"+-{delta * 1e3:.3f} mOhm (90 %); missing a draw's optimum by that much towards its threshold "
            f"costs {down:+.4f} dB (median), the other way {up:+.4f} dB. ")
    if boundary:
        text += ("The worst draws are those the nominal shunt pushes towards their stability boundary, "
                 "where the loop loses damping and the peak rises steeply; so the "
                 f"{risk} moves Rs up, away from the boundary: nearest margin {np.min(mn):.4f} -> "
                 f"{np.min(mr):.4f} ohm, worst 5 % {qn[1]:.4f} -> {qr[1]:.4f} dB, median draw "
                 f"{qn[0]:.4f} -> {qr[0]:.4f} dB.")
    elif d_rs != 0:
        text += ("The stability boundary does not set the move here: the "
                 f"{risk} is made of the draws whose own peaks are highest (see the drivers), and the "
                 f"robust shunt re-balances the two peaks for them (worst 5 % {qn[1]:.4f} -> {qr[1]:.4f} dB, "
                 f"median draw {qn[0]:.4f} -> {qr[0]:.4f} dB).")
    else:
        text += "The nominal shunt is already the best choice for this risk measure."
    return {"text": text, "delta_Rs_ohm": d_rs, "delta_log_Cs": d_lcs, "side": side,
            "boundary_explains": bool(boundary),
            "boundary_side_fraction": {"all": f_all, "worst_10pct": f_worst}, "steepness": steep,
            "nominal_margin_ohm": _m(mn), "robust_margin_ohm": _m(mr)}


def describe_r0(groups, group, plants, nom, rob) -> dict:
    """How each design's stability depends on R0, per model and over the mixture.

    ``R0_crit = R0 − margin`` per draw is the R0 [Ω] at which that draw's loop would go unstable
    (all else fixed). Returns a dict with ``statement`` (words), ``per_model``, ``mixture`` and
    ``warnings`` (to be moved to the result's warnings)."""
    R0 = np.concatenate([bp.R0 for bp in plants])
    out, warns = {"per_model": {}}, []

    def block(sel):
        b = {"R0": summary(R0[sel])}
        for on in (nom, rob):
            b[on.name] = {"margin_ohm": _m(on.margin[sel]), "R0_critical": summary(R0[sel] - on.margin[sel]),
                          "p_unstable": float(np.mean(~on.stable[sel]))}
        return b

    for g, grp in enumerate(groups):
        out["per_model"][grp.label] = block(group == g)
    out["mixture"] = block(np.ones(group.size, bool))
    lines = []
    for on in (rob, nom):
        crit = R0 - on.margin
        qc = quantiles(crit, [0.5, 0.95])
        line = (f"{on.name} shunt (Rs = {on.Rs:.5f} ohm, Cs = {on.Cs:.5g} F): stable while R0 > "
                f"{qc[0]:.4f} ohm (median draw; {qc[1]:.4f} ohm for the 5 % most demanding draws)")
        parts = []
        for g, grp in enumerate(groups):
            sel = group == g
            med = float(np.median(R0[sel]))
            slack = float(quantiles(on.margin[sel], [0.05])[0])
            parts.append(f"{grp.label} puts R0 at {med:.4f} ohm, margin {slack:+.4f} ohm "
                         f"({100 * slack / med:+.1f} % of R0; 5 % of its draws have less)")
        lines.append(line + ": " + "; ".join(parts))
    out["statement"] = ("Stability depends on R0 (the negative Rs cancels most of it). "
                        + ". ".join(lines) + ". "
                        "A coil model that misses physics biases R0 (compare `fit --procedure paper` with "
                        "the default fit), and an ohmmeter reading of the DC resistance given to the "
                        "posterior (`sample --re OHM`) bounds that risk.")
    if len(groups) > 1:
        meds = {grp.label: float(np.median(R0[group == g])) for g, grp in enumerate(groups)}
        spread = max(meds.values()) - min(meds.values())
        low = min(meds, key=meds.get)
        slack = float(np.min(rob.margin[group == list(meds).index(low)]))
        if spread > slack:
            warns.append(f"the models disagree on R0 by {spread:.4f} ohm ("
                         + ", ".join(f"{k} {v:.4f}" for k, v in meds.items())
                         + " ohm), more than the robust shunt's smallest margin on the lowest-R0 model's "
                         f"draws ({slack:.4f} ohm)")
        for g, grp in enumerate(groups):
            p = float(np.mean(~nom.stable[group == g]))
            if p > 0:
                warns.append(f"the nominal shunt is unstable on {100 * p:.1f} % of {grp.label}'s draws: "
                             "its stability depends on which model is right")
    return {**out, "warnings": warns}


def sensitivity(groups, group, opt_rs, opt_cs, opt_att, nom_att) -> dict:
    """Spearman rank correlations, per model, of every parameter with each draw's optimal Rs,
    Cs and attenuation and with the nominal shunt's attenuation; ``top`` lists the three
    largest in magnitude."""
    out = {}
    targets = {"Rs": opt_rs, "Cs": opt_cs, "attenuation_db": opt_att, "nominal_attenuation_db": nom_att}
    for g, grp in enumerate(groups):
        sel = group == g
        if sel.sum() < 3:
            continue
        names = list(grp.model.names)
        rec, top = {}, {}
        for key, y in targets.items():
            rho = spearman(grp.thetas, y[sel])
            rec[key] = {n: (float(r) if np.isfinite(r) else None) for n, r in zip(names, rho, strict=True)}
            order = [i for i in np.argsort(-np.nan_to_num(np.abs(rho), nan=-1.0)) if np.isfinite(rho[i])]
            top[key] = [f"{names[i]} ({rho[i]:+.2f})" for i in order[:3]]
        out[grp.label] = {"spearman": rec, "top": top}
    return out


def _exact_threshold(model, theta, Cs, guess, sampled: SampledShunt) -> float:
    def f(rs):
        return sampled_loop_max_pole(model, theta, rs, Cs, R_in=sampled.R_in, K_in=sampled.K_in,
                                     K_out=sampled.K_out, fs=sampled.fs,
                                     delay_samples=sampled.delay_samples) - 1.0

    for w in (0.005, 0.02, 0.1):
        a, b = guess - w, guess + w
        fa, fb = f(a), f(b)
        if fa > 0 > fb:
            return float(optimize.brentq(f, a, b, xtol=1e-10))
    return math.nan


def exact_checks(plants, groups, group, designs, sampled: SampledShunt | None) -> dict:
    """Check the draws nearest each design's boundary exactly: the closed-loop poles
    (:func:`~bayes_emt.shunt.assess_stability`) for the ideal shunt, the sampled-data loop's
    eigenvalues (:func:`~bayes_emt.shunt.implementation.sampled_loop_max_pole`) with a realisation,
    whose frequency-domain threshold neglects aliasing: its error is measured on the nearest draw
    (bisection on the exact loop) and every draw within ten times that error is checked too."""
    off = np.cumsum([0] + [bp.n for bp in plants])
    out = {}
    for on in designs:
        order = np.argsort(np.abs(on.margin))
        pick = list(order[:_NEAREST])
        rec = {"method": "closed-loop poles (assess_stability)" if sampled is None else
               "sampled-data loop eigenvalues (sampled_loop_max_pole)"}
        if sampled is not None and pick:
            i = int(pick[0])
            g = int(group[i])
            bp, j = plants[g], i - off[g]
            thr_fd = on.Rs - on.margin[i]
            thr_ex = _exact_threshold(bp.model, bp.thetas[j], on.Cs, thr_fd, sampled)
            err = abs(thr_fd - thr_ex) if math.isfinite(thr_ex) else math.nan
            rec["threshold_error_ohm"] = err
            if math.isfinite(err):
                pick = sorted(set(pick) | set(np.flatnonzero(np.abs(on.margin) < 10 * err).tolist()))
        agree = 0
        for i in pick:
            g = int(group[i])
            bp, j = plants[g], i - off[g]
            if sampled is None:
                stable = assess_stability(bp.model, bp.thetas[j], on.Rs, on.Cs).stable
            else:
                stable = sampled_loop_max_pole(bp.model, bp.thetas[j], on.Rs, on.Cs, R_in=sampled.R_in,
                                               K_in=sampled.K_in, K_out=sampled.K_out, fs=sampled.fs,
                                               delay_samples=sampled.delay_samples) < 1.0
            agree += bool(stable) == bool(on.stable[i])
        rec.update({"checked": len(pick), "agree": agree, "disagree": len(pick) - agree,
                    "nearest_margin_ohm": float(on.margin[order[0]]) if order.size else None})
        out[on.name] = rec
    return out
