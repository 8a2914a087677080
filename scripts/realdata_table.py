"""Fit every real recording in ../shared/realdata with every model; print the rms relative residual.

    .venv/bin/python scripts/realdata_table.py [--realdata ../shared/realdata]

Band choices follow ../shared/realdata/README.md: the LS10-44 .zma file is used above 10 Hz and
without its last point; the run2 .txt files (very noisy above 1 kHz) up to 1 kHz.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

from bayes_emt import build_model
from bayes_emt.fitting import fit_admittance
from bayes_emt.io import read_measurement

TWO_PI = 2 * math.pi
#: file -> (reader options, (f_min, f_max) in Hz or None)
FILES = {
    "dayton_LS10-44.zma": ({}, (10.0, 20000.0)),
    "dayton_LS10-44_freeair_run2.txt": ({"freq_unit": "hz"}, (10.0, 1000.0)),
    "dayton_LS10-44_added100g_run2.txt": ({"freq_unit": "hz"}, (10.0, 1000.0)),
    "seas_E0018_freeair.zma": ({}, None),
    "koan_mid_sealed.zma": ({}, None),
    "koan_tweeter.zma": ({}, None),
}
MODELS = ("I", "II", "III", "UD", "NL", "UL")


def load(folder: Path, name: str):
    opts, band = FILES[name]
    meas = read_measurement(folder / name, **opts)
    if band is not None:
        meas = meas.select(TWO_PI * band[0], TWO_PI * band[1])
    return meas


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--realdata", default=str(Path(__file__).resolve().parents[2] / "shared" / "realdata"))
    args = ap.parse_args(argv)
    folder = Path(args.realdata)
    print(f"{'file':<36}" + "".join(f"{m:>9}" for m in MODELS) + "   seconds")
    for name in FILES:
        meas = load(folder, name)
        cells, t0 = [], time.perf_counter()
        for m in MODELS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_admittance(meas, build_model(m))
            cells.append(f"{fit.rms_rel_residual:9.4f}")
        print(f"{name:<36}" + "".join(cells) + f"   {time.perf_counter() - t0:7.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
