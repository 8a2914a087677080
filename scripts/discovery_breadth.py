"""What the diagnosis's breadth costs and buys (issue 23, speed): the search with it cut.

One command::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        .venv/bin/python scripts/discovery_breadth.py --out DIR

Three parts of the search were each added to fix a miss of the concealed-effect benchmark: every
catalogue term polished from its three best starts (:data:`bayes_emt.discovery.name.STARTS_POLISHED`),
the two leading terms fitted again the full way (``REFINE_TOP``), and the masked pairs tried when a
patch leads (``_masked_jobs``). This script cuts all three (one start, no refit, no masked pairs;
nothing else changes) and runs, on that narrowed search:

1. the concealed-effect benchmark (``scripts/discovery_benchmark.py --out DIR/concealed``), whose
   summary is set beside the stored full search's (``scripts/results/discovery/scores.json``);
2. ``benchmarks/bench_diagnose.py`` on ../shared/realdata (the diagnosis against one UD fit of the
   same file, the oracle floor), its rows set beside the stored full search's
   (``benchmarks/results.json``).

Written to ``DIR/breadth.json`` and ``DIR/breadth.md``. The knobs are set in this process before
the diagnosis's worker processes are forked, so they hold there too. A measurement, not an
option: the library's search is the full one.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import runpy
import sys
from pathlib import Path

from bayes_emt._atomic import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]


def narrow() -> None:
    """Cut the three parts of the search (module docstring), in this process."""
    import bayes_emt.discovery.name as name

    name.STARTS_POLISHED = 1
    name.REFINE_TOP = 0
    name._masked_jobs = lambda *a, **k: []


def _run(path: Path, argv: list[str], capture: bool = True) -> str:
    """Run the script at ``path`` with ``argv`` as ``__main__``; its standard output (printed
    instead when not ``capture``)."""
    buf, old = io.StringIO(), sys.argv
    sys.argv = [str(path), *argv]
    try:
        with contextlib.redirect_stdout(buf) if capture else contextlib.nullcontext():
            try:
                runpy.run_path(str(path), run_name="__main__")
            except SystemExit as e:
                if e.code not in (0, None):
                    raise
    finally:
        sys.argv = old
    return buf.getvalue()


def _rows(details: dict) -> dict:
    """The per-recording rows of a ``bench_diagnose`` result's ``details`` (``{}`` when it had no
    recordings)."""
    rows = details.get("diagnose_realdata", {})
    return rows.get("rows", {}) if isinstance(rows, dict) else {}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder for the results (created)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    narrow()
    _run(ROOT / "scripts" / "discovery_benchmark.py", ["--out", str(out / "concealed")], capture=False)
    scores_n = json.loads((out / "concealed" / "scores.json").read_text())
    scores_f = json.loads((ROOT / "scripts" / "results" / "discovery" / "scores.json").read_text())
    narrowed, full = scores_n["summary"], scores_f["summary"]
    for summary, scores in ((narrowed, scores_n), (full, scores_f)):
        summary["seconds_total"] = round(sum(c["seconds"] for c in scores["cases"]), 1)
    found_f = {c["name"]: c["found"] for c in scores_f["cases"]}
    changed = [(c["name"], found_f.get(c["name"]), c["found"]) for c in scores_n["cases"]
               if sorted(c["found"]) != sorted(found_f.get(c["name"]) or [])]
    real = _rows(json.loads(_run(ROOT / "benchmarks" / "bench_diagnose.py", [])).get("details", {}))
    stored = json.loads((ROOT / "benchmarks" / "results.json").read_text())
    full_real = _rows(stored.get("details", {}).get("bench_diagnose", {}))
    keys = ["effects_named", "effects", "cases_right", "cases", "patch_findings_in_lookalikes",
            "null_cases_with_finding", "null_seeds_with_finding", "seconds_total"]
    record = {"concealed": {"full": {k: full.get(k) for k in keys},
                            "narrowed": {k: narrowed.get(k) for k in keys},
                            "changed": [{"case": n, "full": f, "narrowed": g} for n, f, g in changed]},
              "realdata": {"narrowed": real, "full": full_real}}
    lines = ["# The search with its breadth cut (scripts/discovery_breadth.py)", "",
             "## Concealed-effect benchmark", "", "| figure | full search | narrowed |", "|---|---|---|"]
    lines += [f"| {k} | {full.get(k)} | {narrowed.get(k)} |" for k in keys]
    what = [f"{n} (full: {', '.join(f or []) or 'none'}; narrowed: {', '.join(g) or 'none'})"
            for n, f, g in changed]
    lines += ["", "Cases whose findings change: " + ("; ".join(what) or "none")]
    lines += ["", "## ../shared/realdata (one run each; wall x one UD fit of the same file)", "",
              "| recording | full: x UD fit | full: final model | narrowed: x UD fit "
              "| narrowed: final model | oracle floor (CPU x) |", "|---|---|---|---|---|---|"]
    for n, r in real.items():
        f = full_real.get(n, {})
        lines.append(f"| {n} | {f.get('ratio', float('nan')):.0f} | {f.get('final_model', '-')} | "
                     f"{r['ratio']:.0f} | {r['final_model']} | {r['oracle_floor_x_one_ud_fit_cpu']:.1f} |")
    if not real:
        lines.append("(no recordings: ../shared/realdata is absent)")
    atomic_write_text(out / "breadth.json", json.dumps(record, indent=1) + "\n")
    atomic_write_text(out / "breadth.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
