"""One answer whatever the start (issue 35, acceptance 1): a broken start is replaced by the nearest
healthy one, the final comparison weighs every start's final model by one evidence on the same data,
and ``diagnose`` from UD, III and NL(5) gives the same final model."""

import math

import numpy as np
import pytest

from bayes_emt.discovery import diagnose
from bayes_emt.discovery.diagnose import START_FAMILIES
from bayes_emt.discovery.reconcile import (
    TIE_NATS,
    final_comparison,
    healthy_start,
    kept_findings,
    start_ladder,
)
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.estimation.results import FitResult
from bayes_emt.evidence.fit_evidence import fit_log_evidence
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

GRID = np.geomspace(1e1, 1e5, 160)  # rad/s: the paper's UD plant resonates at 50.8 rad/s
WC = {"Cp": 2e-8}


def _data():
    return simulate(parse_model_spec("UD+winding_capacitance"), {**PAPER_TABLES["UD"], **WC}, GRID,
                    noise=0.003, seed=3)


def test_the_start_ladder_goes_down_the_rings_then_to_the_paper_models():
    assert start_ladder(parse_model_spec("NL(4)+suspension_creep")) == [
        "NL(3)+suspension_creep", "NL(2)+suspension_creep", "UD+suspension_creep",
        "III+suspension_creep", "II+suspension_creep", "I+suspension_creep"]
    assert start_ladder(parse_model_spec("UD")) == ["III", "II", "I"]


def test_a_broken_start_is_replaced_by_the_nearest_healthy_one_and_said_so():
    meas = _data()
    good = fit_admittance(meas, parse_model_spec("UD"))
    assert healthy_start(meas, good) == (good, None)
    # the NL(5) start of two real recordings: the ring ladder took over the DC resistance (R0 ~ 0,
    # Qes 0.0002); here UD's values with R0 and zeta at their priors' lower edges
    m = parse_model_spec("UD")
    lo = m.params.from_z(m.params.bounds_z()[0])
    broken = FitResult(m, np.where(np.isin(m.names, ["R0", "zeta"]), lo, good.theta), None, 0.0, 0.0,
                       meas.n_points)
    fit, line = healthy_start(meas, broken)
    assert fit.model.label == "III"
    assert line.startswith("the start UD is broken physics (") and "R0 = " in line
    assert "the search starts from III, the nearest healthy start" in line


def test_the_final_comparison_does_not_depend_on_the_order_the_starts_came_in():
    """The same finals in either order keep the same model; the evidence of the kept one is the best
    of the healthy candidates, or within TIE_NATS of it and simpler."""
    meas = _data()
    a = fit_admittance(meas, parse_model_spec("UD+winding_capacitance"))
    b = fit_admittance(meas, parse_model_spec("III+winding_capacitance"))

    def ev(f):
        return fit_log_evidence(meas, f).log_z

    one = final_comparison(meas, [a, b], ev, families=("UD", "III"))
    two = final_comparison(meas, [b, a], ev, families=("UD", "III"))
    assert one["fit"].model.label == two["fit"].model.label
    assert one["log_z"] == pytest.approx(two["log_z"], abs=1e-6)
    ok = [c["log_z"] for c in one["compared"] if not c["defects"] and math.isfinite(c["log_z"])]
    assert one["log_z"] >= max(ok) - TIE_NATS
    # backward elimination tried the terms away: the model without the capacitance was compared
    assert {"UD", "III"} & {c["model"] for c in one["compared"]}
    # the true model (a UD plant with a winding capacitance) is the one kept
    assert one["fit"].model.label == "UD+winding_capacitance"


def test_a_model_two_finals_reach_is_kept_at_its_better_optimum_in_either_order():
    """Two starts' searches end on the same terms with different values (one a poorer optimum of the
    same model): the comparison keeps the better one (healthy, larger log Z, then lower chi2)
    whichever final came first; it used to keep the first final's fit, so the start given decided
    the values and what was polished from them."""
    meas = _data()
    m = parse_model_spec("UD+winding_capacitance")
    good = fit_admittance(meas, m)
    v = m.as_dict(good.theta)
    poor = fit_admittance(meas, m, initial={**v, "zeta": 1.5 * v["zeta"], "R0": 1.05 * v["R0"]},
                          polish=False, max_nfev=3)
    assert poor.chi2 > 1.01 * good.chi2  # a distinct, poorer optimum of the same model

    def ev(f):
        return fit_log_evidence(meas, f).log_z

    for finals in ([good, poor], [poor, good]):
        out = final_comparison(meas, finals, ev, families=("UD",))
        assert out["fit"].model.label == "UD+winding_capacitance"
        assert out["fit"].chi2 == pytest.approx(good.chi2, rel=1e-9)
        np.testing.assert_allclose(out["fit"].theta, good.theta, rtol=1e-9)
        # one label, one entry: the poorer route does not appear beside it
        assert [c["model"] for c in out["compared"]].count("UD+winding_capacitance") == 1
        assert out["line"] == "" or "is kept over" not in out["line"]


