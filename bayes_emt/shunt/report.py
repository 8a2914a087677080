"""The words and checks around a robust shunt: why its Rs moved, how its stability depends on R0,
which parameters drive the design, and exact stability checks of the draws nearest the boundary.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from .batch_plant import SampledShunt
from .implementation import sampled_loop_max_pole
from .risk import quantiles, spearman, summary
from .stability import assess_stability

__all__ = ["explain_move", "describe_r0", "sensitivity", "exact_checks"]

_NEAREST = 5  # draws nearest the boundary checked exactly per design


def _m(a) -> dict:
    q = quantiles(a, [0.05, 0.5])
    return {"min": float(np.min(a)), "q05": float(q[0]), "median": float(q[1])}


def explain_move(nom, rob, design, held, risk, alpha) -> dict:
    """Why the robust Rs differs from the nominal one, in terms of the stability boundary: the
    margin ``Rs − threshold`` [Ω] of each draw (on the design half, which the choice saw)."""
    d_rs, d_lcs = rob.Rs - nom.Rs, math.log(rob.Cs / nom.Cs)
    mn, mr = nom.margin[design], rob.margin[design]
    an, ar = nom.attenuation[design], rob.attenuation[design]
    k = max(1, int(math.ceil(0.05 * mn.size)))
    close = np.argsort(mn)[:k]
    side = "less negative" if d_rs > 0 else ("more negative" if d_rs < 0 else "unchanged")
    med_n, med_r = float(np.median(an)), float(np.median(ar))
    close_n, close_r = float(np.median(an[close])), float(np.median(ar[close]))
    text = (f"The robust Rs is {abs(d_rs) * 1e3:.3f} mOhm {side} than the nominal "
            f"({nom.Rs:.5f} -> {rob.Rs:.5f} ohm; Cs {nom.Cs:.5g} -> {rob.Cs:.5g} F). Every draw has its "
            "own instability threshold in Rs (minus the real part of the terminal impedance where the "
            "loop reactance vanishes; a lower R0 raises it one for one). The nominal shunt sits "
            f"{np.median(mn):.4f} ohm above the median draw's threshold but {np.min(mn):.4f} ohm above "
            f"the closest draw's (5 % of draws within {quantiles(mn, [0.05])[0]:.4f} ohm). ")
    rho = float(spearman(mn[:, None], np.where(np.isfinite(an), an, 1e300))[0])
    binds = np.isfinite(rho) and rho < -0.3
    if d_rs > 0 and binds:
        text += (f"The draws nearest their threshold are the ones the nominal shunt damps worst (Spearman "
                 f"rho = {rho:+.2f} between margin and attenuation): near its threshold a draw's loop is "
                 f"lightly damped and its peak rises steeply. The 5 % of draws closest to the boundary "
                 f"attenuate {close_n:.3f} dB with the nominal shunt against {med_n:.3f} dB at the median; "
                 f"moving Rs up, away from the boundary, brings them to {close_r:.3f} dB (closest margin now "
                 f"{np.min(mr):.4f} ohm) at {med_r - med_n:+.4f} dB on the median draw: the {risk} "
                 "trades the typical draw for the ones the stability boundary threatens.")
    elif d_rs != 0:
        text += (f"The boundary does not bind here: every draw keeps at least {np.min(mn):.4f} ohm of margin "
                 f"and a draw's attenuation hardly follows its margin (Spearman rho = {rho:+.2f}). The "
                 f"{risk} is set by the draws whose own peaks are highest (see the drivers), and the robust "
                 f"shunt re-balances the two peaks for them (closest margin {np.min(mr):.4f} ohm; median "
                 f"attenuation {med_r - med_n:+.4f} dB).")
    else:
        text += "The nominal shunt is already the best choice for this risk measure."
    return {"text": text, "delta_Rs_ohm": d_rs, "delta_log_Cs": d_lcs, "side": side,
            "boundary_binds": bool(binds), "spearman_margin_attenuation": rho,
            "nominal_margin_ohm": _m(mn), "robust_margin_ohm": _m(mr),
            "closest_5pct_attenuation_db": {"nominal": close_n, "robust": close_r},
            "median_attenuation_db": {"nominal": med_n, "robust": med_r}}


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
                        "the default fit), and an ohmmeter reading of the DC resistance given as an R0 prior "
                        "(`sample --priors`) bounds that risk.")
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
