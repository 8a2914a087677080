"""``bayes-emt shunt --posterior RUN.nc [...]``: the posterior-mode half of the ``shunt`` command
(robust RC shunt over posterior draws; :mod:`bayes_emt.shunt.robust`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

from ...errors import DataFormatError
from ..paths import check_outputs

__all__ = ["run_posterior", "read_compare_file"]


def read_compare_file(path: str, models) -> list[float]:
    """Log evidences for ``models`` from a ``bayes-emt compare`` JSON file
    ``{"models": [{"name", "label", "rings", "log_evidence", ...}]}``, matched by the model's label
    (``NL(5)``, ``UD+winding_capacitance``)."""
    p = Path(path)
    if not p.is_file():
        raise DataFormatError(f"{path}: no such compare file")
    try:
        rec = json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: not a JSON file ({exc})") from None
    entries = rec.get("models") if isinstance(rec, dict) else None
    if not isinstance(entries, list):
        raise DataFormatError(f"{path}: expected " + '{"models": [{"name", "rings", "log_evidence"}, ...]}')
    table = {}
    for i, e in enumerate(entries):
        if not isinstance(e, dict) or "name" not in e or "log_evidence" not in e:
            raise DataFormatError(f"{path}: models[{i}] needs 'name' and 'log_evidence'")
        try:
            lz = float(e["log_evidence"])
        except (TypeError, ValueError):
            raise DataFormatError(f"{path}: models[{i}].log_evidence is not a number") from None
        rings = e.get("rings")
        label = e.get("label") or str(e["name"]).upper() + ("" if rings is None else f"({int(rings)})")
        table[str(label)] = lz
    out = []
    for m in models:
        key = m.label
        if key not in table:
            have = ", ".join(table)
            raise DataFormatError(f"{path}: no log evidence for model {m.label} (has: {have or 'none'})")
        out.append(table[key])
    return out


def _read(path: str):
    from ...api import read_posterior

    if not Path(path).is_file():
        raise DataFormatError(f"{path}: no such posterior file")
    try:
        return read_posterior(path)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise DataFormatError(f"{path}: cannot read a posterior from it ({first})") from None


def _fmt_ci(ci) -> str:
    return f"{ci[0]:.3g} .. {ci[1]:.3g}"


def _fmt_att(s, spec: str = ".3f") -> str:
    def f(v):
        return "unstable" if v is None else format(v, spec)

    return f"{f(s['median'])} ({f(s['q05'])} .. {f(s['q95'])})"


def _tolerance(args) -> float | None:
    """The ohmmeter tolerance [ohm]: ``--ohmmeter-tolerance``, or the 90 % half-width of ``--re``."""
    tol = getattr(args, "ohmmeter_tolerance", None)
    if getattr(args, "re", None) is not None:
        tol = max(tol or 0.0, 1.645 * args.re[1])
    return tol


def run_posterior(args, sampled) -> int:
    from ...io.paramfile import read_param_file, write_json
    from ...shunt.from_posterior import robust_shunt
    from ._common import print_table

    if args.evaluate_on or args.model:
        raise ValueError("--evaluate-on and --model apply to --params alone; with --posterior every draw "
                         "is evaluated")
    if args.log_evidence and args.compare:
        raise ValueError("give the log evidences by --log-evidence or --compare, not both")
    if args.log_evidence and len(args.log_evidence) != len(args.posterior):
        raise ValueError(f"--log-evidence given {len(args.log_evidence)} times for {len(args.posterior)} "
                         "--posterior files: give one per posterior, in the same order")
    if not (0 < args.alpha < 1):
        raise ValueError(f"--alpha must be in (0, 1), got {args.alpha}")
    if args.epsilon != "auto" and not (0 <= args.epsilon < 1):
        raise ValueError(f"--epsilon must be in [0, 1), got {args.epsilon}")
    if not (0 < args.confidence < 1):
        raise ValueError(f"--confidence must be in (0, 1), got {args.confidence}")
    inputs = [("--posterior", p) for p in args.posterior]
    inputs += [("--params", args.params), ("--compare", args.compare)]
    check_outputs([("--json", args.json)], inputs, folders=[("--plot", args.plot, ())])
    posts = [_read(p) for p in args.posterior]
    labels = [p.model.label for p in posts]
    if len(set(labels)) != len(labels):
        raise ValueError(f"each model may be given once: {', '.join(labels)}")
    lzs = (list(args.log_evidence) if args.log_evidence else
           read_compare_file(args.compare, [p.model for p in posts]) if args.compare else None)
    nominal = None
    if args.params:
        m, th = read_param_file(args.params)
        nominal = (m, th, f"fit {args.params} ({m.label})")
    result = robust_shunt(posts, weights="evidence" if lzs else "equal", log_z=lzs, n_draws=args.draws,
                          seed=args.seed, risk=args.risk, alpha=args.alpha, epsilon=args.epsilon,
                          confidence=args.confidence, nominal=nominal, sampled=sampled,
                          ohmmeter_tolerance=_tolerance(args),
                          sources=list(args.posterior), boundary_points=24 if args.plot else 0,
                          progress=not getattr(args, "quiet", False),
                          r0=getattr(args, "r0_interval", "total"))
    res = result.detail
    rep = result.report
    mix = ", ".join(f"{g['label']} {100 * g['weight']:.3g} % ({g['n_draws']} draws)" for g in rep["models"])
    risk = f"CVaR_{args.alpha:g}" if args.risk == "cvar" else args.risk
    print(f"robust RC shunt over {rep['n_draws']} posterior draws [{mix}]: {risk} of the attenuation, "
          f"P(unstable) <= {rep['epsilon']:g} per model; chosen on {rep['n_design']} draws, reported on the "
          f"{rep['n_held_back']} held back")
    ec = rep.get("epsilon_choice") or {}
    if args.epsilon == "auto" and ec.get("unseen_draws") is not None:
        unseen = ", ".join(f"{k} {v}" for k, v in ec["unseen_draws"].items())
        tail = (f"epsilon = {ec['epsilon']:g} needs {ec['draws_needed']}" if ec["showable"] else
                f"too few to show even {ec['epsilon']:g} ({ec['draws_needed']} needed)")
        print(f"  {ec['rule']}: unseen draws {unseen}; {tail}")
    if sampled is not None:
        print(f"  stability of every draw includes the sampled-data controller: fs = {sampled.fs:g} Hz, "
              f"delay {sampled.delay_samples} sample(s), R_in = {sampled.R_in:g} ohm, "
              f"K_in = {sampled.K_in:g}, K_out = {sampled.K_out:g}")
    rows = []
    for name in ("nominal", "robust"):
        d = rep[name]
        risk_v = "unstable" if d["risk_db"] is None else f"{d['risk_db']:.3f}"
        rows.append((name, f"{d['Rs']:.5f}", f"{d['Cs']:.5g}", _fmt_att(d["attenuation_db"]), risk_v,
                     f"{d['p_unstable']:.3g} ({_fmt_ci(d['p_unstable_ci'])})",
                     f"{d['margin_ohm']['min']:.4f}",
                     f"{d['regret_db']['median']:.4f}" if d["regret_db"]["median"] is not None else "-"))
    print_table(rows, ("shunt", "Rs [ohm]", "Cs [F]", "attenuation [dB] median (5 %..95 %)",
                       f"{args.risk} [dB]",
                       f"P(unstable) ({args.confidence:.0%} CI)", "min margin [ohm]", "median regret [dB]"))
    drv = rep.get("driver")
    if drv and drv["qts"]["median"] is not None:
        print(f"driver without a shunt (median, 90 % interval over the held-back draws): fs "
              f"{_fmt_att(drv['fs_hz'], '.4g')} Hz, Qms {_fmt_att(drv['qms'], '.3g')}, Qts "
              f"{_fmt_att(drv['qts'], '.3g')} with a zero-impedance source (resonance at "
              f"{_fmt_att(drv['resonance_hz'], '.4g')} Hz)")
    for name in ("nominal", "robust"):
        d = rep[name]
        red, hz = d.get("resonance_peak_reduction_db"), d.get("resonance_hz")
        q, qf = d.get("qts_damped"), d.get("damped_resonance_hz")
        qtxt = ("" if not q or q.get("median") is None else
                f"; damped Qts' {_fmt_att(q, '.3g')} at {_fmt_att(qf, '.4g')} Hz")
        if red and red.get("median") is not None and hz and hz.get("median") is not None:
            print(f"{name}: resonance peak lowered by {_fmt_att(red, '.2f')} dB (median, 90 % interval over "
                  f"the stable held-back draws), the peak now at {_fmt_att(hz, '.4g')} Hz{qtxt}")
        elif red and red.get("median") is not None:
            print(f"{name}: no resonance peak left within f0/3 .. 40 f0; the largest response there is "
                  f"{_fmt_att(red, '.2f')} dB below the open-terminal peak (median, 90 % interval){qtxt}")
    b = rep["robust"].get("p_unstable_bound")
    if b:
        pm = "; ".join(f"{lb}: {v['n_unstable']} of {v['n_checked']} unstable, "
                       f"P(unstable) <= {v['upper_bound']:.3g}" for lb, v in b["per_model"].items())
        need = ("no finite number" if b["draws_needed"] is None else
                f"{b['draws_needed']} unseen draws, none unstable")
        verdict = "SHOWN" if b["shown"] else "NOT shown"
        print(f"robust: P(unstable) <= {rep['epsilon']:g} {verdict} on the draws the choice never saw ({pm}; "
              f"{args.confidence:.0%} one-sided exact binomial bound; showing it needs {need})")
    pd = rep["per_draw"]
    print(f"each draw's own optimum (median, 90 % interval): Rs {_fmt_att(pd['Rs'], '.5f')} ohm, "
          f"Cs {_fmt_att(pd['Cs'], '.5g')} F, attenuation {_fmt_att(pd['attenuation_db'])} dB "
          f"({pd['n_fallback']} of {rep['n_draws']} draws designed one at a time)")
    print(f"nominal: {rep['nominal']['source']}")
    print("why: " + rep["why"]["text"])
    print("R0: " + rep["r0"]["statement"])
    for name in ("nominal", "robust"):
        d = rep[name]
        if d.get("stability_margin_ohm") is not None:
            unc = d.get("r0_uncertainty_ohm")
            print(f"stability margin ({name}, at the nominal point): {d['stability_margin_ohm']:.4g} ohm; R0 "
                  "uncertainty " + ("none" if unc is None else f"{unc:.4g} ohm (" + ", ".join(
                      f"{k} {v:.4g}" for k, v in d["r0_uncertainty"].items()) + ")"))
    for label, s in rep["sensitivity"].items():
        top = "; ".join(f"{k} <- {', '.join(v)}" for k, v in s["top"].items())
        print(f"drivers ({label}, Spearman): {top}")
    for w in rep["warnings"]:
        print(f"warning: {w}")
    print(f"({rep['timing']['total_s']:.1f} s)")
    if args.plot:
        from ...plotting import save_figure
        from ...plotting.robust_shunt import (
            plot_attenuation_distributions,
            plot_gain_bands,
            plot_stability_boundary,
        )

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        for name, make in (("gain", plot_gain_bands), ("distributions", plot_attenuation_distributions),
                           ("boundary", plot_stability_boundary)):
            path = folder / f"shunt_robust_{name}.png"
            save_figure(make(res), path, dpi=110)
            print(f"wrote {path}")
    if args.json:
        out = {**rep, "posteriors": list(args.posterior)}
        write_json(args.json, out)
        print(f"wrote {args.json}")
    return 0 if math.isfinite(res.robust.Rs) else 1
