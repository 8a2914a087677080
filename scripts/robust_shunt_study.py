"""Shunt design under uncertainty on the bundled data (issue 12, acceptance points 2-4) and the
effect of an ohmmeter reading of R0.

    .venv/bin/python scripts/robust_shunt_study.py [--work DIR] [--draws 1000] [--split-seeds 5]
        [--noise-seeds 4] [--out scripts/results/robust_shunt_study.txt]

1. Posteriors (emcee, seed 1, the defaults of ``bayes-emt sample``; written to ``--work`` and reused
   when present, checkpointed while they run): NL(5) and UD on the bundled data
   (:func:`bayes_emt.io.datasets.load_paper_bench`: NL Table 5, 0.2 % noise); UD with an ohmmeter
   prior on R0 (a simulated reading of the true 2.56 ohm with 0.5 % error, lognormal sigma_log 0.005);
   NL(n) on data simulated like the bundled set but with 2 % noise (seed 20261124), n chosen from
   the data by Hankel singular values (:func:`bayes_emt.estimation.hankel.select_rings`: 4 rings; the
   fifth ring's singular value is below the noise floor at 2 % noise, and an NL(5) posterior of
   these data does not converge in 40000 steps because that ring is not determined by them).
2. Acceptance 2: the robust shunt on the NL posterior (``--draws`` draws, CVaR_0.9, epsilon 1e-3):
   nominal vs robust on the held-back half, worst-5 % attenuation and P(unstable) with its interval,
   for several random splits (``--split-seeds``).
3. Acceptance 3: the same on the 2 % noise posterior: where the robust Rs moves, and why, for
   ``--split-seeds`` splits; then for ``--noise-seeds`` more 2 % noise recordings (seeds 1, 2, ...,
   each with its own Hankel ring count and posterior, not saved).
4. Acceptance 4: the UD + NL mixture (equal weights: no evidence is computed here) against each
   model's own robust shunt, each evaluated on both posteriors; then R0 and the Table-6-style
   design of I, II, III, UD and NL fitted to the bundled data by both procedures (``polished``,
   the default, and the paper's two steps), each evaluated on every draw of the NL posterior.
5. The ohmmeter prior: UD's R0 posterior and robust shunt with and without it, on the NL posterior.

Seeded throughout; the same command prints the same numbers (times aside).
"""

from __future__ import annotations

import argparse
import io
import math
import sys
import time
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np

from bayes_emt import build_model, simulate
from bayes_emt.api import read_posterior
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.estimation.hankel import select_rings
from bayes_emt.inference.priors import apply_priors
from bayes_emt.inference.sampling import sample_posterior
from bayes_emt.io.datasets import PAPER_BENCH_SEED, load_paper_bench
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.shunt import design_rc_shunt
from bayes_emt.shunt.batch.plant import BatchPlant
from bayes_emt.shunt.draws import mixture_weights, sample_mixture
from bayes_emt.shunt.risk import clopper_pearson, summary
from bayes_emt.shunt.robust import design_robust_shunt
from bayes_emt.shunt.saa import DrawPool

NOISY_SEED = 20261124
OHMMETER = {"seed": 2026, "rel_error": 0.005}


def posterior(work: Path, name: str, meas, model, seed: int = 1, max_steps: int | None = None):
    """The posterior ``work/name.nc`` (sampled, checkpointed and saved if absent)."""
    out = work / f"{name}.nc"
    if out.exists():
        return read_posterior(out)
    ckpt = work / f"{name}.h5"
    t = time.perf_counter()
    post = sample_posterior(meas, model, seed=seed, checkpoint=ckpt, resume=ckpt.exists(), progress=False,
                            max_steps=max_steps)
    post.save(out)
    print(f"  sampled {name}: {post.n_steps} steps, converged {post.converged}, "
          f"{time.perf_counter() - t:.0f} s")
    return post


def ohmmeter_model(model, reading):
    """``model`` with R0's prior from an ohmmeter reading [ohm] of the stated accuracy."""
    return apply_priors(model, {"R0": {"dist": "lognormal", "median": reading,
                                       "sigma_log": OHMMETER["rel_error"]}}, where="ohmmeter")[0]


def held_line(label, rep):
    a = rep["attenuation_db"]
    q95 = "unstable" if a["q95"] is None else f"{a['q95']:.4f}"
    lo, hi = rep["p_unstable_ci"]
    return (f"  {label:<8} Rs {rep['Rs']:.5f} ohm  Cs {rep['Cs']:.5g} F  median {a['median']:.4f} dB  "
            f"worst-5 % (q95) {q95} dB  P(unstable) {rep['p_unstable']:.3g} (95 % CI {lo:.3g} .. {hi:.3g}, "
            f"{rep['n_draws']} held-back draws)")


