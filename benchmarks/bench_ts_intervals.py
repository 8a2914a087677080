"""Free-air ``thiele_small`` with honest intervals on a real 344-row DATS export (one thread).

The recording is ``../shared/realdata/grs_12SW-4HE_dats_0h.txt`` (a GRS 12SW-4HE woofer on the
Dayton Audio Test System: 344 rows 1.03 Hz-20.6 kHz at 1/24 octave, of which the 77 rows below
10 Hz come in runs of one repeated value, below the analyser's resolution, and are dropped: 267
points from 9.5 Hz fitted). Two
runs of the whole call, each timed in CPU seconds (``time.process_time``) beside wall seconds and
the load average:

* ``default``: ``thiele_small(meas)``: the evidence-supported model among II, III, UD, NL(3) and
  the best with a semi-inductance or suspension creep, the correlated model-discrepancy
  likelihood, the evidence-weighted mixture over the candidates;
* ``white_UD``: ``thiele_small(meas, "UD", noise="white")``: the model and likelihood of
  ``ts`` before the discrepancy likelihood (plus the mixture's Laplace components of II and III).

Run on one core:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        .venv/bin/python benchmarks/run.py --no-compare -k ts_intervals

Target: the default run within 10 s (CPU) and within twice the white UD run. Skipped (no result)
when the recording is absent.
"""

import math
import os
import time
import warnings
from pathlib import Path

import numpy as np

from bayes_emt.measurement import Measurement
from bayes_emt.thiele_small import thiele_small

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata" / "grs_12SW-4HE_dats_0h.txt"


def read_dats(path: Path) -> Measurement:
    """The DATS export's ``Freq Impedance Phase`` rows (Hz, Ω, degrees), the ``*`` header lines
    skipped, the rows up to the last run of repeated rows below 20 Hz (below the analyser's
    resolution) dropped."""
    rows = []
    for line in path.read_text(encoding="latin-1").splitlines():
        parts = line.split()
        if not parts or line.lstrip().startswith("*"):
            continue
        try:
            rows.append([float(x) for x in parts[:3]])
        except ValueError:
            continue
    a = np.array(rows)
    # up to the last run of repeated rows below 20 Hz (the analyser's bins below its resolution)
    rep = np.flatnonzero(np.all(np.diff(a[:, 1:], axis=0) == 0, axis=1)) + 1
    a = a[int(rep[-1]) + 1:] if rep.size and a[rep[-1], 0] < 20.0 else a
    Z = a[:, 1] * np.exp(1j * np.deg2rad(a[:, 2]))
    return Measurement(2 * math.pi * a[:, 0], 1 / Z, meta={"source": path.name})


def _run(meas, *args, **kwargs):
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = thiele_small(meas, *args, seed=0, **kwargs)
    return r, time.process_time() - c0, time.perf_counter() - t0


def measure() -> dict:
    if not DATA.exists():
        return {"results": {}, "targets": {}, "details": {"ts_intervals": f"skipped: {DATA} absent"}}
    meas = read_dats(DATA)
    r_w, cpu_w, wall_w = _run(meas, "UD", noise="white")
    r_d, cpu_d, wall_d = _run(meas)
    hw = {k: 100 * (p["ci90"][1] - p["ci90"][0]) / 2 / p["value"] for k, p in r_d.parameters.items()
          if k in ("fs", "Re", "Qms", "Qes", "Qts")}
    return {"results": {"ts_intervals_default_cpu_s": cpu_d,
                        "ts_intervals_ratio_to_white_ud": cpu_d / cpu_w},
            "targets": {"ts_intervals_default_cpu_s": ["<=", 10.0],
                        "ts_intervals_ratio_to_white_ud": ["<=", 2.0]},
            "details": {"ts_intervals": {"points": meas.n_points, "default_model": r_d.model,
                                         "weights": r_d.inputs["mixture"]["weights"],
                                         "default_cpu_s": cpu_d, "default_wall_s": wall_d,
                                         "white_ud_cpu_s": cpu_w, "white_ud_wall_s": wall_w,
                                         "half_width_pct": hw, "load_average_1min": os.getloadavg()[0]}}}
