"""Automatic initial estimate (SPEC.md §3.1): Levy linearisation, coil stage, validation, fallback."""

import warnings

import numpy as np
import pytest

from bayes_emt import FitError, build_model, simulate
from bayes_emt.estimation.guess import (
    POOR_RMS,
    InitialEstimate,
    coil_estimate,
    find_initial_estimate,
    initial_estimate,
    levy_plant,
    resonance_bands,
)
from bayes_emt.models import terms as T
from bayes_emt.models.linearise import rational_alpha
from bayes_emt.reference import PAPER_TABLES

CASES = [("I", None, "I"), ("II", None, "II"), ("III", None, "III"), ("UD", None, "UD"),
         ("NL", 5, "NL"), ("UL", 5, "UD")]


def truth_of(name, rings, table):
    m = build_model(name, rings=rings)
    return m, m.vector(PAPER_TABLES[table])


def test_levy_plant_is_exact_for_model_I():
    # model I is exactly the rational function of the linearisation: SPEC §3.1 over the paper's
    # 10-300 rad/s band recovers Table 1 to rounding
    model, truth = truth_of("I", None, "I")
    meas = simulate(model, truth).select(10, 300)
    np.testing.assert_allclose(levy_plant(meas.omega, meas.Y), truth, rtol=1e-9)


def test_levy_plant_rejects_non_physical_data():
    omega = np.geomspace(10, 1e5, 300)
    with pytest.raises(FitError, match="not physical"):
        levy_plant(omega, 1e-3 * 1j * omega)  # a capacitor: no resonance, no R0


def test_resonance_bands_follow_the_peak():
    model, truth = truth_of("UD", None, "UD")
    bands = resonance_bands(simulate(model, truth))
    # the paper's 10-300 rad/s around omega0 = 50.8 rad/s is about 0.2-6 omega0
    lo, hi = bands[0]
    assert lo == pytest.approx(10.2, rel=0.05) and hi == pytest.approx(305, rel=0.05)
    assert all(lo <= 50.8 <= hi for lo, hi in bands)


@pytest.mark.parametrize("name, rings, table", [c for c in CASES if c[0] != "NL"])
def test_noise_free_estimate_is_close(name, rings, table):
    # I, II are rational in the linearised form and come out exact; the Bessel/ring coils within
    # the alpha scan's resolution (its refined grid steps by 3 %)
    model, truth = truth_of(name, rings, table)
    ie = find_initial_estimate(simulate(model, truth), model)
    rel = np.abs(ie.theta / truth - 1)
    assert np.max(rel) < (1e-3 if name in ("I", "II") else 0.03), dict(zip(model.names, rel, strict=True))
    assert ie.rms_rel_residual < 0.01


@pytest.mark.parametrize("name, rings, table", CASES)
def test_initial_estimate_needs_no_guess(name, rings, table):
    model, truth = truth_of(name, rings, table)
    meas = simulate(model, truth, noise=0.002, seed=1)
    theta = initial_estimate(meas, model)
    assert isinstance(theta, np.ndarray) and theta.shape == (model.ndim,)
    assert np.all(model.params.in_support(theta))
    # the plant parameters come out close; the fit takes it from there
    np.testing.assert_allclose(theta[:4], truth[:4], rtol=0.05)


def test_nl_starts_from_uniform_rings():
    # SPEC §3.1: NL starts from the uniform-core estimate through the UL formulas (SPEC §2)
    model, truth = truth_of("NL", 5, "NL")
    theta = initial_estimate(simulate(model, truth, noise=0.002, seed=3), model)
    p = model.as_dict(theta)
    P = np.array([p[f"P{j}"] for j in range(1, 6)])
    R = np.array([p[f"R{j}"] for j in range(1, 6)])
    j = np.arange(1, 6)
    np.testing.assert_allclose(P, P[0], rtol=1e-12)
    np.testing.assert_allclose(R / R[0], np.sqrt(j) / (np.sqrt(j) - np.sqrt(j - 1)), rtol=1e-12)


