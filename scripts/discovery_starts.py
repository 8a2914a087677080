"""Start-independence and the default output on every real recording (issue 35, acceptance 1 and 2;
issue 34, acceptance 2).

One command::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_starts.py \
        [--out scripts/results/discovery_starts] [--starts UD NL(5) III] [--only FILE ...]

Every recording in ../shared/realdata (the six of :data:`bayes_emt.io.datasets.REALDATA_FILES` in
their useful band, and the DATS exports from 10 Hz up: their rows below repeat the analyser's
resolution) is diagnosed from each start (one worker, no time budget: the same answer on any
machine). Per run: the final model, its findings, its log evidence on the searched points [nats],
whether its final model has a defect (:func:`bayes_emt.discovery.sanity.defects`), the number of lines
the default output prints
(the header and :func:`bayes_emt.discovery.summary.summary_lines`), CPU seconds and the load average.
Per recording the table says whether every start reached the same final model, else the spread of
their log evidence (a tie when within 2 nats). Runs are written as they finish (``runs/*.json``,
resumed on a re-run); the table is ``table.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path

from bayes_emt._atomic import atomic_write_text
from bayes_emt.discovery import diagnose
from bayes_emt.discovery.diagnose import SEARCH_PER_DECADE, START_FAMILIES
from bayes_emt.discovery.sanity import defects
from bayes_emt.discovery.summary import MAX_LINES, summary_lines
from bayes_emt.errors import DataFormatError
from bayes_emt.evidence.fit_evidence import fit_log_evidence
from bayes_emt.io import read_measurement
from bayes_emt.io.datasets import REALDATA_FILES, load_concealed_bench, load_realdata
from bayes_emt.models import parse_model_spec

REAL = Path(os.environ.get("BAYES_EMT_REALDATA",
                          Path(__file__).resolve().parents[2] / "shared" / "realdata"))
DATS = ("grs_12SW-4HE_dats_0h.txt", "scanspeak_18W-4424G00_dats_0h.txt",
        "sb_SB26STAC-C000-4_dats_freeair.txt")
CONCEALED = "concealed_bench.csv"  # the bundled recording with a concealed fixture mode
TIE_NATS = 2.0


def load(name: str):
    if name == CONCEALED:
        return load_concealed_bench()
    if name in REALDATA_FILES:
        return load_realdata(REAL, name)
    return read_measurement(REAL / name).select(2 * math.pi * 10.0, None)


def run_one(name: str, start: str, out: Path, starts=()) -> dict:
    path = out / "runs" / f"{name}__{start}.json"
    if path.exists():
        return json.loads(path.read_text())
    meas = load(name)
    t = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = diagnose(meas, parse_model_spec(start), workers=1, time_budget=None, starts=starts)
        lz = fit_log_evidence(meas.thin(SEARCH_PER_DECADE), d.final_fit).log_z
    cpu = time.process_time() - t
    lines = 1 + len(summary_lines(d, max_lines=MAX_LINES - 1))
    rec = {"file": name, "start": start, "final_model": d.final_model,
           "findings": [f.physics for f in d.findings], "final_log_z": lz,
           "defects": defects(d.final_fit, d.final_fit.model.names),
           "default_output_lines": lines, "summary": summary_lines(d, max_lines=MAX_LINES - 1),
           "warnings": list(d.warnings), "cpu_seconds": cpu, "load_average_1min": os.getloadavg()[0],
           "budget_hit": d.budget_hit, "all_starts": bool(starts)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(rec, indent=1, default=float))
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="scripts/results/discovery_starts")
    ap.add_argument("--starts", nargs="*", default=["UD", "NL(5)", "III"])
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--first-only", nargs="*", default=None, metavar="FILE",
                    help="these recordings from the first start alone: every diagnosis searches from UD, "
                         "III and NL(5) whatever its start, so the others repeat the same searches (the "
                         "table says which rows were run from one start)")
    ap.add_argument("--all-starts", action="store_true",
                    help="every diagnosis searches from UD, III and NL(5) too (diagnose --all-starts, "
                         "API starts=START_FAMILIES) and keeps the final comparison's answer")
    a = ap.parse_args(argv)
    out = Path(a.out)
    every = [*REALDATA_FILES, *DATS, CONCEALED]
    names = [n for n in a.only if n in every] if a.only else every  # in the order given
    recs = {}
    for n in names:  # every start of a recording in turn: a partial run holds whole rows
        for start in a.starts:
            if a.first_only is not None and n in a.first_only and start != a.starts[0]:
                continue
            p = out / "runs" / f"{n}__{start}.json"
            if a.report_only and not p.exists():
                continue
            try:
                r = run_one(n, start, out, START_FAMILIES if a.all_starts else ())
            except DataFormatError as e:  # the DATS exports: this branch's reader refuses them
                print(f"{n}: not read: {e}", flush=True)
                continue
            recs[(n, start)] = r
            print(f"{n:40s} {start:6s} -> {r['final_model']:45s} log Z {r['final_log_z']:.1f} "
                  f"lines {r['default_output_lines']} defects {len(r['defects'])} {r['cpu_seconds']:.0f} s",
                  flush=True)
    rows = ["| recording | " + " | ".join(f"from {s}" for s in a.starts) + " | same final model | "
            "log Z spread [nats] | default output lines (max) | each start's own search reached |",
            "|---|" + "---|" * len(a.starts) + "---|---|---|---|"]
    for n in names:
        rs = [recs.get((n, s)) for s in a.starts]
        got = [r for r in rs if r]
        if not got:
            continue
        finals = {r["final_model"] for r in got}
        lzs = [r["final_log_z"] for r in got
               if r["final_log_z"] is not None and math.isfinite(r["final_log_z"])]
        spread = max(lzs) - min(lzs) if len(lzs) > 1 else 0.0
        if len(got) < 2:
            same = "one start run" + (" (its diagnosis searched from UD, III and NL(5))"
                                      if got[0].get("all_starts") else "")
        elif len(finals) == 1:
            same = "yes"
        elif len(lzs) < len(got):
            same = "NO (a final model's evidence failed)"
        else:
            same = "tie (within 2 nats)" if spread <= TIE_NATS else "NO"
        cells = [f"{r['final_model']} (log Z {r['final_log_z']:.1f}{', DEFECT' if r['defects'] else ''})"
                 if r else "-" for r in rs]
        reached = next((w.split("reached: ", 1)[1].split(". ", 1)[0].split("; final comparison")[0]
                        for w in got[0]["warnings"] if w.startswith("the searches from")), "-")
        rows.append(f"| {n} | " + " | ".join(cells) + f" | {same} | {spread:.1f} | "
                    f"{max(r['default_output_lines'] for r in got)} | {reached} |")
    rows += ["", "Per run: CPU seconds of the diagnosis and its evidence, the 1-minute load average at "
             "its end, "
             "the defects of its final model (every parameter checked).", "",
             "| recording | start | all starts | CPU s | load | defects |", "|---|---|---|---|---|---|"]
    rows += [f"| {n} | {s} | {'yes' if r.get('all_starts') else 'no'} | {r['cpu_seconds']:.0f} | "
             f"{r['load_average_1min']:.1f} | {'; '.join(r['defects']) or 'none'} |"
             for (n, s), r in recs.items()]
    atomic_write_text(out / "table.md", "\n".join(rows) + "\n")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
