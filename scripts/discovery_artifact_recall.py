"""Instrument-step recall of discrepancy discovery (issue 35, acceptance 4).

One command::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_artifact_recall.py \\
        [--out scripts/results/artifact_recall] [--workers 1] [--part 1/2]

Runs the concealed benchmark's step cases (:func:`discovery_benchmark.step_cases`: NL(5) and UD
plants, 0.2 % noise, 500 points over 10-1e5 rad/s, a range switch at 3000 rad/s with every phase
step of 5, 10 and 25 times the noise and every magnitude step of 1 and 3 times, plus the issue's own
switch on NL(5), 0.4 % and 0.05 rad; two seeds each: 26 recordings), each diagnosed from its
plant's base model (:func:`bayes_emt.discovery.diagnose`, ``seed=0``), and scores the fraction
named ``measurement_artifact`` overall and among the cases whose phase step is at least 10 times
the noise (the acceptance asks >= 90 % there). Beside each case it records what decided about the
step: for every round in which ``measurement_artifact`` was a candidate, its Δ log Z [nats],
whether it was accepted, why not (the step test, undetermined parameters) and the choice's words
(the patch margin with its ℓ). Each case is written to ``--out/cases/NAME.json`` as the benchmark
writes it (resumed on a re-run; ``--part i/n`` runs every n-th case, for parallel processes); the
table is ``artifact_recall.md`` and ``artifact_recall.json``, over every case finished.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import discovery_benchmark as bench

from bayes_emt._atomic import atomic_write_text

ARTIFACT = "measurement_artifact"


def decision(r: dict) -> list[dict]:
    """Per round where the step was a candidate: its Δ log Z, acceptance, problem and the choice."""
    out = []
    for t in r["diagnosis"].get("tried", []):
        for c in t["candidates"]:
            if ARTIFACT not in c["physics"].split("+"):
                continue
            out.append({"round": t["round"], "physics": c["physics"],
                        # None: a step the measured points do not show, refused before its evidence
                        "delta_log_evidence": (None if c["delta_log_evidence"] is None
                                               or not math.isfinite(c["delta_log_evidence"])
                                               else round(c["delta_log_evidence"], 1)),
                        "accepted": c["accepted"], "patch_problem": c["patch_problem"],
                        "choice": [n for n in t.get("choice", []) if ARTIFACT in n]})
    return out


def record(c: dict, r: dict) -> dict:
    eff = c["effects"][ARTIFACT]
    return {"name": r["name"], "base": c["base"], "seed": c["seed"],
            "phase_x_noise": round(eff["psi_s"] / c["noise"]),
            "mag_x_noise": round(eff["delta_s"] / c["noise"]),
            "named": ARTIFACT in r["found"], "found": r["found"], "final_model": r["final_model"],
            "cpu_seconds": r["cpu_seconds"], "seconds": r["seconds"], "decision": decision(r)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="scripts/results/artifact_recall")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--only", nargs="*", default=None, help="run only these cases (the table: every case "
                    "already finished)")
    ap.add_argument("--part", default="1/1", help="i/n: run every n-th case starting at the i-th")
    ap.add_argument("--time-budget", type=float, default=0.0,
                    help="the diagnosis's wall-clock budget [s] (default 0: none, so that the machine's load "
                         "cannot cut a search)")
    ap.add_argument("--report-only", action="store_true", help="tabulate the finished cases, run nothing")
    a = ap.parse_args(argv)
    try:
        i, n = (int(x) for x in a.part.split("/"))
        if not 1 <= i <= n:
            raise ValueError
    except ValueError:
        ap.error(f"--part {a.part!r}: give i/n with 1 <= i <= n")
    bench.WORKERS = a.workers
    bench.TIME_BUDGET = a.time_budget
    out = Path(a.out)
    recs = []
    # the issue's own switch first, then the acceptance's cases (phase step >= 10x the noise, largest
    # first), the 5x ones last
    def rank(c):
        e = c["effects"][ARTIFACT]
        return (-round(e["psi_s"] / c["noise"]), round(e["delta_s"] / c["noise"]) != 2, c["base"], c["seed"])

    order = sorted(bench.step_cases(), key=rank)
    for k, c in enumerate(order):
        done = (out / "cases" / f"{c['name']}.json").exists()
        mine = k % n == i - 1 and (a.only is None or c["name"] in a.only)
        if not done and (a.report_only or not mine):
            continue
        recs.append(record(c, bench.run_case(c, out)))
        x = recs[-1]
        print(f"{x['name']:28s} {'yes' if x['named'] else 'NO '} found {','.join(x['found']) or '-'} "
              f"{x['cpu_seconds']:.0f} CPU s", flush=True)
    recs.sort(key=lambda x: (x["base"], x["phase_x_noise"], x["mag_x_noise"], x["seed"]))
    strong = [x for x in recs if x["phase_x_noise"] >= 10]
    summary = {
        "cases": len(recs),
        "named": sum(x["named"] for x in recs),
        "phase_at_least_10x": len(strong),
        "named_phase_at_least_10x": sum(x["named"] for x in strong),
        "recall_phase_at_least_10x": sum(x["named"] for x in strong) / len(strong) if strong else None,
        "other_findings": sum(len([p for p in x["found"] if p != ARTIFACT]) for x in recs),
        "cpu_seconds_median": sorted(x["cpu_seconds"] for x in recs)[len(recs) // 2] if recs else None,
    }
    rows = []
    for x in recs:
        why = "; ".join(
            f"r{d['round']} {d['physics']} "
            + ("(no evidence) " if d["delta_log_evidence"] is None else f"{d['delta_log_evidence']:g} nats ")
            + ("accepted" if d["accepted"] else f"refused: {d['patch_problem'] or 'not accepted'}")
            + ("" if not d["choice"] else " / " + " / ".join(d["choice"]))
            for d in x["decision"]) or "never a candidate"
        rows.append(f"| {x['name']} | {x['phase_x_noise']} | {x['mag_x_noise']} | "
                    f"{', '.join(x['found']) or '-'} | {'yes' if x['named'] else 'NO'} | "
                    f"{x['cpu_seconds']:.0f} | {why.replace('|', '/')} |")
    table = ["| case | phase step / noise | magnitude step / noise | found | artifact named | CPU s | "
             "what decided about the step |",
             "|---|---|---|---|---|---|---|", *rows, "", "```\n" + json.dumps(summary, indent=1) + "\n```"]
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "artifact_recall.md", "\n".join(table) + "\n")
    atomic_write_text(out / "artifact_recall.json", json.dumps({"summary": summary, "cases": recs}, indent=1))
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