def test_findings_follow_the_kept_model():
    from types import SimpleNamespace as NS

    f_wc = NS(physics="winding_capacitance", model_spec="UD+winding_capacitance")
    f_eddy = NS(physics="eddy_current", model_spec="NL(4)")
    f_pair = NS(physics="suspension_creep+winding_capacitance",
                model_spec="NL(4)+suspension_creep+winding_capacitance")
    fit = FitResult(parse_model_spec("NL(4)+winding_capacitance"), None, None, 0.0, 0.0, 1)
    assert kept_findings([f_wc, f_eddy, f_pair], fit) == [f_wc, f_eddy]
    fit_ud = FitResult(parse_model_spec("UD+winding_capacitance"), None, None, 0.0, 0.0, 1)
    assert kept_findings([f_wc, f_eddy, f_pair], fit_ud) == [f_wc]


@pytest.mark.slow
def test_diagnose_from_ud_iii_and_nl5_reaches_the_same_final_model():
    meas = _data()
    finals = {s: diagnose(meas, parse_model_spec(s), workers=1, time_budget=None, starts=START_FAMILIES)
              for s in ("UD", "III", "NL(5)")}
    labels = {d.final_model for d in finals.values()}
    assert labels == {"UD+winding_capacitance"}, {s: d.final_model for s, d in finals.items()}
    for d in finals.values():
        assert any("the searches from" in w for w in d.warnings)


def test_the_final_comparison_computes_no_evidence_for_a_broken_candidate():
    """A candidate with a defect is never kept, so its evidence (often the costliest: it fails at the
    prior's edge and falls back) is not computed; a final's always is, and the answer is the healthy
    best as before."""
    from bayes_emt.discovery.sanity import defects

    meas = _data()
    a = fit_admittance(meas, parse_model_spec("UD+winding_capacitance"))
    asked = []

    def ev(f):
        asked.append(f)
        return fit_log_evidence(meas, f).log_z

    out = final_comparison(meas, [a], ev, families=("UD", "III", "NL(2)"))
    broken = [c for c in out["compared"] if c["defects"]]
    assert broken, "the case needs a broken candidate (III+winding_capacitance: Cp at its prior's edge)"
    assert all(math.isnan(c["log_z"]) for c in broken)
    assert all(not defects(f, f.model.names) or f is a for f in asked)
    assert out["fit"].model.label == "UD+winding_capacitance" and out["cut"] == []


def test_the_final_comparison_on_a_pool_keeps_what_it_keeps_without_one_and_stops_at_the_deadline():
    """The candidates of each step run in parallel and are added in the same order: the same kept
    model, log Z and compared set as in one process; a deadline already passed compares nothing,
    keeps the first final and names every candidate it left out."""
    from bayes_emt._procs import ProcessPool, WallClock
    from bayes_emt.discovery.name import FitCache

    meas = _data()
    a = fit_admittance(meas, parse_model_spec("UD+winding_capacitance"))
    b = fit_admittance(meas, parse_model_spec("III"))
    fams = ("UD", "III", "NL(2)")
    one_cache = FitCache()
    one = final_comparison(meas, [a, b], lambda f: one_cache.evidence_of(meas, f).log_z, cache=one_cache,
                           families=fams)
    cache = FitCache()
    with ProcessPool(2) as pool:
        par = final_comparison(meas, [a, b], lambda f: cache.evidence_of(meas, f).log_z, cache=cache,
                               families=fams, pool=pool)
    assert par["fit"].model.label == one["fit"].model.label and par["cut"] == []
    assert par["log_z"] == pytest.approx(one["log_z"], abs=1e-6)
    lz = lambda out: {c["model"]: c["log_z"] for c in out["compared"]}  # noqa: E731
    assert lz(par).keys() == lz(one).keys()
    np.testing.assert_allclose([lz(par)[k] for k in lz(one)], list(lz(one).values()), atol=1e-6)

    clock = WallClock()
    cache = FitCache()
    with ProcessPool(2) as pool:
        late = final_comparison(meas, [a, b], lambda f: cache.evidence_of(meas, f).log_z, cache=cache,
                                families=fams, pool=pool, clock=clock, deadline=clock() - 1.0)
    assert late["fit"] is a and late["compared"] == []
    assert late["cut"][:2] == ["UD+winding_capacitance", "III"] and "NL(2)+winding_capacitance" in late["cut"]
