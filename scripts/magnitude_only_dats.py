"""|Z|-only against |Z|-and-phase Thiele-Small parameters on the three real DATS exports.

For each file and model: ``thiele_small`` (posterior intervals, seed 1) with the phase, and again
with the phase dropped (``read_options={"magnitude_only": True}``); prints a Markdown table of fs,
Re, Qms, Qes: the |Z|-only value, its relative difference from the with-phase value, and whether
the |Z|-only 90 % interval contains the with-phase value; then how many of the four |Z|-only values
the with-phase 90 % intervals contain, and the departure of the recorded phase from the
minimum-phase partner of |Z| near resonance (``bayes_emt.thiele_small.bode``, on the with-phase
result's curve). CPU seconds per run (one thread).
``auto``: the model the evidence supports (``ts``'s default), chosen separately for each run.

    OMP_NUM_THREADS=1 .venv/bin/python scripts/magnitude_only_dats.py [--models auto,UD,UD+semi_inductance]
        [--band-over-fs 10]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.bode import phase_departure

REAL = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"
FILES = ["grs_12SW-4HE_dats_0h.txt", "scanspeak_18W-4424G00_dats_0h.txt",
         "sb_SB26STAC-C000-4_dats_freeair.txt"]
NAMES = ("fs", "Re", "Qms", "Qes")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default="UD")
    ap.add_argument("--json", default=None)
    ap.add_argument("--band-over-fs", type=float, default=None,
                    help="fit up to this multiple of DATS's own fs (e.g. 10): the coil model matters less")
    args = ap.parse_args()
    rows, out = [], []
    for model in args.models.split(","):
        for name in FILES:
            res = {}
            f_range = None
            if args.band_over_fs:
                from bayes_emt.io import read_measurement

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    fs = read_measurement(REAL / name).meta["bench_fit"]["values"]["fs"]
                f_range = (None, args.band_over_fs * fs)
            for mag in (False, True):
                t = time.process_time()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = thiele_small(REAL / name, None if model == "auto" else model, seed=1,
                                     read_options={"magnitude_only": mag}, f_range_hz=f_range)
                res[mag] = (r.to_json_dict()["parameters"], time.process_time() - t)
                if not mag:
                    dep = phase_departure(r.curve, r.parameters["fs"]["value"])
            p, m = res[False][0], res[True][0]
            cells = []
            for n in NAMES:
                v, vm, (lo, hi) = p[n]["value"], m[n]["value"], m[n]["ci90"]
                cells.append(f"{vm:.4g} ({100 * (vm / v - 1):+.2f} %, {'in' if lo <= v <= hi else 'OUT'})")
            back = sum(p[n]["ci90"][0] <= m[n]["value"] <= p[n]["ci90"][1] for n in NAMES)
            rows.append(f"| {name} | {model} | " + " | ".join(cells)
                        + f" | {back}/{len(NAMES)} | {dep['max_deg']:.2f} ({dep['noise_deg']:.3f})"
                        + f" | {res[False][1]:.0f} / {res[True][1]:.0f} |")
            out.append({"file": name, "model": model, "with_phase": p, "magnitude_only": m,
                        "phase_departure": dep,
                        "cpu_s": [res[False][1], res[True][1]]})
            print(rows[-1], flush=True)
    print("| file | model | " + " | ".join(f"{n}: |Z|-only (vs with phase, interval)" for n in NAMES)
          + " | with-phase ci90 holds |Z|-only | phase departure deg (noise) | CPU s (phase / |Z|) |")
    print("\n".join(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
