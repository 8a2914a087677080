"""Simulation-based calibration of the posterior's credible intervals (issue 4, acceptance 1).

For each of N datasets: draw a truth around the paper's values for the model (Table 4 for UD:
independent log-normal scatter of ``--scatter`` = 20 % per parameter), simulate it with
``--noise`` = 0.2 % relative complex noise on ``--points`` log-spaced frequencies over
10..1e5 rad/s (300 by default instead of the paper's 2000, to keep 100 runs affordable on two
shared cores; the posterior is then wider, not differently shaped), fit it, sample the posterior
with the default sampler settings, and record whether each parameter's 90 % central credible
interval covers the truth. A calibrated posterior covers in 90 % of the datasets; with N = 100
the binomial standard error is 3 %, so 90 ± 5 % is the acceptance band.

Also recorded: ``sigma_rel`` (its truth is the simulated noise level), convergence, steps, τ.
Results are appended to a JSON-lines file as each dataset finishes (``--out``), so an
interrupted run resumes where it stopped (datasets are seeded by their index); datasets run in
a process pool (``--jobs``).

    OMP_NUM_THREADS=1 .venv/bin/python scripts/calibrate_posterior.py --n 100 --jobs 2 \\
        --out scripts/results/calibration_UD.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np


def one(index: int, seed: int, model_name: str, points: int, max_steps: int, scatter: float,
        noise: float) -> dict:
    """Simulate, fit and sample dataset ``index``; return its coverage record."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from bayes_emt import build_model, simulate
    from bayes_emt.inference.sampling import sample_posterior
    from bayes_emt.reference import PAPER_TABLES

    model = build_model(model_name)
    rng = np.random.default_rng([seed, index])
    base = model.vector(PAPER_TABLES[model_name])
    truth = base * np.exp(scatter * rng.standard_normal(base.size))
    omega = np.geomspace(10, 1e5, points)
    meas = simulate(model, truth, omega, noise=noise, seed=int(rng.integers(2**31)))
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            post = sample_posterior(meas, model, seed=index, max_steps=max_steps, progress=False)
    except Exception as exc:  # a failed dataset is recorded, not hidden
        return {"index": index, "error": f"{type(exc).__name__}: {exc}", "trace": traceback.format_exc(),
                "truth": truth.tolist(), "seconds": time.perf_counter() - t0}
    names = list(model.names) + ["sigma_rel"]
    full = np.r_[truth, noise]
    x = post.flat()[:, : len(names)]
    lo, hi = np.quantile(x, [0.05, 0.95], axis=0)
    return {"index": index, "names": names, "truth": full.tolist(), "q05": lo.tolist(), "q95": hi.tolist(),
            "median": np.median(x, axis=0).tolist(),
            "covered": ((lo <= full) & (full <= hi)).tolist(), "converged": post.converged,
            "n_steps": post.n_steps, "tau_max": float(np.max(post.tau)), "ess_min": float(np.min(post.ess)),
            "seconds": time.perf_counter() - t0}


def table(records: list[dict], model_name: str, points: int) -> str:
    """The coverage table: per parameter, the fraction of datasets whose 90 % interval covers."""
    ok = [r for r in records if "covered" in r]
    failed = len(records) - len(ok)
    names = ok[0]["names"]
    cov = np.array([r["covered"] for r in ok], float)
    n = cov.shape[0]
    se = 100 * np.sqrt(0.9 * 0.1 / n)
    lines = [f"{n} datasets, model {model_name}, {points} points, 90 % central credible intervals "
             f"({sum(r['converged'] for r in ok)} converged, {failed} failed); binomial s.e. {se:.1f} %",
             f"median steps {np.median([r['n_steps'] for r in ok]):.0f}, median tau_max "
             f"{np.median([r['tau_max'] for r in ok]):.0f}, "
             f"median {np.median([r['seconds'] for r in ok]):.0f} s per dataset",
             f"{'parameter':<10} {'coverage':>9}  within 90 +- 5 %"]
    for j, name in enumerate(names):
        p = 100 * cov[:, j].mean()
        lines.append(f"{name:<10} {p:8.1f}%  {'yes' if 85 <= p <= 95 else 'NO'}")
    lines.append(f"{'all':<10} {100 * cov.mean():8.1f}%")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="number of datasets")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    ap.add_argument("--model", default="UD", help="model (truths around its paper table)")
    ap.add_argument("--points", type=int, default=300, help="frequencies per dataset")
    ap.add_argument("--max-steps", type=int, default=20000, help="sampler budget per dataset")
    ap.add_argument("--scatter", type=float, default=0.2, help="log-normal scatter of the truths")
    ap.add_argument("--noise", type=float, default=0.002, help="relative noise of the simulation")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--out", default="calibration_UD.jsonl", help="JSON-lines results (appended)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    done = {}
    if out.exists():
        for line in out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[r["index"]] = r
    todo = [i for i in range(args.n) if i not in done]
    print(f"{len(done)} datasets already done, {len(todo)} to go", file=sys.stderr)
    with ProcessPoolExecutor(max_workers=args.jobs) as pool, out.open("a") as fh:
        futs = [pool.submit(one, i, args.seed, args.model, args.points, args.max_steps, args.scatter,
                            args.noise) for i in todo]
        for k, fut in enumerate(as_completed(futs), start=1):
            r = fut.result()
            done[r["index"]] = r
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            what = (f"covered {sum(r['covered'])}/{len(r['covered'])}, converged {r['converged']}"
                    if "covered" in r else f"FAILED {r['error']}")
            print(f"[{k}/{len(todo)}] dataset {r['index']}: {what}, {r['seconds']:.0f} s", file=sys.stderr,
                  flush=True)
    print(table([done[i] for i in sorted(done) if i < args.n], args.model, args.points))
    return 0


if __name__ == "__main__":
    sys.exit(main())
