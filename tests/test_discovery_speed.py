"""The fast paths of the discrepancy search decide as the full one does (issue 23, acceptance 1):
warm-started candidate fits (polished from the current fit, without the paper's intermediate steps;
the leaders fitted again the full way), the coil-model cache and the process pool. Properties of
the decisions, not timings."""

import numpy as np
import pytest

from bayes_emt.discovery import diagnose
from bayes_emt.discovery.locate import Band
from bayes_emt.discovery.name import rank_candidates
from bayes_emt.discovery.prefer import choose
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.evidence.fit_evidence import blocked, fit_log_evidence, slice_log_integral
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

GRID = np.geomspace(1e1, 1e5, 200)


@pytest.fixture(scope="module")
def capacitance_case():
    """UD data with 20 nF across the terminals (0.3 % noise), the UD fit, its log Z and the top band."""
    meas = simulate(parse_model_spec("UD+winding_capacitance"), {**PAPER_TABLES["UD"], "Cp": 2e-8}, GRID,
                    noise=0.003, seed=3)
    fit = fit_admittance(meas, parse_model_spec("UD"))
    band = Band(float(GRID[130]), float(GRID[-1]), 130, GRID.size - 1, ("real", "imag"), 100.0, 25.0,
                float(GRID[170]))
    return meas, fit, fit_log_evidence(meas, fit).log_z, band


def test_warm_started_candidates_give_the_full_fits_decision(capacitance_case):
    meas, fit, lz, band = capacitance_case
    ids = ["winding_capacitance", "lead_impedance", "lr2"]
    # the warm start alone (no leader fitted again the full way), and the full fits
    warm = rank_candidates(meas, fit, lz, band, 0.003, ids, warm=True, refine=0)
    full = rank_candidates(meas, fit, lz, band, 0.003, ids, warm=False)
    pick_w, pick_f = choose(warm)[0], choose(full)[0]
    assert pick_w is not None and pick_f is not None
    assert pick_w.physics == pick_f.physics == "winding_capacitance"
    assert {c.physics for c in warm if c.accepted} == {c.physics for c in full if c.accepted}
    # the same optimum: the evidence agrees to well inside the 1-nat tie rule, the value to 0.1 %
    assert pick_w.delta_log_z == pytest.approx(pick_f.delta_log_z, abs=0.5)
    assert pick_w.added["Cp"][0] == pytest.approx(pick_f.added["Cp"][0], rel=1e-3)


def test_the_leaders_full_fit_replaces_a_warm_one_only_when_better_and_then_with_its_own_evidence(
        capacitance_case):
    """``_refine`` computes a full fit's log Z only when that fit beats its warm one: every kept
    candidate's fit is the better of the two (chi2) and its log Z is that fit's."""
    meas, fit, lz, band = capacitance_case
    ids = ["winding_capacitance", "lead_impedance", "lr2"]
    warm = {c.physics: c for c in rank_candidates(meas, fit, lz, band, 0.003, ids, warm=True, refine=0)}
    full = {c.physics: c for c in rank_candidates(meas, fit, lz, band, 0.003, ids, warm=False)}
    refined = rank_candidates(meas, fit, lz, band, 0.003, ids, warm=True, refine=2)
    for c in refined:
        if c.physics not in full or c.physics not in warm:
            continue
        assert c.fit.chi2 <= min(warm[c.physics].fit.chi2, full[c.physics].fit.chi2) * (1 + 1e-9)
        assert c.log_z == pytest.approx(fit_log_evidence(meas, c.fit).log_z, abs=1e-6)


def test_warm_fit_needs_its_start():
    meas = simulate(parse_model_spec("II"), PAPER_TABLES["II"], GRID, noise=0.003, seed=1)
    with pytest.raises(ValueError, match="warm"):
        fit_admittance(meas, parse_model_spec("II"), warm=True)


