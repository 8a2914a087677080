"""Fit every real recording in ../shared/realdata with every model; print the rms relative residual,
then each fit's warnings (bayes_emt.estimation.adequacy; ``--messages`` prints them in full).

    .venv/bin/python scripts/realdata_table.py [--realdata ../shared/realdata] [--messages]

Band choices follow ../shared/realdata/README.md: the LS10-44 .zma file is used above 10 Hz and
without its last point; the run2 .txt files (very noisy above 1 kHz) up to 1 kHz.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

from bayes_emt import build_model
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io.datasets import REALDATA_FILES, load_realdata

MODELS = ("I", "II", "III", "UD", "NL", "UL")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--realdata", default=str(Path(__file__).resolve().parents[2] / "shared" / "realdata"))
    ap.add_argument("--messages", action="store_true", help="print every warning's message")
    args = ap.parse_args(argv)
    folder = Path(args.realdata)
    print(f"{'file':<36}" + "".join(f"{m:>9}" for m in MODELS) + "   seconds", flush=True)
    found = []
    for name in REALDATA_FILES:
        meas = load_realdata(folder, name)
        cells, t0 = [], time.perf_counter()
        for m in MODELS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_admittance(meas, build_model(m))
            cells.append(f"{fit.rms_rel_residual:9.4f}")
            found.append((name, fit.model.label, fit.warnings))
        print(f"{name:<36}" + "".join(cells) + f"   {time.perf_counter() - t0:7.1f}", flush=True)
    print("\nwarnings (model_inadequate, parameter_at_bound, not_identifiable, resonance_outside_data):")
    for name, label, warns in found:
        print(f"{name:<36} {label:<6} " + (", ".join(w["code"] for w in warns) or "-"))
        if args.messages:
            for w in warns:
                print(f"    [{w['code']}] {w['message']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