def on_draws(post, Rs, Cs, n: int = 1000, seed: int = 0):
    """A shunt on ``n`` draws of ``post``: attenuation summary, P(unstable) with CI, margins."""
    groups, _ = sample_mixture([(post.model, post.theta(), "")], [1.0], n, seed=seed)
    bp = BatchPlant(post.model, groups[0].thetas)
    ev = DrawPool([(bp, np.arange(bp.n))]).evaluate(Rs, Cs)
    k = int(np.count_nonzero(~ev.stable))
    return {"att": summary(ev.attenuation), "p": k / bp.n, "ci": clopper_pearson(k, bp.n),
            "margin_min": float(np.min(ev.margin)), "margin_med": float(np.median(ev.margin))}


def move_line(label, d) -> str:
    """One line: where the robust Rs moved, whether the boundary test explains it, the steepness."""
    st, fr = d["steepness"], d["boundary_side_fraction"]
    return (f"{label}: robust Rs - nominal Rs = {d['delta_Rs_ohm'] * 1e3:+.3f} mOhm ({d['side']}); "
            f"the stability boundary explains it: {d['boundary_explains']} (boundary-side draws: "
            f"{100 * fr['all']:.0f} % of all, {100 * fr['worst_10pct']:.0f} % of the nominal's worst 10 %; "
            f"missing a draw's own Rs by {st['delta_ohm'] * 1e3:.3f} mOhm costs {st['loss_down_db']:+.4f} dB "
            f"down, {st['loss_up_db']:+.4f} up)")


def fmt_eval(e) -> str:
    a = e["att"]

    def f(v):
        return "unstable" if not math.isfinite(v) else f"{v:7.2f}"

    return (f"{f(a['median'])} [{f(a['q05'])}, {f(a['q95'])}] dB   P(unstable) {e['p']:.3f} "
            f"({e['ci'][0]:.3f}..{e['ci'][1]:.3f})   margin min {e['margin_min']:+.4f} ohm")


