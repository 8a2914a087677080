"""An ohmmeter reading of R0 (``--re``): the cut (default) and the prior mode
(:mod:`bayes_emt.estimation.meter`, :mod:`bayes_emt.inference.meter_cut`)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from bayes_emt.added_mass.multi import fit_multi_mass
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.estimation.meter import Meter, as_meter, cut_covariance, move_draws
from bayes_emt.io import write_measurement
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver

SPEC = "I+semi_inductance"


@pytest.fixture(scope="module")
def driver():
    sim = simulate_driver(SPEC, deltas=(0.010,), seed=5, n_points=400)
    model = parse_model_spec(SPEC)
    return sim, model, fit_admittance(sim.free, model)


def test_as_meter_forms_and_bad_values():
    assert as_meter(None) is None
    m = as_meter(5.0)
    assert (m.value, m.sd, m.mode) == (5.0, 0.05, "cut")
    assert as_meter((5.0, 0.1, "prior")).mode == "prior"
    assert as_meter((5.0, 0.1), "prior").mode == "prior"
    for bad in ((5.0, 0.0), (-1.0, 0.1), (5.0, 0.1, "maybe"), "x"):
        with pytest.raises(ValueError, match="re"):
            as_meter(bad)


def test_cut_covariance_is_conditional_plus_the_readings_variance():
    """For a Gaussian ``N(0, Σ)``: ``Σ_cond`` is the covariance given coordinate 0 (Schur complement),
    ``v`` the regression on it, and ``Σ_cut`` gives coordinate 0 the reading's variance."""
    rng = np.random.default_rng(0)
    a = rng.normal(size=(4, 4))
    cov = a @ a.T + 4 * np.eye(4)
    cut, v, cond = cut_covariance(cov, 0, 0.3)
    schur = cov[1:, 1:] - np.outer(cov[1:, 0], cov[0, 1:]) / cov[0, 0]
    assert np.allclose(cond[1:, 1:], schur, rtol=1e-12)
    assert v[0] == 1.0 and np.allclose(v[1:], cov[1:, 0] / cov[0, 0])
    assert cut[0, 0] == pytest.approx(0.09, rel=1e-12)
    assert np.allclose(cut[1:, 0], 0.09 * v[1:])
    assert np.all(np.linalg.eigvalsh(cut) > -1e-12)


def test_move_draws_gives_the_readings_distribution():
    """R0 (on a log sampling space here) takes N(value, sd); the other parameter moves by its
    regression per ohm; the same seed gives the same draws."""
    from bayes_emt.params import LogUniform, ParamSet, ParamSpec

    params = ParamSet([ParamSpec("R0", "ohm", "R0", LogUniform(0.1, 100.0)),
                       ParamSpec("a", "-", "a", LogUniform(1e-3, 1e3))])
    rng = np.random.default_rng(1)
    x = np.column_stack([np.full(20000, 2.0), np.exp(rng.normal(size=20000))])
    meter = Meter(2.0, 0.1)
    out = move_draws(x, params, 0, np.array([0.0, 0.5]), meter, np.random.default_rng(2))
    assert out[:, 0].mean() == pytest.approx(2.0, abs=4 * 0.1 / np.sqrt(20000))
    assert out[:, 0].std() == pytest.approx(0.1, rel=0.03)
    assert np.allclose(np.log(out[:, 1]) - np.log(x[:, 1]), 0.5 * (out[:, 0] - 2.0))
    again = move_draws(x, params, 0, np.array([0.0, 0.5]), meter, np.random.default_rng(2))
    assert np.array_equal(out, again)  # same seed, same draws (same process)


def test_cut_holds_r0_at_the_reading_when_the_data_pin_it_tighter(driver):
    """The data pin R0 at σ_d; a reading 3 σ_d away with sd 5 σ_d: Bayes' rule (prior mode) leaves R0
    near the data's value, the cut puts it at the reading with the reading's sd, and every other
    parameter moves by its regression on R0 (the linear cut, to 15 % of each move that is larger
    than a tenth of that parameter's standard error)."""
    sim, model, free = driver
    r0, sd_d = free.parameters["R0"], free.stderr["R0"]
    meter, sd = r0 + 3 * sd_d, 5 * sd_d
    cut = fit_admittance(sim.free, model, re=(meter, sd))
    prior = fit_admittance(sim.free, model, re=(meter, sd, "prior"))
    assert abs(cut.parameters["R0"] - meter) <= 1e-3 * sd
    assert cut.stderr["R0"] == pytest.approx(sd, rel=0.02)
    assert abs(prior.parameters["R0"] - r0) < abs(prior.parameters["R0"] - meter)
    info = cut.info["re"]
    assert info["mode"] == "cut" and info["R0_data"] == pytest.approx(r0, rel=1e-6)
    assert info["conflict_sd"] == pytest.approx(3 * sd_d / np.hypot(sd_d, sd), rel=0.05)
    assert not [w for w in cut.warnings if w["code"] == "re_conflict"]
    params = model.params
    dz = params.to_z(cut.theta) - params.to_z(free.theta)
    i = model.names.index("R0")
    pred = np.asarray(info["sensitivity_per_ohm"]) * (cut.theta[i] - free.theta[i])
    se_z = np.sqrt(np.diag(free.cov_z))
    big = np.abs(pred) > 0.1 * se_z
    big[i] = False
    assert big.sum() >= 3
    assert np.allclose(dz[big], pred[big], rtol=0.15, atol=0.0), (dz, pred)
    for name in model.names:  # Σ_cut − Σ_data = (sd_z² − Σ_ii) v vᵀ ⪰ 0 when the reading is the looser
        if name != "R0":
            assert cut.stderr[name] >= 0.95 * free.stderr[name], name
    assert cut.chi2 >= free.chi2 * (1 - 1e-9)  # R0 off the data's optimum: the data fit no better


