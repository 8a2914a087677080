"""Coverage of the T/S 90 % intervals when the model is wrong: data from NL(3) + LOG creep,
fitted with UD (no creep, a different coil), free air plus one added mass of 10 g.

The simulated driver is :data:`bayes_emt.thiele_small.simulate.DEFAULT_DRIVER`'s mechanics and
Re (Mms 14.9 g, fs 42 Hz, Qms 3, Bl 7 T m, Re 5.7 Ω; LOG creep λ = 0.05 per e-fold, Knudsen &
Jensen) with the coil of the paper's NL model (its first three rings: ``PAPER_TABLES["NL"]``),
recorded with 0.5 % complex Gaussian noise on ``--points`` log-spaced frequencies over 10 Hz-2 kHz.
The truth of fs and Qms is the LOG-creep convention's (fs at zero mechanical reactance,
:mod:`bayes_emt.thiele_small.relations`). Per parameter (fs, Re, Qms, Qes, Bl, Mms) the fraction of
seeds whose 90 % interval holds the truth is printed, for each ``--noise``, for the default ``ci90``
(the model's posterior with the definitional spread between methods) and the model's own
``ci90_model`` (acceptance: ≥ 80 % with the default). ``--fit UD`` runs ``ts --model UD`` as a user
would: the model spread's candidates (other coil models, UD with each physics term ts tries) enter
the interval by their evidence; ``--no-spread`` leaves them out. ``--fit auto`` runs ``ts`` as a user would
without naming a model: the evidence then chooses among its candidates (which include NL(3) with
creep), and the same figures are printed for that choice.

    OMP_NUM_THREADS=1 .venv/bin/python scripts/ts_wrong_model.py --seeds 20 --noise correlated,white

Records append to ``scripts/results/ts_wrong_model.jsonl``; the summary goes to
``scripts/results/ts_wrong_model.txt``.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

from bayes_emt.reference import PAPER_TABLES
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver

RESULTS = Path(__file__).resolve().parent / "results"
SPEC = "NL(3)+suspension_creep"
FIT = "UD"
NAMES = ("fs", "Re", "Qms", "Qes", "Bl", "Mms")
COIL = {k: PAPER_TABLES["NL"][k] for k in ("Pg", "P1", "P2", "P3", "R1", "R2", "R3")}


def run_case(seed: int, *, noise: str, points: int, fit: str = FIT, spread: bool = True) -> dict:
    sim = simulate_driver(SPEC, driver=COIL, deltas=(0.010,), seed=seed, n_points=points)
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if fit == "auto":  # ts's default: the model the evidence supports, the mixture's candidates
            r = thiele_small(sim.free, loaded=list(sim.loaded), sd=sim.sd, seed=seed, noise=noise)
        else:  # the model named, as ``ts --model UD``: its spread's candidates weighed against it
            r = thiele_small(sim.free, fit, loaded=list(sim.loaded), sd=sim.sd, seed=seed, noise=noise,
                             **({} if spread else {"models_for_spread": []}))
    weights = r.inputs.get("mixture", {}).get("weights", {})
    out = {"seed": seed, "noise": noise, "fit": fit, "spread": spread, "model": r.model, "points": points,
           "mixture": {m: round(float(w), 4) for m, w in weights.items()},
           "cpu_s": time.process_time() - c0,
           "wall_s": time.perf_counter() - t0, "intervals": r.inputs.get("intervals", "model"), "inside": {},
           "inside_model": {}, "half_width_pct": {}, "half_width_model_pct": {}, "error_pct": {}}
    for k in NAMES:
        p, t = r.parameters[k], sim.truth[k]
        lo, hi = p["ci90"]
        out["inside"][k] = bool(lo <= t <= hi)
        out["half_width_pct"][k] = 100 * (hi - lo) / 2 / p["value"]
        mlo, mhi = p.get("ci90_model") or p["ci90"]  # the model's own interval, before the spread
        out["inside_model"][k] = bool(mlo <= t <= mhi)
        out["half_width_model_pct"][k] = 100 * (mhi - mlo) / 2 / p["value"]
        out["error_pct"][k] = 100 * (p["value"] - t) / t
    return out


def summarise(recs: list[dict]) -> str:
    lines = []
    for noise, fit, spread in sorted({(r["noise"], r.get("fit", FIT), r.get("spread", False)) for r in recs}):
        rs = [r for r in recs if r["noise"] == noise and r.get("fit", FIT) == fit
              and r.get("spread", False) == spread]
        cov = {k: np.mean([r["inside"][k] for r in rs]) for k in NAMES}
        hw = {k: np.median([r["half_width_pct"][k] for r in rs]) for k in NAMES}
        err = {k: np.median(np.abs([r["error_pct"][k] for r in rs])) for k in NAMES}
        what = ("ts's default model choice (" + ", ".join(sorted({r["model"] for r in rs})) + ")"
                if fit == "auto" else fit + (" with its model spread (the mixture's weights: " + ", ".join(
                    sorted({m for r in rs for m, w in r.get("mixture", {}).items() if w >= 0.01})) + ")"
                    if spread else ", its spread off"))
        lines.append(f"{noise}: {len(rs)} seeds, {what} fitted to {SPEC}; coverage of the 90 % interval / "
                     "median half-width [%] / median |error| [%]")
        lines += [f"  {k:4s} {100 * cov[k]:5.0f} %  {hw[k]:6.2f}  {err[k]:6.2f}" for k in NAMES]
        lines.append(f"  all  {100 * np.mean([r['inside'][k] for r in rs for k in NAMES]):5.0f} %")
        if all("inside_model" in r for r in rs):
            lines.append("  the model's own interval (ci90_model): coverage / median half-width [%]")
            lines += [f"  {k:4s} {100 * np.mean([r['inside_model'][k] for r in rs]):5.0f} %  "
                      f"{np.median([r['half_width_model_pct'][k] for r in rs]):6.2f}" for k in NAMES]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--points", type=int, default=400)
    ap.add_argument("--noise", default="correlated,white")
    ap.add_argument("--fit", default=FIT, help="the model fitted (default UD, the wrong one), or 'auto': "
                    "ts without a model, the one the evidence supports among its candidates")
    ap.add_argument("--no-spread", action="store_true", help="with a named model: no model spread "
                    "(models_for_spread=[]), the model's posterior alone")
    ap.add_argument("--no-save", action="store_true")
    a = ap.parse_args(argv)
    recs = []
    RESULTS.mkdir(exist_ok=True)
    for noise in a.noise.split(","):
        for seed in range(a.seeds):
            rec = run_case(seed, noise=noise, points=a.points, fit=a.fit, spread=not a.no_spread)
            recs.append(rec)
            print(json.dumps(rec), flush=True)
            if not a.no_save:
                with open(RESULTS / "ts_wrong_model.jsonl", "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
    text = summarise(recs)
    print(text)
    if not a.no_save:
        if a.fit == FIT and a.no_spread:  # the study as first run: UD alone
            name = "ts_wrong_model.txt"
        elif a.fit == "auto" or a.no_spread:
            name = f"ts_wrong_model_{a.fit}.txt"
        else:  # a named model with its spread
            name = f"ts_wrong_model_{a.fit}_spread.txt"
        (RESULTS / name).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
