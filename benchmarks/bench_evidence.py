"""Model comparison by evidence on the bundled data: seconds and likelihood calls per model.

Two ways in:

* ``python benchmarks/bench_evidence.py [--models I,II,III,UD,UL,NL] [--nlive N] [--seed S]``
  runs the full comparison (``bayes_emt.evidence.compare.compare_models``) on
  ``bayes_emt.io.datasets.load_paper_bench()``, prints seconds and calls per model and stage, and
  merges ``{"evidence_seconds": {model: s}, "evidence_calls": ..., "evidence_total_seconds": s}``
  into ``benchmarks/results.json`` (atomically; other keys kept). Target (issue 11): all six
  models in < 600 s on the 2-core machine; exit code 1 when missed.
* ``benchmarks/run.py`` loads :data:`BENCHMARKS` like every ``bench_*.py``: one unit of nested
  sampling's inner work (a queue of 16 random walks of ``20 + k`` steps on the NL(5) likelihood,
  batched), so the cost per likelihood call is compared side by side with a baseline revision
  (a baseline without ``bayes_emt.evidence`` reports it as missing, as run.py does for any
  benchmark its tree predates).

Time scales with calls: the full run's seconds ≈ calls / (likelihood evaluations per second) +
dynesty's own bookkeeping; the per-stage calls are printed so the figure can be projected for a
faster likelihood.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results.json"
TARGET_SECONDS = 600.0

_cases: dict = {}


def setup():
    from bayes_emt import build_model
    from bayes_emt.evidence.batching import BatchingPool, batched_random_walk
    from bayes_emt.inference.likelihood import Likelihood
    from bayes_emt.io.datasets import load_paper_bench
    from bayes_emt.reference import PAPER_TABLES

    lik = Likelihood(build_model("NL"), load_paper_bench())
    theta = np.r_[lik.model.vector(PAPER_TABLES["NL"]), 0.002, 1e-7]
    # the unit-cube position of theta (inverse of the prior transform: every prior is log-uniform)
    lo, hi = lik.params.bounds_z()
    u0 = (lik.params.to_z(theta) - lo) / (hi - lo)
    pool = BatchingPool(lik, lik.params.prior_transform, 16)
    _cases["walk"] = (pool, u0, lik, batched_random_walk)


def _walk():
    from collections import namedtuple

    pool, u0, lik, walk = _cases["walk"]
    Arg = namedtuple("Arg", "u loglstar axes scale rseed kwargs")
    k = u0.size
    args = [Arg(u0, -np.inf, np.eye(k) * 1e-6, 1.0, np.random.default_rng(i), {"walks": 20 + k})
            for i in range(16)]
    return walk(args, pool._prior_batch, pool._evaluate)


BENCHMARKS = {"nested_walk_queue16_NL5": _walk}


def _show(m, reused) -> None:
    stages = {k: round(v, 1) for k, v in m.seconds.items()}
    print(f"{m.name}: {m.seconds_total:.0f} s, calls {m.calls}, seconds {stages}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", default="I,II,III,UD,UL,NL")
    ap.add_argument("--nlive", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(RESULTS))
    args = ap.parse_args(argv)

    from bayes_emt._atomic import atomic_write_text
    from bayes_emt.api import as_model
    from bayes_emt.evidence.compare import CompareSettings, compare_models
    from bayes_emt.evidence.nested import NestedSettings
    from bayes_emt.io.datasets import load_paper_bench

    nested = NestedSettings() if args.nlive is None else NestedSettings(n_live=args.nlive)
    settings = CompareSettings(seed=args.seed, nested=nested)
    specs = [(m, as_model(m)) for m in args.models.split(",")]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        cmp = compare_models(load_paper_bench(), specs, settings=settings, workdir=tmp,
                             on_model=_show)
    total = time.perf_counter() - t0
    out = Path(args.out)
    data = json.loads(out.read_text()) if out.exists() else {}
    data["evidence_seconds"] = {m.name: round(m.seconds_total, 2) for m in cmp.models}
    data["evidence_calls"] = {m.name: m.calls for m in cmp.models}
    data["evidence_total_seconds"] = round(total, 2)
    data["evidence_settings"] = settings.to_dict()
    atomic_write_text(out, json.dumps(data, indent=2))
    print(f"total {total:.0f} s for {len(specs)} models (target < {TARGET_SECONDS:.0f} s); wrote {out}")
    return 0 if total < TARGET_SECONDS else 1


if __name__ == "__main__":
    sys.exit(main())
