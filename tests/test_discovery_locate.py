"""Locating a mismatch (issue 13): the noise estimate, the scan, its false-alarm calibration,
the whiteness tests and the rational shape of a residual. Known residual patterns and white
noise; tolerances are tied to each statistic's own sampling error (stated per test)."""

import numpy as np
import pytest

from bayes_emt.discovery.locate import (
    Band,
    ljung_box,
    locate_mismatch,
    noise_scale,
    projected_jacobian,
    runs_test,
    scan_statistics,
)
from bayes_emt.discovery.shape import describe_shape, residual_shape
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

GRID = np.geomspace(1e1, 1e5, 400)


def _max(r):
    return max(float(np.max(T)) for _, _, T in scan_statistics(r))


def test_noise_scale_is_the_std_of_white_noise_and_ignores_smooth_structure():
    rng = np.random.default_rng(0)
    x = 0.3 * rng.standard_normal(4000)
    # the MAD of 4000 second differences has a relative sd of about 1.7 %: 6 % is > 3 sd
    assert noise_scale(x) == pytest.approx(0.3, rel=0.06)
    smooth = 3.0 * np.sin(np.linspace(0, 6 * np.pi, x.size))  # 10 sigma, three periods
    assert noise_scale(x + smooth) == pytest.approx(0.3, rel=0.08)


def test_scan_statistic_is_chi2_3_for_white_noise():
    rng = np.random.default_rng(1)
    for L, _, T in scan_statistics(rng.standard_normal((2000, 256))):
        # per scale, the mean over 2000 independent series is 3 (chi2_3) within 4 standard errors
        # (the error from the spread of the per-series means: overlapping windows are correlated)
        per_series = T.mean(axis=-1)
        se = per_series.std() / np.sqrt(per_series.size)
        assert abs(per_series.mean() - 3.0) < 4 * se, L


def test_a_smooth_bump_is_located_where_it_is():
    rng = np.random.default_rng(2)
    n = 400
    r = rng.standard_normal((2, n))
    i = np.arange(n)
    # 2 sigma high, 20 points wide, imaginary part: energy sum(bump^2) = 4 * 8 sqrt(pi) = 57
    r[1] += 2.0 * np.exp(-0.5 * ((i - 300) / 8.0) ** 2)
    white = [_max(rng.standard_normal((2, n))) for _ in range(200)]
    assert _max(r) > np.quantile(white, 0.99)
    # the strongest window sits on the bump, in the imaginary part
    best = max(
        (
            (float(T[p, k]), p, int(st[k]), L)
            for L, st, T in scan_statistics(r)
            for p in range(2)
            for k in range(T.shape[1])
        )
    )
    assert best[1] == 1 and best[2] <= 300 <= best[2] + best[3] - 1


def _null(seed, noise=0.003):
    model = parse_model_spec("UD")
    return model, simulate(model, PAPER_TABLES["UD"], GRID, noise=noise, seed=seed)


def test_false_alarm_rate_matches_alpha_on_fresh_replicates():
    """The threshold is the (1 - alpha) quantile of the bootstrap maxima: fresh white replicates,
    projected the same way, exceed it with probability alpha (alpha = 0.1 here for power; 600
    replicates give a binomial sd of 0.012, the tolerance 0.04 is > 3 sd)."""
    model, meas = _null(0)
    theta = model.vector(PAPER_TABLES["UD"])
    loc = locate_mismatch(meas, model, theta, alpha=0.1, replicates=600, seed=3)
    U = projected_jacobian(model, meas, theta)
    rng = np.random.default_rng(99)
    e = rng.standard_normal((600, 2 * meas.n_points))
    e = (e - (e @ U) @ U.T).reshape(-1, 2, meas.n_points)
    s = np.sqrt(np.mean(noise_scale(e) ** 2, axis=-1))
    maxima = np.array([_max(x / si) for x, si in zip(e, s, strict=True)])
    assert np.mean(maxima > loc.threshold) == pytest.approx(0.1, abs=0.04)


def test_a_correct_fit_shows_no_band_and_a_missing_capacitance_is_located_at_the_top():
    model, meas = _null(4)
    loc = locate_mismatch(meas, model, model.vector(PAPER_TABLES["UD"]))
    assert not loc.bands and loc.p_value > 0.01
    assert loc.sigma_rel == pytest.approx(0.003, rel=0.1)
    aug = parse_model_spec("UD+winding_capacitance")
    vals = {**PAPER_TABLES["UD"], "Cp": 2e-9}
    meas = simulate(aug, vals, GRID, noise=0.003, seed=4)
    loc = locate_mismatch(meas, model, model.vector(PAPER_TABLES["UD"]))
    assert loc.bands
    # the capacitance's admittance s Cp exceeds the noise only near the top of the band
    assert loc.bands[0].hi == pytest.approx(GRID[-1]) and loc.bands[0].lo > 1e3


def test_whiteness_tests_tell_white_from_structured():
    rng = np.random.default_rng(5)
    white = rng.standard_normal(2000)
    ar = np.zeros(2000)
    for k in range(1, 2000):
        ar[k] = 0.6 * ar[k - 1] + rng.standard_normal()
    assert ljung_box(white)["p_value"] > 1e-3 and ljung_box(ar)["p_value"] < 1e-10
    assert runs_test(white)["p_value"] > 1e-3 and runs_test(ar)["z"] < -5


def test_rational_shape_finds_a_resonance_in_the_residual():
    """A residual that is exactly a second-order resonance at 2000 rad/s (damping 0.05): the
    rational fit's pole pair has that modulus (noise-free: 1 % tolerance)."""
    model = parse_model_spec("UD")
    theta = model.vector(PAPER_TABLES["UD"])
    Ym = model.admittance(GRID, theta)
    s = 1j * GRID
    e = 0.05 * (2 * 0.05 * 2000 * s) / (s * s + 2 * 0.05 * 2000 * s + 2000.0**2)
    from bayes_emt.measurement import Measurement

    meas = Measurement(GRID, Ym * (1 + e))
    i_lo, i_hi = int(np.searchsorted(GRID, 300)), int(np.searchsorted(GRID, 2e4))
    band = Band(float(GRID[i_lo]), float(GRID[i_hi]), i_lo, i_hi, ("real", "imag"), 100.0, 25.0, 2000.0)
    shape = residual_shape(meas, model, theta, band)
    mods = [np.hypot(*p) for p in shape["poles_rad_s"]]
    assert min(abs(m - 2000) for m in mods) < 20
    assert shape["rms_unexplained_rel"] < 1e-3 * shape["rms_residual_rel"]
    assert "318.3 Hz" in describe_shape(band, shape)
