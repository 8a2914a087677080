"""Run every benchmark in this folder and print times beside the stored baseline.

Each ``bench_*.py`` module defines ``BENCHMARKS``: a dict ``name -> callable`` (no arguments; one
call is one timed unit of work) and optionally ``setup()`` run once before timing. Times are the
median of ``--repeat`` calls after one warm-up call.

    .venv/bin/python benchmarks/run.py                 # compare with benchmarks/baseline.json
    .venv/bin/python benchmarks/run.py --save-baseline # store this machine's times as the baseline
    .venv/bin/python benchmarks/run.py -k shunt        # only benchmarks whose name contains 'shunt'

Targets (acceptance numbers such as "< 10 s for all six fits") are printed beside the times;
they are checked here, never in timed unit tests.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
BASELINE = HERE / "baseline.json"


def load_modules():
    for path in sorted(HERE.glob("bench_*.py")):
        spec = importlib.util.spec_from_file_location(path.stem, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        if hasattr(mod, "BENCHMARKS"):
            yield path.stem, mod


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("-k", default="", help="substring filter on benchmark names")
    ap.add_argument("--save-baseline", action="store_true")
    args = ap.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    baseline = json.loads(BASELINE.read_text()) if BASELINE.exists() else {"times": {}}
    times, targets = {}, {}
    print(f"{'benchmark':<44} {'baseline [s]':>12} {'now [s]':>10} {'ratio':>7} {'target [s]':>10}")
    for modname, mod in load_modules():
        if hasattr(mod, "setup"):
            mod.setup()
        for name, fn in mod.BENCHMARKS.items():
            full = f"{modname}.{name}"
            if args.k not in full:
                continue
            fn()  # warm-up (imports, caches)
            runs = []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                fn()
                runs.append(time.perf_counter() - t0)
            t = statistics.median(runs)
            times[full] = t
            target = getattr(mod, "TARGETS", {}).get(name)
            targets[full] = target
            base = baseline["times"].get(full)
            ratio = f"{t / base:7.2f}" if base else "    new"
            tgt = "" if target is None else f"{target:>9.3g}{'✓' if t < target else '✗'}"
            print(f"{full:<44} {base if base else float('nan'):>12.4f} {t:>10.4f} {ratio} {tgt:>10}")
    if args.save_baseline:
        rec = {"machine": f"{platform.machine()} {platform.processor()} cpus={os.cpu_count()}",
               "python": sys.version.split()[0], "times": {**baseline["times"], **times}}
        BASELINE.write_text(json.dumps(rec, indent=2) + "\n")
        print(f"baseline written to {BASELINE}")
    missed = [k for k, t in times.items() if targets.get(k) is not None and t >= targets[k]]
    if missed:
        print("targets missed: " + ", ".join(missed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
