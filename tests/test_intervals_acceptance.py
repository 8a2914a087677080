"""The honest-interval acceptance studies (docs/intervals.md), all slow: the model right (the T/S
coverage study, scripts/ts_coverage.py), the model wrong (scripts/ts_wrong_model.py) and DATS's own
fits of the three DATS curves in ../shared/realdata. Each needs minutes to hours of CPU; the lead
runs them after merging."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

REALDATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"
SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_model_right_coverage_90_and_width_within_1_5x_of_white():
    """Simulated driver, the fitted model is the simulated one (free air + 10 g + 20 g, 600 points,
    0.5 % noise), posterior intervals, 20 seeds: pooled coverage of the default (correlated)
    intervals 90 +- 5 %, and their median width at most 1.5x the white intervals' (the issue's
    acceptance 2)."""
    cov = _load("ts_coverage")
    inside, ratio = [], []
    for seed in range(20):
        c = cov.run_case("mass", seed, fast=False, points=600)
        w = cov.run_case("mass", seed, fast=False, points=600, noise="white")
        inside += list(c["inside"].values())
        ratio += [(c["ci90"][k][1] - c["ci90"][k][0]) / (w["ci90"][k][1] - w["ci90"][k][0])
                  for k in c["ci90"]]
    assert 0.85 <= np.mean(inside) <= 0.95
    assert np.median(ratio) <= 1.5


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="not met: seeds 0-4 (300 points) had 7 of 30 inside (Re +6 % off, "
                   "interval +-1.3 %); the OU discrepancy does not widen enough for a smooth misfit")
def test_model_wrong_truth_inside_in_80_percent():
    """NL(3) + LOG creep data fitted with UD, free air + 10 g, 20 seeds: the true fs, Re, Qms, Qes,
    Bl, Mms inside the default 90 % interval in at least 80 % of (seed, parameter) cases."""
    wm = _load("ts_wrong_model")
    recs = [wm.run_case(seed, noise="correlated", points=400) for seed in range(20)]
    assert np.mean([r["inside"][k] for r in recs for k in wm.NAMES]) >= 0.8


DATS = ("grs_12SW-4HE_dats_0h.txt", "scanspeak_18W-4424G00_dats_0h.txt",
        "sb_SB26STAC-C000-4_dats_freeair.txt")


@pytest.mark.slow
@pytest.mark.skipif(not all((REALDATA / f).exists() for f in DATS), reason="realdata absent")
@pytest.mark.xfail(strict=True, reason="not met: DATS's fs, Re, Qes, Qts inside in 2 of 12 (GRS: Qes, Qts; "
                   "ScanSpeak: none; SB26: none); DATS's Re is the plateau below 10 Hz, fs its phase zero")
def test_dats_header_values_inside_the_default_intervals():
    from bayes_emt.thiele_small import thiele_small

    bench = _load_bench()
    for f in DATS:
        meas, ref = bench.read_dats(REALDATA / f), _dats_header(REALDATA / f)
        r = thiele_small(meas, seed=0)
        for k in ("fs", "Re", "Qes", "Qts"):
            lo, hi = r.parameters[k]["ci90"]
            assert lo <= ref[k] <= hi, (f, k, ref[k], lo, hi)


def _load_bench():
    spec = importlib.util.spec_from_file_location(
        "bench_ts_intervals", Path(__file__).resolve().parents[1] / "benchmarks" / "bench_ts_intervals.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _dats_header(path: Path) -> dict[str, float]:
    keys = {"f(s)": "fs", "R(e)": "Re", "Q(es)": "Qes", "Q(ts)": "Qts"}
    out = {}
    for line in path.read_text(encoding="latin-1").splitlines():
        if line.startswith("*") and "=" in line:
            k, v = line[1:].split("=", 1)
            if k.strip() in keys:
                out[keys[k.strip()]] = float(v.split()[0])
    assert len(out) == 4 and all(math.isfinite(v) for v in out.values())
    return out
