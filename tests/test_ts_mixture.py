"""Model form in the T/S intervals (bayes_emt.thiele_small.mixture): weighted quantiles, evidence
weights, the Laplace components, and the evidence-supported default model."""

import math

import numpy as np
import pytest
from scipy import stats

from bayes_emt import build_model, simulate
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.compute import AUTO_CANDIDATES
from bayes_emt.thiele_small.mixture import laplace_draws, mixture_weights, weighted_quantiles
from bayes_emt.thiele_small.simulate import simulate_driver


def test_weighted_quantiles_of_a_two_component_mixture():
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 1, 20000), rng.normal(10, 1, 5000)
    # 0.75 / 0.25 weights whatever the draw counts: the median is in the first component
    v = np.r_[a, b]
    w = np.r_[np.full(a.size, 0.75 / a.size), np.full(b.size, 0.25 / b.size)]
    q05, q50, q95 = weighted_quantiles(v, w, [0.05, 0.5, 0.95])
    # exact mixture quantiles (the components do not overlap): N(0,1) below 0.75, N(10,1) above
    assert q50 == pytest.approx(stats.norm.ppf(0.5 / 0.75), abs=0.04)
    assert q05 == pytest.approx(stats.norm.ppf(0.05 / 0.75), abs=0.06)
    assert q95 == pytest.approx(10 + stats.norm.ppf((0.95 - 0.75) / 0.25), abs=0.08)
    assert np.isnan(weighted_quantiles([np.nan], [1.0], [0.5])).all()


def test_mixture_weights_are_normalised_evidence_ratios():
    w = mixture_weights({"A": 0.0, "B": math.log(3.0), "C": float("nan")})
    assert set(w) == {"A", "B"} and w["B"] == pytest.approx(0.75) and w["A"] == pytest.approx(0.25)
    assert mixture_weights({"A": float("nan")}) == {}


def test_laplace_component_matches_the_fit_when_the_model_is_right():
    """A simulated UD curve (0.5 % noise, 300 points): the Laplace component under the correlated
    likelihood is centred on the truth within its own 3 sd, with a finite covariance."""
    from bayes_emt.estimation.fitting import fit_admittance

    model = build_model("UD")
    truth = model.vector(PAPER_TABLES["UD"])
    meas = simulate(model, truth, np.geomspace(10, 1e5, 300), noise=0.005, seed=4)
    fit = fit_admittance(meas, model)
    th, why = laplace_draws(Likelihood(model, meas, noise="correlated"), fit, 2000, np.random.default_rng(1))
    assert th is not None, why
    z = (np.log(np.median(th, axis=0)) - np.log(truth)) / np.std(np.log(th), axis=0)
    assert np.all(np.abs(z) < 3), z


def test_default_model_is_the_most_probable_candidate_and_the_mixture_is_reported():
    sim = simulate_driver("UD", deltas=(), seed=2, n_points=300)
    r = thiele_small(sim.free, fast=True)
    sp = r.inputs["model_spread"]["models"]
    assert r.inputs["model_choice"] == "evidence" and r.inputs["noise"] == "white"  # the default
    assert set(AUTO_CANDIDATES) <= {m["model"] for m in sp}
    ok = [m for m in sp if not m["undetermined"] and m["log_evidence"] is not None]
    assert sp[0]["model"] == max(ok, key=lambda m: m["log_evidence"])["model"]  # the main model first
    assert r.inputs["mixture"]["weights"]
    for p in r.parameters.values():
        assert p["model_spread"] is not None and p["model_only"]["model"] == sp[0]["model"]


def test_the_curve_is_the_requested_models_not_the_last_candidates():
    """With a requested model the spread's candidates (II, III) get Laplace components after the
    main posterior; the result's curve (and Small's method on it) stays the requested model's."""
    from bayes_emt.inference.sampling import SamplerSettings

    sim = simulate_driver("UD", deltas=(), seed=2, n_points=200)
    short = SamplerSettings(max_steps=200, warmup=100, ess_target=50, min_tau_multiple=5, max_draws=400)
    with pytest.warns(Warning):  # a 200-step chain may not meet the stopping rule; that is not tested
        r = thiele_small(sim.free, "UD", settings=short)
    assert {"II", "III"} <= set(r.inputs["mixture"]["weights"]) | set(r.inputs["model_spread"]["candidates"])
    assert r.curve["model"] == r.model


