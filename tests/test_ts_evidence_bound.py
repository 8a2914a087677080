"""The evidence-supported default model skips what cannot matter (bayes_emt.thiele_small.compute):
a candidate whose likelihood's maximum is more than 25 nats below the best evidence gets weight 0
without its evidence's subspace fallback (``Z = ∫ L π ≤ max L``), recorded with that bound; and NL's
start computes its UL surrogate's coil candidates once (bayes_emt.estimation.guess)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small.compute import (
    EVIDENCE_SKIP_NATS,
    _resolve_pending,
    _terms_on_best_coils,
    select_spread_models,
)
from bayes_emt.thiele_small.simulate import simulate_driver

REALDATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"
GRS = REALDATA / "grs_12SW-4HE_dats_0h.txt"


def test_skip_margin_makes_the_weight_negligible():
    """25 nats: a skipped candidate's probability is below 1e-10 whatever its evidence."""
    assert EVIDENCE_SKIP_NATS >= 23.1  # exp(-23.03) = 1e-10
    assert math.exp(-EVIDENCE_SKIP_NATS) < 1e-10


def test_pending_evidences_best_fit_first_and_bounded_below_the_leader():
    """Resolved by rms (best first, no bound before any evidence), each later one asked for its
    evidence only above the best evidence so far minus the margin; a bounded one keeps its bound."""
    calls = []

    def pending(label, log_z, upper):
        def get(below):
            calls.append((label, below))
            if below is not None and upper < below:
                return float("nan"), upper
            return log_z, None
        return get

    recs = {"II": {"rms": 0.26, "undetermined": [], "log_z": float("nan"),
                   "pending_evidence": pending("II", 1870.0, 1915.0)},
            "NL(3)": {"rms": 0.021, "undetermined": [], "log_z": float("nan"),
                      "pending_evidence": pending("NL(3)", 2914.0, 3001.0)},
            "UD": {"rms": 0.056, "undetermined": [], "log_z": float("nan"),
                   "pending_evidence": pending("UD", 2438.0, 2900.0)},
            "NL(2)": {"rms": 0.037, "undetermined": ["Pg"], "log_z": float("nan")}}
    comps = {m: (None, None, r) for m, r in recs.items()}
    _resolve_pending(comps)
    below = 2914.0 - EVIDENCE_SKIP_NATS
    assert calls == [("NL(3)", None), ("UD", below), ("II", below)]
    assert recs["NL(3)"]["log_z"] == 2914.0 and recs["UD"]["log_z"] == 2438.0
    assert math.isnan(recs["II"]["log_z"]) and recs["II"]["log_z_upper"] == 1915.0
    assert "log_z_upper" not in recs["UD"] and not any("pending_evidence" in r for r in recs.values())
    # an evidence already known leads from the start
    recs2 = {"A": {"rms": 0.01, "undetermined": [], "log_z": 100.0},
             "B": {"rms": 0.02, "undetermined": [], "log_z": float("nan"),
                   "pending_evidence": pending("B", 50.0, 60.0)}}
    calls.clear()
    _resolve_pending({m: (None, None, r) for m, r in recs2.items()})
    assert calls == [("B", 100.0 - EVIDENCE_SKIP_NATS)] and recs2["B"]["log_z_upper"] == 60.0


def test_a_bounded_candidate_has_probability_zero_and_a_failed_one_is_still_kept():
    nan = float("nan")
    out = select_spread_models([{"model": "A", "rms": 0.02, "undetermined": [], "log_z": 10.0},
                                {"model": "B", "rms": 0.02, "undetermined": [], "log_z": nan,
                                 "log_z_upper": -20.0},
                                {"model": "C", "rms": 0.02, "undetermined": [], "log_z": nan}])
    assert out[0]["probability"] == 1.0 and out[0]["included"]
    assert out[1]["probability"] == 0.0 and not out[1]["included"]
    assert out[2]["probability"] is None and out[2]["included"]


def test_no_terms_on_a_better_fitting_coil_whose_evidence_is_bounded():
    """A bounded evidence is not a failed one: it says the candidate is improbable."""
    nan = float("nan")
    recs = [{"model": "UD", "rms": 0.019, "undetermined": [], "log_z": 6320.0},
            {"model": "NL(3)", "rms": 0.014, "undetermined": [], "log_z": nan, "log_z_upper": 6200.0}]
    assert [m.label for m in _terms_on_best_coils(recs)] == ["UD+semi_inductance", "UD+suspension_creep"]


