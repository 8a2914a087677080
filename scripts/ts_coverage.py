"""Coverage of the T/S intervals on simulated drivers of known T/S (issue 22, acceptance 1 and 3).

Cases (``bayes_emt.thiele_small.simulate``; a 6.5" woofer: Mms 14.9 g, fs 42 Hz, Qms 3, Bl 7 T m,
Re 5.7 Ω, Sd 133 cm², semi-inductance (Leach) coil L0 0.2 mH, K 0.02, n 0.6):

* ``mass``: free air + two added masses (10 g, 20 g), model ``I+semi_inductance``;
* ``creep``: the same with LOG creep (λ = 0.05 per e-fold), model ``I+semi_inductance+suspension_creep``;
  the truth of fs and Qms is the cited convention's (:mod:`bayes_emt.thiele_small.relations`);
* ``volume``: free air + a sealed 10 L box (added volume), model ``I+semi_inductance``.

Each seed draws new noise (0.5 % relative, complex Gaussian on Z) on ``--points`` log-spaced
frequencies over 10 Hz–2 kHz. Per parameter the fraction of seeds whose 90 % interval holds the
truth is printed (acceptance: ≥ 80 % for every parameter; for ``volume``, Vas).

    .venv/bin/python scripts/ts_coverage.py --seeds 20 --fast            # Laplace intervals, ~3 min
    .venv/bin/python scripts/ts_coverage.py --seeds 5 --cases mass,creep  # posterior, ~1 min a run

Results append to ``scripts/results/ts_coverage.jsonl`` (one record per case, seed and method)
and the summary is written to ``scripts/results/ts_coverage_<method>.txt``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver

RESULTS = Path(__file__).resolve().parent / "results"
CASES = {"mass": "I+semi_inductance", "creep": "I+semi_inductance+suspension_creep",
         "volume": "I+semi_inductance"}


def run_case(case: str, seed: int, *, fast: bool, points: int, noise: str = "white") -> dict:
    spec = CASES[case]
    if case == "volume":
        sim = simulate_driver(spec, deltas=(), box_volume=0.010, seed=seed, n_points=points)
        kw = {"box": sim.box}
    else:
        sim = simulate_driver(spec, seed=seed, n_points=points)
        kw = {"loaded": list(sim.loaded)}
    t0 = time.perf_counter()
    r = thiele_small(sim.free, spec, sd=sim.sd, fast=fast, seed=seed, models_for_spread=[], noise=noise, **kw)
    inside = {k: bool(p["ci90"][0] <= sim.truth[k] <= p["ci90"][1]) for k, p in r.parameters.items()}
    # the model's own interval (before the definitional spread between methods) and the width ratio
    model_ci = {k: p.get("ci90_model") or p["ci90"] for k, p in r.parameters.items()}
    inside_model = {k: bool(c[0] <= sim.truth[k] <= c[1]) for k, c in model_ci.items()}
    ratio = {k: (p["ci90"][1] - p["ci90"][0]) / (model_ci[k][1] - model_ci[k][0])
             for k, p in r.parameters.items() if model_ci[k][1] > model_ci[k][0]}
    return {"case": case, "seed": seed, "method": "laplace" if fast else "posterior", "points": points,
            "noise": noise,
            "seconds": time.perf_counter() - t0, "inside": inside, "inside_model": inside_model,
            "width_ratio_to_model": ratio,
            "truth": {k: sim.truth[k] for k in r.parameters},
            "value": {k: p["value"] for k, p in r.parameters.items()},
            "ci90": {k: p["ci90"] for k, p in r.parameters.items()},
            "warnings": [w["code"] for w in r.warnings]}


def summary(records: list[dict]) -> str:
    lines = []
    for case in CASES:
        recs = [r for r in records if r["case"] == case]
        if not recs:
            continue
        names = list(recs[0]["inside"])
        cov = {n: np.mean([r["inside"][n] for r in recs if n in r["inside"]]) for n in names}
        lines.append(f"{case} ({CASES[case]}), {len(recs)} seeds, {recs[0]['method']} intervals, "
                     f"{recs[0]['points']} points per recording, "
                     f"median {np.median([r['seconds'] for r in recs]):.1f} s")
        covm = {n: np.mean([r["inside_model"][n] for r in recs if n in r.get("inside_model", {})] or [np.nan])
                for n in names}
        wr = {n: np.median([r["width_ratio_to_model"][n] for r in recs
                            if n in r.get("width_ratio_to_model", {})] or [np.nan]) for n in names}
        lines += [f"  {n:20s} coverage {100 * c:5.1f} %{'' if c >= 0.8 else '  < 80 %'}"
                  f"   model's own {100 * covm[n]:5.1f} %, width ratio {wr[n]:.2f} (median)"
                  for n, c in cov.items()]
        lines.append(f"  {'all parameters':20s} coverage {100 * np.mean(list(cov.values())):5.1f} %   "
                     f"model's own {100 * np.nanmean(list(covm.values())):5.1f} %, largest median width "
                     f"ratio {np.nanmax(list(wr.values())):.2f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--cases", default="mass,creep,volume")
    ap.add_argument("--fast", action="store_true",
                    help="Laplace (fit covariance) intervals, not the posterior")
    ap.add_argument("--points", type=int, default=600)
    ap.add_argument("--noise", choices=["correlated", "white"], default="white",
                    help="the likelihood's noise (default white, as ts; correlated: the model-discrepancy "
                         "likelihood)")
    ap.add_argument("--no-save", action="store_true")
    args = ap.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    bad = [c for c in cases if c not in CASES]
    if bad:
        ap.error(f"unknown case(s) {bad}; choose from {list(CASES)}")
    records = []
    for case in cases:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            rec = run_case(case, seed, fast=args.fast, points=args.points, noise=args.noise)
            records.append(rec)
            miss = [k for k, v in rec["inside"].items() if not v]
            print(f"{case} seed {seed}: {rec['seconds']:.1f} s, outside: {miss or 'none'}", flush=True)
            if not args.no_save:
                RESULTS.mkdir(exist_ok=True)
                with open(RESULTS / "ts_coverage.jsonl", "a", encoding="utf-8") as fh:
                    fh.write(json.dumps(rec) + "\n")
    text = summary(records)
    print(text)
    if not args.no_save:
        method = "laplace" if args.fast else "posterior"
        (RESULTS / f"ts_coverage_{method}.txt").write_text(
            f"scripts/ts_coverage.py --seeds {args.seeds} --cases {args.cases} --points {args.points}"
            f"{' --fast' if args.fast else ''}\n{text}\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
