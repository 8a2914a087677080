"""Joint evidence on the LS10-44 added-mass pair (issue 23): diagnose the free-air run, check each
finding on the run with 0.100 kg added (``be.diagnose(..., also=[(B, 0.100)])``), diagnose that run
too and check each term only it names on the free-air run (:func:`bayes_emt.discovery.joint.search_other`).

One command::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_joint_pair.py \
        [--out scripts/results/discovery_realdata_margin] [--time-budget 240] [--reuse]

Reads ../shared/realdata (the files are not in the repository) as
:data:`bayes_emt.io.datasets.REALDATA_FILES` says (10 Hz-1 kHz), writes ``joint_pair.json`` (the
diagnosis with its ``joint`` record) and prints what the second recording says of each finding.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import warnings
from pathlib import Path

import bayes_emt as be
from bayes_emt._atomic import atomic_write_text
from bayes_emt._record import render_text
from bayes_emt.io.datasets import load_realdata

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
PAIR = ("dayton_LS10-44_freeair_run2.txt", "dayton_LS10-44_added100g_run2.txt", 0.100)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="scripts/results/discovery_realdata_margin")
    ap.add_argument("--time-budget", type=float, default=240.0, help="CPU s of the diagnosis (0: none)")
    ap.add_argument("--setup", default="free-air")
    ap.add_argument("--reuse", action="store_true",
                    help="take the diagnosis from --out/joint_pair.json and redo only the joint check")
    a = ap.parse_args(argv)
    if not REAL.is_dir():
        print(f"{REAL} is absent: nothing to do", file=sys.stderr)
        return 2
    base, loaded = (load_realdata(REAL, n) for n in PAIR[:2])
    out = Path(a.out)
    if a.reuse and not (out / "joint_pair.json").is_file():
        print(f"--reuse: {out / 'joint_pair.json'} does not exist (run once without --reuse)",
              file=sys.stderr)
        return 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if a.reuse:
            from bayes_emt.discovery.diagnose import Diagnosis
            from bayes_emt.discovery.joint import with_second_recordings

            d = Diagnosis.from_json_dict(json.loads((out / "joint_pair.json").read_text()))
            d = with_second_recordings(dataclasses.replace(
                d, joint=(), warnings=tuple(w for w in d.warnings if "(joint evidence)" not in w)),
                base, [(loaded, PAIR[2])],
                search={"setup": a.setup, "time_budget": a.time_budget or None})
        else:
            d = be.diagnose(base, setup=a.setup, time_budget=a.time_budget or None,
                            also=[(loaded, PAIR[2])], progress=lambda m: print("   ", m, flush=True))
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "joint_pair.json", json.dumps(d.to_json_dict(), indent=1))
    print(d.headline())
    # the joint-evidence tables of the diagnosis (both ways), then the joint added-mass fits
    print(render_text([t for t in d.tables() if "joint evidence" in t.title]))
    for j in d.joint:
        for which, r in j.get("added_mass", {}).items():
            print(f"  joint added-mass fit, {which}: {json.dumps(r)}")
    for w in d.warnings:
        print("warning:", w)
    return 0


if __name__ == "__main__":
    sys.exit(main())