@pytest.mark.skipif(not GRS.exists(), reason="realdata absent")
@pytest.mark.parametrize("spec", ["II", "III"])
def test_the_bound_is_above_the_evidence_where_the_screen_fails(spec):
    """On a real woofer the Laplace screens of II and III fail; the fallback's evidence is below the
    likelihood's maximum that ``below`` reports (``Z ≤ max L``), and ``below`` under it runs the fallback."""
    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.evidence.fit_evidence import fit_log_evidence
    from bayes_emt.inference.likelihood import Likelihood
    from bayes_emt.io import read_measurement

    meas = read_measurement(GRS)
    model = parse_model_spec(spec)
    fit = fit_admittance(meas, model)
    lik = Likelihood(model, meas)
    bounded = fit_log_evidence(meas, fit, lik=lik, below=math.inf)
    full = fit_log_evidence(meas, fit, lik=lik)
    assert bounded.method == "bounded" and math.isnan(bounded.log_z) and math.isfinite(bounded.upper)
    assert full.method == "laplace_subspace" and full.log_z <= bounded.upper
    again = fit_log_evidence(meas, fit, lik=lik, below=bounded.upper - 1.0)
    assert again.method == "laplace_subspace" and again.log_z == pytest.approx(full.log_z, rel=1e-12)


def test_nl_start_shares_its_surrogate_coil_candidates_and_is_unchanged():
    """Inside ``shared_coil_candidates`` the UL surrogate's coil candidates are computed once for the
    UL fit's start and NL's own estimate, and NL's estimate is the same as without sharing."""
    import bayes_emt.estimation.guess as G

    sim = simulate_driver("UD", deltas=(), seed=4, n_points=300)
    model = parse_model_spec("NL(2)")
    ul = parse_model_spec("UL(2)")
    plain = G.find_initial_estimate(sim.free, model)
    calls = []
    orig = G._coil_candidates

    def counted(*a, **k):
        calls.append(a[1].label)
        return orig(*a, **k)

    G._coil_candidates = counted
    try:
        with G.shared_coil_candidates():
            G.find_initial_estimate(sim.free, ul)
            n_ul = len(calls)
            shared = G.find_initial_estimate(sim.free, model)
    finally:
        G._coil_candidates = orig
    assert n_ul > 0 and len(calls) == n_ul  # NL's estimate computed no coil candidate of its own
    np.testing.assert_array_equal(shared.theta, plain.theta)
    assert shared.path == plain.path and len(shared.alternatives) == len(plain.alternatives)
    for a, b in zip(shared.alternatives, plain.alternatives, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.slow
@pytest.mark.skipif(not GRS.exists(), reason="realdata absent")
def test_default_model_and_intervals_are_those_of_every_evidence_computed(monkeypatch):
    """On the GRS woofer the skip leaves the chosen model, the weights above 1e-3 and the values
    (1e-6 relative) and 90 % intervals (1e-3 relative: a component of weight 1e-200 moves the
    weighted quantiles' interpolation) as with every evidence computed; the skipped candidates are
    recorded with their bound, far below the chosen model's evidence, and weight 0."""
    import bayes_emt.thiele_small.compute as C
    from bayes_emt.io import read_measurement

    meas = read_measurement(GRS)
    fast = C.thiele_small(meas, seed=0)
    margin = C.EVIDENCE_SKIP_NATS
    monkeypatch.setattr(C, "EVIDENCE_SKIP_NATS", math.inf)  # no skip: every evidence computed
    full = C.thiele_small(meas, seed=0)
    assert fast.model == full.model
    wf, wa = fast.inputs["mixture"]["weights"], full.inputs["mixture"]["weights"]
    assert {m: w for m, w in wf.items() if w > 1e-3} == {m: w for m, w in wa.items() if w > 1e-3}
    for q in ("fs", "Re", "Qms", "Qes", "Qts"):
        assert fast.parameters[q]["value"] == pytest.approx(full.parameters[q]["value"], rel=1e-6)
        np.testing.assert_allclose(fast.parameters[q]["ci90"], full.parameters[q]["ci90"], rtol=1e-3)
    models = {r["model"]: r for r in fast.inputs["model_spread"]["models"]}
    lead = models[fast.model]["log_evidence"]
    skipped = [r for r in models.values() if r["log_evidence_upper_bound"] is not None]
    assert skipped, "no candidate skipped on the GRS woofer"
    full_models = {r["model"]: r for r in full.inputs["model_spread"]["models"]}
    for r in skipped:
        assert r["log_evidence"] is None and r["log_evidence_upper_bound"] < lead - margin
        assert wf[r["model"]] == 0.0 and not r["included"]
        assert full_models[r["model"]]["log_evidence"] <= r["log_evidence_upper_bound"]