def run(args) -> None:
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    bench = load_paper_bench()
    nl, ud = build_model("NL"), build_model("UD")
    print("# Shunt design under uncertainty on the bundled data (scripts/robust_shunt_study.py)")
    print(f"draws {args.draws}, CVaR_0.9, epsilon 1e-3; posteriors in {work}\n")
    print("## posteriors")
    p_nl = posterior(work, "bench_NL5", bench, nl)
    p_ud = posterior(work, "bench_UD", bench, ud)
    noisy = simulate(nl, PAPER_TABLES["NL"], noise=0.02, seed=NOISY_SEED, source="NL Table 5, 2 % noise")
    n2 = select_rings(noisy).rings
    p_nl2 = posterior(work, f"noise2_NL{n2}", noisy, build_model("NL", rings=n2))
    rng = np.random.default_rng(OHMMETER["seed"])
    truth_r0 = PAPER_TABLES["NL"]["R0"]
    reading = truth_r0 * (1 + OHMMETER["rel_error"] * rng.standard_normal())
    ud_ohm = ohmmeter_model(ud, reading)
    p_udo = posterior(work, "bench_UD_ohmmeter", bench, ud_ohm)
    for name, p in (("NL(5), bundled", p_nl), ("UD, bundled", p_ud), ("UD + ohmmeter R0 prior", p_udo),
                    (f"NL({n2}), 2 % noise", p_nl2)):
        r0 = summary(p.theta()[:, p.model.params.index("R0")])
        print(f"  {name:<24} converged {p.converged}, {p.draws.shape[0] * p.draws.shape[1]} draws kept; "
              f"R0 {r0['median']:.4f} [{r0['q05']:.4f}, {r0['q95']:.4f}] ohm")
    print(f"  (truth R0 = {truth_r0} ohm; the ohmmeter read {reading:.4f} ohm, 0.5 % accuracy)\n")

    def robust(posts, seed=0, **kw):
        w, note = mixture_weights([None] * len(posts))
        groups, warns = sample_mixture([(p.model, p.theta(), p.model.label) for p in posts], w, args.draws,
                                       seed=seed)
        return design_robust_shunt(groups, seed=seed, notes=[note] + warns, **kw)

    print("## acceptance 2: NL posterior of the bundled data, held-back half")
    better = 0
    for s in range(args.split_seeds):
        t = time.perf_counter()
        res = robust([p_nl], seed=s)
        rep = res.to_json_dict()
        dq = rep["robust"]["attenuation_db"]["q95"] - rep["nominal"]["attenuation_db"]["q95"]
        better += dq < 0
        print(f"split seed {s} ({time.perf_counter() - t:.1f} s): robust worst-5 % minus nominal's: "
              f"{dq * 1e3:+.3f} mdB")
        print(held_line("nominal", rep["nominal"]))
        print(held_line("robust", rep["robust"]))
    print(f"robust worst-5 % better than nominal on {better} of {args.split_seeds} splits")
    print("why (split 0 shown last): " + rep["why"]["text"] + "\n")

    print(f"## acceptance 3: NL({n2}) posterior of 2 % noise data (ring count by Hankel singular values)")
    for s in range(args.split_seeds):
        rep = robust([p_nl2], seed=s).to_json_dict()
        if s == 0:
            print(held_line("nominal", rep["nominal"]))
            print(held_line("robust", rep["robust"]))
            first = rep
        print(move_line(f"split seed {s}", rep["why"]))
    d = first["why"]
    print("why (split 0): " + d["text"])
    print("margins [ohm]: nominal " + ", ".join(f"{k} {v:.4f}" for k, v in d["nominal_margin_ohm"].items())
          + "; robust " + ", ".join(f"{k} {v:.4f}" for k, v in d["robust_margin_ohm"].items()))
    print("R0: " + first["r0"]["statement"])
    up = explained = total = 0
    for ns in range(1, args.noise_seeds + 1):
        data = simulate(nl, PAPER_TABLES["NL"], noise=0.02, seed=ns,
                        source=f"NL Table 5, 2 % noise, seed {ns}")
        n = select_rings(data).rings
        t = time.perf_counter()
        post = sample_posterior(data, build_model("NL", rings=n), seed=1, progress=False)
        print(f"2 % noise recording seed {ns}: NL({n}), {post.n_steps} steps, converged {post.converged}, "
              f"{time.perf_counter() - t:.0f} s")
        for s in range(args.split_seeds):
            d = robust([post], seed=s).to_json_dict()["why"]
            up += d["delta_Rs_ohm"] > 0
            explained += d["boundary_explains"]
            total += 1
            print(move_line(f"  split seed {s}", d))
    if total:
        print(f"over {total} splits of {args.noise_seeds} more recordings: robust Rs less negative in {up}, "
              f"the boundary test explains the move in {explained}")
    print()

    print("## acceptance 4: UD + NL mixture (equal weights) against each model's own robust shunt")
    mix = robust([p_ud, p_nl])
    own = {"UD only": robust([p_ud]), "NL(5) only": robust([p_nl]), "mixture": mix}
    for w in mix.warnings:
        print(f"  warning: {w}")
    print(f"  {'design':<11} {'Rs [ohm]':>9} {'Cs [F]':>8}   on the UD posterior{'':<38}"
          "on the NL(5) posterior")
    for name, r in own.items():
        ev_ud = on_draws(p_ud, r.robust.Rs, r.robust.Cs, args.draws)
        ev_nl = on_draws(p_nl, r.robust.Rs, r.robust.Cs, args.draws)
        print(f"  {name:<11} {r.robust.Rs:9.5f} {r.robust.Cs:8.5f}   {fmt_eval(ev_ud)}   |   "
              f"{fmt_eval(ev_nl)}")
    print("  R0 per model: " + "; ".join(f"{k}: {v['R0']['median']:.4f} ohm"
                                          for k, v in mix.to_json_dict()["r0"]["per_model"].items()))
    print("\n## Table-6-style designs from least-squares fits of the bundled data, on the NL(5) posterior")
    print(f"  {'model':<6} {'procedure':<9} {'R0 [ohm]':>9} {'Rs [ohm]':>9} {'Cs [F]':>8}   "
          "on every draw of the NL posterior: attenuation median [q05, q95], P(unstable) (95 % CI), margin")
    for name in ("I", "II", "III", "UD", "NL"):
        m = build_model(name)
        for proc in ("polished", "paper"):
            fit = fit_admittance(bench, m, polish=(proc == "polished"))
            dsg = design_rc_shunt(m, fit.theta)
            ev = on_draws(p_nl, dsg.Rs, dsg.Cs, args.draws)
            print(f"  {m.label:<6} {proc:<9} {fit.parameters['R0']:9.4f} {dsg.Rs:9.4f} {dsg.Cs:8.4f}   "
                  f"{fmt_eval(ev)}")
    print()
    print("## ohmmeter prior on R0 (UD, the inadequate model): robust shunt without and with it, on NL(5)")
    for name, p in (("UD", p_ud), ("UD + ohmmeter", p_udo)):
        r = robust([p])
        ev = on_draws(p_nl, r.robust.Rs, r.robust.Cs, args.draws)
        r0 = summary(p.theta()[:, p.model.params.index("R0")])
        print(f"  {name:<14} R0 {r0['median']:.4f} [{r0['q05']:.4f}, {r0['q95']:.4f}] ohm  robust Rs "
              f"{r.robust.Rs:.5f} ohm, Cs {r.robust.Cs:.5f} F  ->  on NL(5): {fmt_eval(ev)}")
        print(f"  {'':<14} its own report: " + r.to_json_dict()["r0"]["statement"].split(". ")[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", default="robust_shunt_work", help="folder for the posterior files (reused)")
    ap.add_argument("--draws", type=int, default=1000)
    ap.add_argument("--split-seeds", type=int, default=5)
    ap.add_argument("--noise-seeds", type=int, default=4, help="more 2 %% noise recordings for acceptance 3")
    ap.add_argument("--out", default=None, help="also write the printout here")
    args = ap.parse_args(argv)
    buf = io.StringIO()

    class Tee(io.TextIOBase):
        def write(self, s):
            sys.__stdout__.write(s)
            sys.__stdout__.flush()
            return buf.write(s)

    t = time.perf_counter()
    with redirect_stdout(Tee()):
        run(args)
        print(f"\n(total {time.perf_counter() - t:.0f} s; bundled data seed {PAPER_BENCH_SEED})")
    if args.out:
        from bayes_emt._atomic import atomic_write_text

        atomic_write_text(args.out, buf.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