def test_an_undetermined_candidates_evidence_is_computed_only_when_every_candidate_is_undetermined():
    from bayes_emt.thiele_small.compute import _resolve_deferred

    calls = []

    def rec(und, lz):
        r = {"undetermined": und, "log_z": lz}
        if und:
            r["deferred_evidence"] = lambda: calls.append(1) or -5.0
        return (None, None, r)

    comps = {"A": rec([], 1.0), "B": rec(["x"], float("nan"))}
    _resolve_deferred(comps)
    assert not calls and math.isnan(comps["B"][2]["log_z"])  # A is determined: B's evidence is not needed
    comps = {"B": rec(["x"], float("nan")), "C": rec(["y"], float("nan"))}
    _resolve_deferred(comps)
    assert len(calls) == 2 and comps["B"][2]["log_z"] == -5.0 and "deferred_evidence" not in comps["C"][2]


def test_a_requested_models_spread_weighs_it_against_the_physics_the_default_tries():
    """``ts --model UD``'s candidates: the other coil models (NL(3) among them) and UD with each
    physics term the default tries; a requested model that holds a term keeps it on every base and
    is not offered twice; a ring count is part of a candidate's name (NL(5) requested: NL(3) stays)."""
    from bayes_emt.models import parse_model_spec
    from bayes_emt.thiele_small.compute import AUTO_TERMS
    from bayes_emt.thiele_small.spread import spread_models

    def labels(spec):
        return [m.label for m in spread_models(parse_model_spec(spec), None, parse_model_spec, AUTO_TERMS)]

    assert labels("UD") == ["II", "III", "NL(2)", "NL(3)", "UD+semi_inductance", "UD+suspension_creep"]
    assert labels("NL(5)") == ["II", "III", "UD", "NL(2)", "NL(3)", "NL(5)+semi_inductance",
                               "NL(5)+suspension_creep"]
    assert labels("NL(2)") == ["II", "III", "UD", "NL(3)", "NL(2)+semi_inductance", "NL(2)+suspension_creep"]
    assert labels("UD+suspension_creep") == ["II+suspension_creep", "III+suspension_creep",
                                             "NL(2)+suspension_creep", "NL(3)+suspension_creep",
                                             "UD+suspension_creep+semi_inductance"]
    explicit = spread_models(parse_model_spec("UD"), ["III"], parse_model_spec, AUTO_TERMS)
    assert [m.label for m in explicit] == ["III"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 17])
def test_a_requested_wrong_model_with_an_added_mass_reports_the_mixture_that_holds_the_truth(seed):
    """Data from NL(3) + LOG creep with a 10 g added mass (0.5 % noise, 300 points), ``ts`` asked for
    UD: the joint candidates get Laplace components, the evidence puts the weight on NL(3) with
    creep (tried on the best coil model as the default does, and on NL(3) itself when its own joint
    evidence fails, as on seed 17, where UD+creep took the weight and Re was 4.9 % off), the
    reported values and intervals are the mixture's and hold the truth; UD's own values stay under
    ``model_only`` and a line says so."""
    from bayes_emt.thiele_small.simulate import simulate_driver as sim_driver

    coil = {k: PAPER_TABLES["NL"][k] for k in ("Pg", "P1", "P2", "P3", "R1", "R2", "R3")}
    sim = sim_driver("NL(3)+suspension_creep", driver=coil, deltas=(0.010,), seed=seed, n_points=300)
    r = thiele_small(sim.free, "UD", loaded=list(sim.loaded), sd=sim.sd, seed=seed)
    w = r.inputs["mixture"]["weights"]
    assert max(w, key=w.get) == "NL(3)+suspension_creep" and w["NL(3)+suspension_creep"] > 0.9
    assert any(x["code"] == "better_model" for x in r.warnings)
    for k in ("fs", "Re", "Qms", "Qes", "Bl", "Mms"):
        p = r.parameters[k]
        assert p["ci90"][0] <= sim.truth[k] <= p["ci90"][1], (k, p, sim.truth[k])
        assert p["model_only"]["model"] == "UD"
    # UD alone is off in Re (its coil takes part of the creep's loss): the mixture is what holds it
    ud = r.parameters["Re"]["model_only"]
    assert not ud["ci90"][0] <= sim.truth["Re"] <= ud["ci90"][1]
