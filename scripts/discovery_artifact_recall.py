"""Instrument-step recall of discrepancy discovery (issue 35, acceptance 4).

One command::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_artifact_recall.py \
        [--out scripts/results/discovery] [--workers 1]

Runs the concealed benchmark's step cases (:func:`discovery_benchmark.step_cases`: NL(5) and UD
plants, 0.2 % noise, a range switch at 3000 rad/s with phase steps 5, 10 and 25 times the noise and
magnitude steps 1 or 3 times, two seeds each: 12 cases), each diagnosed from its plant's base model, and
scores the fraction named ``measurement_artifact`` overall and among the cases whose phase step is
at least 10 times the noise (the acceptance asks >= 90 % there). Each case is written to
``--out/cases/NAME.json`` as the benchmark writes it (resumed on a re-run); the table is
``artifact_recall.md`` and ``artifact_recall.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import discovery_benchmark as bench

from bayes_emt._atomic import atomic_write_text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="scripts/results/discovery")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--only", nargs="*", default=None, help="run only these cases (the table: every case "
                    "already finished)")
    a = ap.parse_args(argv)
    bench.WORKERS = a.workers
    out = Path(a.out)
    rows, recs = [], []
    for c in bench.step_cases():
        done = (out / "cases" / f"{c['name']}.json").exists()
        if a.only is not None and c["name"] not in a.only:
            if not done:
                continue
        r = bench.run_case(c, out)
        eff = c["effects"]["measurement_artifact"]
        px = round(eff["psi_s"] / c["noise"])
        mx = round(eff["delta_s"] / c["noise"])
        named = "measurement_artifact" in r["found"]
        recs.append({"name": r["name"], "phase_x_noise": px, "mag_x_noise": mx, "named": named,
                     "found": r["found"], "final_model": r["final_model"], "cpu_seconds": r["cpu_seconds"]})
        rows.append(f"| {r['name']} | {r['start']} | {px} | {mx} | {', '.join(r['found']) or '-'} | "
                    f"{'yes' if named else 'NO'} | {r['cpu_seconds']:.0f} |")
        print(rows[-1], flush=True)
    strong = [x for x in recs if x["phase_x_noise"] >= 10]
    summary = {
        "cases": len(recs),
        "named": sum(x["named"] for x in recs),
        "phase_at_least_10x": len(strong),
        "named_phase_at_least_10x": sum(x["named"] for x in strong),
        "recall_phase_at_least_10x": sum(x["named"] for x in strong) / len(strong) if strong else None,
        "other_findings": sum(len([p for p in x["found"] if p != "measurement_artifact"]) for x in recs),
    }
    table = ["| case | start | phase step / noise | magnitude step / noise | found | artifact named "
             "| CPU s |",
             "|---|---|---|---|---|---|---|", *rows, "", "```\n" + json.dumps(summary, indent=1) + "\n```"]
    atomic_write_text(out / "artifact_recall.md", "\n".join(table) + "\n")
    atomic_write_text(out / "artifact_recall.json", json.dumps({"summary": summary, "cases": recs}, indent=1))
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
