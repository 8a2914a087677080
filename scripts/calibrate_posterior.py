"""Simulation-based calibration of the posterior's credible intervals (issue: posterior, point 1).

For each of N datasets: draw a truth around the paper's Table 4 UD values (independent
log-normal scatter of 20 % per parameter), simulate it with 0.2 % relative complex noise on
``--points`` log-spaced frequencies over 10..1e5 rad/s, fit, sample the posterior, and record
whether each parameter's 90 % central credible interval covers the truth. Coverage should be
90 % ± 5 % (binomial standard error at N = 100: 3 %).

Results are appended to a JSON-lines file as each dataset finishes (``--out``), so an
interrupted run resumes where it stopped; datasets run in a process pool (``--jobs``).

    .venv/bin/python scripts/calibrate_posterior.py --n 100 --jobs 2 --out calibration_UD.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

MODEL = "UD"
SCATTER = 0.2


def one(index: int, seed: int, points: int, max_steps: int) -> dict:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from bayes_emt import build_model, simulate
    from bayes_emt.reference import PAPER_TABLES
    from bayes_emt.sampling import sample_posterior

    model = build_model(MODEL)
    rng = np.random.default_rng([seed, index])
    base = model.vector(PAPER_TABLES[MODEL])
    truth = base * np.exp(SCATTER * rng.standard_normal(base.size))
    omega = np.geomspace(10, 1e5, points)
    meas = simulate(model, truth, omega, noise=0.002, seed=int(rng.integers(2**31)))
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = sample_posterior(meas, model, seed=index, max_steps=max_steps, progress=False)
    x = post.flat()[:, : model.ndim]
    lo, hi = np.quantile(x, [0.05, 0.95], axis=0)
    return {"index": index, "truth": truth.tolist(), "q05": lo.tolist(), "q95": hi.tolist(),
            "covered": ((lo <= truth) & (truth <= hi)).tolist(), "converged": post.converged,
            "n_steps": post.n_steps, "tau_max": float(np.max(post.tau)),
            "seconds": time.perf_counter() - t0}


def table(records: list[dict]) -> str:
    from bayes_emt import build_model

    names = build_model(MODEL).names
    cov = np.array([r["covered"] for r in records], float)
    n = cov.shape[0]
    lines = [f"{n} datasets, model {MODEL}, 90 % central credible intervals "
             f"({sum(r['converged'] for r in records)} runs converged)",
             f"{'parameter':<10} {'coverage':>9} {'binomial s.e.':>14}"]
    for j, name in enumerate(names):
        p = cov[:, j].mean()
        lines.append(f"{name:<10} {100 * p:8.1f}% {100 * np.sqrt(0.9 * 0.1 / n):13.1f}%")
    lines.append(f"{'all':<10} {100 * cov.mean():8.1f}%")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--max-steps", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--out", default="calibration_UD.jsonl")
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
        futs = [pool.submit(one, i, args.seed, args.points, args.max_steps) for i in todo]
        for k, fut in enumerate(as_completed(futs), start=1):
            r = fut.result()
            done[r["index"]] = r
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(f"[{k}/{len(todo)}] dataset {r['index']}: covered {sum(r['covered'])}/{len(r['covered'])}, "
                  f"{r['seconds']:.0f} s, converged {r['converged']}", file=sys.stderr)
    print(table([done[i] for i in sorted(done) if i < args.n]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
