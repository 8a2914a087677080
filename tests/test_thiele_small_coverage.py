"""Coverage of the T/S 90 % intervals on simulated drivers (scripts/ts_coverage.py).

Fast: 4 seeds of the two-added-mass case with the fit's Gaussian (``fast``) intervals; every
parameter's truth inside in at least 2 of 4 (a calibrated 90 % interval fails that with
probability 0.004 per parameter). Slow: 20 seeds of each case, every parameter >= 80 %, all
parameters together 90 +- 5 %, and the default intervals no wider than 1.5 times the model's own
(median), for the ``fast`` intervals (the posterior's are in scripts/results)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_SPEC = importlib.util.spec_from_file_location(
    "ts_coverage", Path(__file__).resolve().parents[1] / "scripts" / "ts_coverage.py")
ts_coverage = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(ts_coverage)


def _coverage(case, seeds, points):
    recs = [ts_coverage.run_case(case, s, fast=True, points=points) for s in seeds]
    names = list(recs[0]["inside"])
    return {n: float(np.mean([r["inside"][n] for r in recs])) for n in names}, recs


def test_added_mass_intervals_cover_in_few_seeds():
    cov, recs = _coverage("mass", range(4), 400)
    assert set(cov) >= {"fs", "Qts", "Bl", "Mms", "Vas"}
    low = {n: c for n, c in cov.items() if c < 0.5}
    assert not low, low


@pytest.mark.slow
@pytest.mark.parametrize("case", ["mass", "creep", "volume"])
def test_coverage_at_least_80_percent_over_20_seeds(case):
    """Every parameter >= 80 %; where the model is right the default (total) intervals are the
    model's own: coverage over all parameters 90 +- 5 % and every parameter's median width at most
    1.5 times the model's own interval (before the residual test, fs and Qms were 8-21 times)."""
    cov, recs = _coverage(case, range(20), 600)
    names = ["Vas"] if case == "volume" else list(cov)
    low = {n: cov[n] for n in names if cov[n] < 0.8}
    assert not low, low
    assert 0.85 <= float(np.mean(list(cov.values()))) <= 0.95, cov
    ratio = {n: float(np.median([r["width_ratio_to_model"].get(n, 1.0) for r in recs])) for n in cov}
    wide = {n: x for n, x in ratio.items() if x > 1.5}
    assert not wide, wide