def test_a_reading_far_from_the_data_is_warned_about(driver):
    sim, model, free = driver
    r0, sd_d = free.parameters["R0"], free.stderr["R0"]
    f = fit_admittance(sim.free, model, re=(r0 + 30 * sd_d, sd_d))
    w = [w for w in f.warnings if w["code"] == "re_conflict"]
    assert len(w) == 1 and "ohm" in w[0]["message"] and "cut" in w[0]["message"]
    assert f.info["re"]["conflict_sd"] == pytest.approx(30 / np.sqrt(2), rel=0.05)


def test_joint_added_mass_fit_under_the_cut(driver):
    sim, model, _ = driver
    runs = [sim.free, sim.loaded[0][0]]
    plain = fit_multi_mass(runs, [0.010], model)
    r0 = plain.values["R0"]
    meter = Meter(r0 * 1.02, r0 * 0.005)
    mf = fit_multi_mass(runs, [0.010], model, re=meter)
    assert abs(mf.values["R0"] - meter.value) <= 1e-3 * meter.sd
    assert mf.stderr["R0"] == pytest.approx(meter.sd, rel=0.02)
    assert mf.re["mode"] == "cut" and len(mf.re["sensitivity_per_ohm"]) == len(mf.joint.names)


def test_ts_fast_reports_the_readings_re(driver):
    sim, model, free = driver
    meter = free.parameters["R0"] * 1.03
    r = thiele_small(sim.free, SPEC, re=(meter, 0.01 * meter), fast=True, models_for_spread=[], seed=0)
    p = r.parameters["Re"]
    assert abs(p["value"] - meter) <= 0.2 * 0.01 * meter
    lo, hi = p["ci90"]
    assert (hi - lo) / 2 == pytest.approx(1.645 * 0.01 * meter, rel=0.15)
    assert r.inputs["re"]["mode"] == "cut"


def test_cut_posterior_gives_r0_the_readings_distribution(driver):
    """The cut posterior: R0's draws follow N(reading, sd) (mean within 4 standard errors of the
    draws' mean, sd within 10 %), the record's R0 prior is the reading, and the other parameters'
    medians sit at the cut fit's values within a quarter of their posterior sd."""
    from bayes_emt.inference.meter_cut import cut_posterior, held_fit
    from bayes_emt.inference.sampling import SamplerSettings, sample_posterior

    sim, model, free = driver
    meter = Meter(free.parameters["R0"] + 3 * free.stderr["R0"], 5 * free.stderr["R0"])
    fit = fit_admittance(sim.free, model, re=meter)
    held = model.with_priors({"R0": meter.prior()})
    settings = SamplerSettings(max_steps=4000, ess_target=400.0)
    post = cut_posterior(sample_posterior(sim.free, held, fit=held_fit(fit, meter), seed=3, settings=settings,
                                          progress=False), fit, meter, seed=3)
    i = post.names.index("R0")
    r0 = post.flat()[:, i]
    assert r0.mean() == pytest.approx(meter.value, abs=4 * meter.sd / np.sqrt(400))
    assert r0.std() == pytest.approx(meter.sd, rel=0.10)
    assert post.likelihood.model.params["R0"].prior.to_dict()["sigma"] == pytest.approx(meter.sd)
    assert np.all(np.isfinite(post.log_prob)) and post.settings["re"]["mode"] == "cut"
    flat = post.flat()
    for k, name in enumerate(model.names):
        if name != "R0":
            assert abs(np.median(flat[:, k]) - fit.parameters[name]) <= 0.25 * flat[:, k].std(), name


def test_cli_fit_says_how_the_reading_counted(tmp_path, driver):
    sim, _, free = driver
    data = write_measurement(sim.free, tmp_path / "free.zma")
    meter = free.parameters["R0"] * 1.05
    base = [sys.executable, "-m", "bayes_emt.cli", "fit", str(data), "--model", SPEC, "--re", f"{meter:.5f}"]
    p = subprocess.run(base, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "held at the reading (cut)" in p.stdout and "re_conflict" in p.stdout
    q = subprocess.run(base + ["--re-mode", "prior"], capture_output=True, text=True, timeout=300)
    assert q.returncode == 0, q.stderr
    assert "applied as a penalty (prior)" in q.stdout
    bad = subprocess.run(base + ["--re-mode", "maybe"], capture_output=True, text=True, timeout=60)
    assert bad.returncode != 0 and "--re-mode" in bad.stderr and "Traceback" not in bad.stderr


def test_api_sample_with_a_reading(driver):
    """``be.sample(..., re=...)``: the cut by default (R0's draws spread like the reading), Bayes'
    rule with ``"prior"`` (R0 stays near the data's value when the data pin it 5x tighter)."""
    import bayes_emt as be
    from bayes_emt.inference.sampling import SamplerSettings

    sim, model, free = driver
    sd_d = free.stderr["R0"]
    reading = (free.parameters["R0"] + 3 * sd_d, 5 * sd_d)
    settings = SamplerSettings(max_steps=4000, ess_target=400.0)
    cut = be.sample(sim.free, SPEC, re=reading, seed=1, settings=settings, progress=False)
    prior = be.sample(sim.free, SPEC, re=(*reading, "prior"), seed=1, settings=settings, progress=False)
    i = cut.names.index("R0")
    assert cut.flat()[:, i].std() == pytest.approx(reading[1], rel=0.10)
    assert abs(np.median(prior.flat()[:, i]) - free.parameters["R0"]) < 1.5 * sd_d
    assert prior.flat()[:, i].std() < 0.5 * reading[1]