def test_coil_stage_with_the_true_plant_recovers_ul():
    # the UL coil scales with beta at fixed alpha, so the alpha scan is exact up to its grid
    model, truth = truth_of("UL", 5, "UD")
    coil = coil_estimate(simulate(model, truth), model, np.r_[truth[:4], 0.0])
    p = model.as_dict(truth)
    for name in ("R0", "Lg", "alpha", "beta"):
        assert coil[name] == pytest.approx(p[name], rel=0.03), name


@pytest.mark.parametrize("with_gap", [False, True])
def test_rational_bessel_linearisation_is_exact_on_its_own_form(with_gap):
    # SPEC §3.1: Z_III ~ beta sqrt(alpha) s (alpha s + 8)/(4 alpha s + 16); on data of exactly that
    # form (plus R0, and Lg s for UD) the linear solve returns alpha to rounding
    s = 1j * np.geomspace(10, 1e5, 400)
    alpha = 3.74e-4
    Ze = 2.57 + T.bessel_eddy_rational(s, alpha, 0.287) + (7.86e-4 * s if with_gap else 0)
    a = rational_alpha(s, Ze, 1 / np.abs(Ze), with_gap)
    assert a == pytest.approx(alpha, rel=1e-6)


def test_alternatives_are_distinct_and_ranked():
    model, truth = truth_of("UD", None, "UD")
    meas = simulate(model, truth, noise=0.002, seed=4)
    ie = find_initial_estimate(meas, model)
    assert isinstance(ie, InitialEstimate) and len(ie.alternatives) <= 2
    zs = [model.params.to_z(t) for t in (ie.theta, *ie.alternatives)]
    for i in range(len(zs)):
        for j in range(i):
            assert np.max(np.abs(zs[i] - zs[j])) > 1e-3
    assert ie.path.startswith(("levy", "resonance peak")) and ie.band[0] < 50.8 < ie.band[1]


def test_a_band_that_misses_the_resonance_is_outvoted_by_the_peak():
    # a user band far above the resonance gives a meaningless linearised plant; the peak-based
    # candidate wins, so the estimate is still close
    model, truth = truth_of("UD", None, "UD")
    ie = find_initial_estimate(simulate(model, truth, noise=0.002, seed=2), model, band=(2e3, 1e5))
    assert ie.rms_rel_residual < 0.05
    assert ie.theta[1] == pytest.approx(50.8, rel=0.02)


def test_poor_linearisation_runs_the_global_stage():
    # model I cannot describe data with eddy currents: the best linearised candidate is poor, so
    # perturbed candidates are scored too, and the path says so
    data_model, truth = truth_of("II", None, "II")
    meas = simulate(data_model, truth, noise=0.002, seed=1)
    model = build_model("I")
    ie = find_initial_estimate(meas, model, seed=7)
    assert ie.details["global_stage"] and ie.details["candidates"] > ie.details["linearised_candidates"]
    linear_only = min(np.sqrt(np.mean(np.abs(model.admittance(meas.omega, t) / meas.Y - 1) ** 2))
                      for t in (ie.theta, *ie.alternatives))
    assert ie.rms_rel_residual == pytest.approx(linear_only) and ie.rms_rel_residual > POOR_RMS / 2
    # same seed, same answer
    np.testing.assert_array_equal(find_initial_estimate(meas, model, seed=7).theta, ie.theta)


def test_no_resonance_in_band_still_gives_a_finite_start():
    model, truth = truth_of("UD", None, "UD")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meas = simulate(model, truth, np.geomspace(1e3, 1e5, 300), noise=0.002, seed=1)
    theta = initial_estimate(meas, model)
    assert np.all(np.isfinite(theta)) and np.all(model.params.in_support(theta))
    # the electrical part is what the band shows: R0 and the coil come out close
    assert theta[3] == pytest.approx(2.57, rel=0.05)