def test_blocked_density_and_reused_line_grid_give_the_same_numbers():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3, 3))

    def f(z):
        return -0.5 * np.sum((z @ a) ** 2, axis=-1)

    z = rng.standard_normal((1000, 3))
    np.testing.assert_array_equal(blocked(f, rows=64)(z), f(z))
    # the refined trapezoid grids hold the coarser ones' points: a Gaussian's integral to 1e-9
    assert slice_log_integral(lambda t: -0.5 * t**2) == pytest.approx(0.5 * np.log(2 * np.pi), abs=1e-9)


@pytest.mark.slow
def test_the_pool_and_the_fast_paths_give_the_full_searchs_findings():
    """The concealed capacitance diagnosed from UD three ways (warm start and cache with two worker
    processes; warm in one process; the full fits in one process): the same findings, bands and
    final model; Δ log Z the same within 0.5 nat."""
    meas = simulate(parse_model_spec("UD+winding_capacitance"), {**PAPER_TABLES["UD"], "Cp": 2e-8}, GRID,
                    noise=0.003, seed=3)
    runs = [diagnose(meas, parse_model_spec("UD"), time_budget=None, workers=2),
            diagnose(meas, parse_model_spec("UD"), time_budget=None, workers=1),
            diagnose(meas, parse_model_spec("UD"), time_budget=None, workers=1, warm=False)]
    pooled, warm, full = runs
    assert [f.physics for f in full.findings] == ["winding_capacitance"]
    for d in (pooled, warm):
        assert d.final_model == full.final_model
        assert [f.physics for f in d.findings] == [f.physics for f in full.findings]
        for a, b in zip(d.findings, full.findings, strict=True):
            assert a.delta_log_evidence == pytest.approx(b.delta_log_evidence, abs=0.5)
            assert (a.band.i_lo, a.band.i_hi) == (b.band.i_lo, b.band.i_hi)
    # the pool merges in the candidates' order: the record is the one-process record
    assert [c["physics"] for t in pooled.tried for c in t["candidates"]] == \
        [c["physics"] for t in warm.tried for c in t["candidates"]]
    # (nan for a step refused before its evidence, in the same places; numbers to 1e-9 relative)
    np.testing.assert_allclose([c["delta_log_evidence"] for t in pooled.tried for c in t["candidates"]],
                               [c["delta_log_evidence"] for t in warm.tried for c in t["candidates"]],
                               rtol=1e-9, atol=1e-9, equal_nan=True)


def test_base_models_fitted_in_a_pool_are_the_same_fits():
    from bayes_emt.discovery.diagnose import _pool, preferred_base_model
    from bayes_emt.discovery.name import CpuClock, FitCache

    meas = simulate(parse_model_spec("III"), PAPER_TABLES["III"], GRID, noise=0.003, seed=2)
    alone = preferred_base_model(meas)
    pool, clock, cache = _pool(2), CpuClock(), FitCache()
    try:
        pooled = preferred_base_model(meas, cache=cache, pool=pool, clock=clock)
    finally:
        pool.shutdown()
    assert pooled[0].model.label == alone[0].model.label
    np.testing.assert_array_equal(pooled[0].theta, alone[0].theta)
    assert pooled[1] == alone[1] and list(pooled[2]) == list(alone[2])
    np.testing.assert_array_equal(list(pooled[2].values()), list(alone[2].values()))  # nan: no log Z
    assert set(cache.fits) >= {"I", "II", "III", "UD"} and clock.workers > 0


def test_a_search_the_budget_stopped_says_so():
    """``Diagnosis.budget_hit`` reads the budget's warning: a budget spent before the first band is
    examined stops the search and says so; the unbudgeted search does not."""
    meas = simulate(parse_model_spec("UD+winding_capacitance"), {**PAPER_TABLES["UD"], "Cp": 2e-8}, GRID,
                    noise=0.003, seed=3)
    cut = diagnose(meas, parse_model_spec("UD"), time_budget=1e-9, workers=1)
    assert cut.budget_hit and cut.findings == ()
    assert any(w.startswith("time budget of 1e-09 s reached") for w in cut.warnings)
    full = diagnose(meas, parse_model_spec("UD"), time_budget=None, workers=1)
    assert not full.budget_hit and [f.physics for f in full.findings] == ["winding_capacitance"]
