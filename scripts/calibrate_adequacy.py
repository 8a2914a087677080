"""Calibrate the fit-adequacy detector (bayes_emt.estimation.adequacy) by simulation.

Two populations, each fitted by ``fit_admittance`` and summarised by the detector's statistics
(largest local residual rms in units of the local noise, ``rho_max``; the runs-test z-score; the
lag-1 correlation) and the warning codes the fit carries:

* adequate: data simulated by the model that fits them (NL(5) at Table 5, UD at Table 4, I at
  Table 1; the paper's 2000 log points over 1e1..1e5 rad/s, 0.2 % relative complex noise, seeds
  0..N-1), and the bundled dataset fitted with NL(5). ``model_inadequate`` must never fire;
* inadequate: a driver in a vented box (tests/vented_box.py, SPEC §7 ``enclosure_port``; four
  loudspeaker-like parameter sets, noise 0.2, 0.5 and 1 %) fitted with UD and NL(5); it must fire;
* control: the same four drivers in free air (no port: exactly UD), 0.2 and 1 % noise, fitted
  with UD; it must not fire.

    OMP_NUM_THREADS=1 .venv/bin/python scripts/calibrate_adequacy.py --seeds 20 \\
        --out scripts/results/adequacy_calibration.jsonl

Prints one line per fit and the ranges per population; appends JSON lines to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))  # the vented-box helper lives with the tests


def stats(meas, model) -> dict:
    from bayes_emt.estimation.adequacy import residual_structure
    from bayes_emt.estimation.fitting import fit_admittance

    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_admittance(meas, model)
    e = (model.admittance(meas.omega, fit.theta) - meas.Y) / np.abs(meas.Y)
    rs = residual_structure(e)
    return {"model": model.label, "rms_rel": fit.rms_rel_residual, "rho_max": rs.rho_max,
            "runs_z": rs.runs_z, "lag1": rs.lag1, "noise_median": float(np.median(rs.noise)),
            "codes": list(fit.warning_codes), "seconds": time.perf_counter() - t}


def cases(seeds: int):
    from vented_box import VENTED_CASES, simulate_vented_box

    from bayes_emt import build_model, simulate
    from bayes_emt.io.datasets import load_paper_bench
    from bayes_emt.reference import PAPER_TABLES

    yield "adequate", "bundled data", lambda: (load_paper_bench(), build_model("NL", rings=5))
    for name, table in (("NL", "NL"), ("UD", "UD"), ("I", "I")):
        for seed in range(seeds):
            def make(name=name, table=table, seed=seed):
                model = build_model(name)
                return simulate(model, PAPER_TABLES[table], noise=0.002, seed=seed), model
            yield "adequate", f"{name} simulated, seed {seed}", make
    for case in range(len(VENTED_CASES)):
        for noise in (0.002, 0.005, 0.01):
            for name in ("UD", "NL"):
                def make(case=case, noise=noise, name=name):
                    return simulate_vented_box(case, noise=noise, seed=case), build_model(name)
                yield "inadequate", f"vented box {case}, noise {noise:g}", make
    for case in range(len(VENTED_CASES)):
        for noise in (0.002, 0.01):
            def make(case=case, noise=noise):
                return simulate_vented_box(case, noise=noise, seed=case, port=False), build_model("UD")
            yield "control", f"free air {case}, noise {noise:g}", make


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--out", default=None, help="append JSON lines here")
    args = ap.parse_args(argv)
    rows = []
    for pop, label, make in cases(args.seeds):
        meas, model = make()
        rec = {"population": pop, "case": label, **stats(meas, model)}
        rows.append(rec)
        print(f"{pop:10s} {label:28s} {rec['model']:6s} rms {rec['rms_rel']:.4f} "
              f"rho_max {rec['rho_max']:8.2f} z {rec['runs_z']:6.1f} lag1 {rec['lag1']:5.2f} "
              f"{','.join(rec['codes']) or '-'} "
              f"({rec['seconds']:.1f} s)", flush=True)
        if args.out:
            with open(args.out, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
    for pop in ("adequate", "inadequate", "control"):
        sel = [r for r in rows if r["population"] == pop]
        fired = sum("model_inadequate" in r["codes"] for r in sel)
        rho = [r["rho_max"] for r in sel]
        print(f"{pop}: {len(sel)} fits, rho_max {min(rho):.3g}..{max(rho):.3g}, "
              f"runs z {min(r['runs_z'] for r in sel):.2f}..{max(r['runs_z'] for r in sel):.2f}, "
              f"model_inadequate fired {fired}/{len(sel)}; other codes: "
              + json.dumps({c: sum(c in r["codes"] for r in sel) for c in
                            ("parameter_at_bound", "not_identifiable", "resonance_outside_data")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
