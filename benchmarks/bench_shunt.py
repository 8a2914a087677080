"""Shunt design speed: one model's H∞-optimal RC shunt, stability included (target < 1 s each, issue 3).

    .venv/bin/python benchmarks/bench_shunt.py          # per-model time (median of 5 after a warm-up)
    .venv/bin/python benchmarks/run.py -k shunt         # the same through the common runner
"""

import os
import statistics
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from bayes_emt import build_model  # noqa: E402
from bayes_emt.reference import PAPER_TABLES  # noqa: E402
from bayes_emt.shunt import design_rc_shunt, evaluate_rc_shunt  # noqa: E402

MODELS = ("I", "II", "III", "UD", "NL")


def _design(name):
    model = build_model(name)
    theta = model.vector(PAPER_TABLES[name])

    def run():
        return design_rc_shunt(model, theta)

    return run


def _evaluate_on_nl():
    model = build_model("NL")
    theta = model.vector(PAPER_TABLES["NL"])

    def run():
        return evaluate_rc_shunt(model, theta, -2.40, 0.0814)

    return run


BENCHMARKS = {f"design_{name}": _design(name) for name in MODELS}
BENCHMARKS["evaluate_NL"] = _evaluate_on_nl()
TARGETS = {f"design_{name}": 1.0 for name in MODELS}


def main(repeat: int = 5) -> int:
    print(f"{'benchmark':<14} {'median [s]':>10} {'min [s]':>9} {'target [s]':>10}   result")
    missed = []
    for name, fn in BENCHMARKS.items():
        res = fn()  # warm-up
        runs = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            fn()
            runs.append(time.perf_counter() - t0)
        t = statistics.median(runs)
        target = TARGETS.get(name)
        mark = "" if target is None else f"{target:>9.3g}{'✓' if t < target else '✗'}"
        if target is not None and t >= target:
            missed.append(name)
        print(f"{name:<14} {t:>10.4f} {min(runs):>9.4f} {mark:>10}   Rs = {res.Rs:.4f} ohm, "
              f"Cs = {res.Cs:.4g} F, {res.attenuation_db:.2f} dB")
    if missed:
        print("targets missed: " + ", ".join(missed))
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
