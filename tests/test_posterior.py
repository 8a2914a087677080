"""Posterior record: agreement with least squares, DataTree file, derived quantities, plots, CLI."""

import json
import math
import warnings

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.cli import main
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.inference.posterior import Posterior, physical_from_pair, read_posterior
from bayes_emt.inference.sampling import SamplerSettings, sample_posterior
from bayes_emt.io import write_measurement
from bayes_emt.reference import PAPER_ADDED_MASS, PAPER_PHYSICAL, PAPER_TABLES

OMEGA = np.geomspace(10, 1e5, 200)
MODEL = build_model("I")


@pytest.fixture(scope="module")
def meas_I():
    return simulate(MODEL, PAPER_TABLES["I"], OMEGA, noise=0.002, seed=3)


@pytest.fixture(scope="module")
def post_I(meas_I):
    return sample_posterior(meas_I, MODEL, seed=1, max_steps=8000)


def test_converged_posterior_agrees_with_least_squares(post_I, meas_I):
    # a well-posed model with Gaussian noise: centre and spread match the least-squares estimate
    # and its standard errors (coverage over many datasets: scripts/calibrate_posterior.py)
    from bayes_emt.estimation.fitting import fit_admittance

    assert post_I.converged and "converged at step" in post_I.message
    start = post_I.settings["production_start"]  # the stopping rule's chain: the last production segment
    assert start >= post_I.settings["warmup"] and post_I.n_steps % post_I.settings["check_every"] == 0
    assert post_I.n_steps - start >= 50 * np.max(post_I.tau) and np.min(post_I.ess) >= 1000
    assert post_I.burn == start + math.ceil(2 * np.max(post_I.tau))
    assert post_I.draws.shape[0] * post_I.draws.shape[1] <= 2000 and post_I.steps[0] == post_I.burn
    assert 0.1 < post_I.acceptance < 0.95
    fit = fit_admittance(meas_I, MODEL)
    x = post_I.theta()
    se = np.array(list(fit.stderr.values()))
    assert np.all(np.abs(np.median(x, axis=0) - fit.theta) < 0.3 * se)
    assert np.all(np.abs(x.std(axis=0) / se - 1) < 0.12)
    truth = MODEL.vector(PAPER_TABLES["I"])
    assert np.all(np.abs(np.median(x, axis=0) - truth) < 4 * x.std(axis=0))
    rows = {r["name"]: r for r in post_I.summary_rows()}
    assert rows["sigma_rel"]["q05"] < 0.002 < rows["sigma_rel"]["q95"]
    assert rows["sigma_abs"]["unit"] == "S" and rows["R0"]["unit"] == "ohm"
    # the stored blob is the log-likelihood of the stored draw
    np.testing.assert_allclose(post_I.log_lik, post_I.likelihood(post_I.draws), rtol=1e-10)


def test_datatree_round_trip_summary_and_loo(post_I, tmp_path):
    import arviz as az

    path = post_I.save(tmp_path / "run.nc")
    dt = az.from_netcdf(path)
    groups = {"posterior", "log_likelihood", "sample_stats", "observed_data", "constant_data"}
    assert groups <= set(dt.children)
    assert dt["log_likelihood"]["Y"].dims == ("chain", "draw", "omega")
    np.testing.assert_allclose(dt["constant_data"]["omega_rad_s"].values, OMEGA)
    np.testing.assert_array_equal(dt["posterior"]["draw"].values, post_I.steps)
    obs = dt["observed_data"]
    np.testing.assert_allclose(obs["Y_real"].values + 1j * obs["Y_imag"].values, post_I.likelihood.meas.Y)
    s = az.summary(dt)
    assert {"R0", "L0", "sigma_rel", "sigma_abs", "L_lf"} <= set(s.index)
    assert np.all(np.isfinite(s["mean"].to_numpy(dtype=float)))
    assert dt["posterior"]["R0"].attrs["units"] == "ohm"
    a = dt.attrs
    assert a["model"] == "I" and a["converged"] == 1 and a["n_steps"] == post_I.n_steps
    assert json.loads(a["priors"])[0]["name"] == "zeta" and json.loads(a["versions"])["emcee"]
    assert json.loads(a["tau"])["R0"] == pytest.approx(post_I.tau[3])
    with warnings.catch_warnings():  # a few Pareto k > 0.7 on 28 x 70 thinned draws: not the point here
        warnings.simplefilter("ignore", UserWarning)
        assert np.isfinite(az.loo(dt).elpd)
    back = read_posterior(path)
    np.testing.assert_array_equal(back.draws, post_I.draws)
    assert back.likelihood.params == post_I.likelihood.params and back.model.label == "I"
    assert back.summary_rows() == post_I.summary_rows() and back.converged


def test_derived_low_frequency_inductance_has_closed_forms():
    # SPEC §2: III at low frequency is (β √α / 2) s; UD adds Lg; I is L0
    for name, expected in (("I", lambda p: p["L0"]),
                           ("UD", lambda p: p["Lg"] + p["beta"] * math.sqrt(p["alpha"]) / 2),
                           ("III", lambda p: p["beta"] * math.sqrt(p["alpha"]) / 2)):
        m, p = build_model(name), PAPER_TABLES[name]
        theta = np.r_[m.vector(p), 0.002, 1e-9][None, None, :]
        post = _fake_posterior(m, theta)
        assert post.derived()["L_lf"][0, 0] == pytest.approx(expected(p), rel=1e-6)


def _fake_posterior(model, draws):
    meas = simulate(model, draws[0, 0, : model.ndim], np.array([10.0, 100.0]))
    lik = Likelihood(model, meas)
    c, d = draws.shape[:2]
    return Posterior(lik, draws, np.arange(d), np.zeros((c, d)), np.zeros((c, d)), np.ones(lik.ndim),
                     np.ones(lik.ndim), d, 0, 1, True, 0, "", 0.3, 0.0)


def test_added_mass_hook_reproduces_table_b9():
    # SPEC §3.4 / Tables 5, B.8, B.9: base NL (omega0 50.8) and 0.645 kg removed (omega0' 64.2)
    nl = build_model("NL")
    base = _fake_posterior(nl, np.r_[nl.vector(PAPER_TABLES["NL"]), 0.002, 1e-9][None, None, :])
    loaded = _fake_posterior(nl, np.r_[nl.vector(PAPER_ADDED_MASS["parameters"]), 0.002, 1e-9][None, None, :])
    phys = physical_from_pair(base, loaded, PAPER_ADDED_MASS["delta_m"])
    for name, ref in PAPER_PHYSICAL.items():  # the paper rounds to 3 figures (k: 4.47e3)
        assert phys[name][0] == pytest.approx(ref, rel=0.02), name
    wrong = physical_from_pair(base, loaded, +0.645)  # the resonance moved the wrong way
    assert np.isnan(wrong["m"][0])


def test_plots_return_figures(post_I):
    from matplotlib.figure import Figure

    from bayes_emt.plotting.posterior import plot_bode_bands, plot_corner, plot_trace

    for fig in (plot_corner(post_I, names=["R0", "L0", "sigma_rel"]), plot_bode_bands(post_I, n_draws=50),
                plot_trace(post_I, names=["R0", "omega0"])):
        assert isinstance(fig, Figure)
    with pytest.raises(ValueError, match="unknown parameter"):
        plot_corner(post_I, names=["Rzero"])
    with pytest.raises(TypeError):
        plot_bode_bands(post_I, colour="red")


def test_cli_sample_with_priors_json_and_plots(meas_I, tmp_path, capsys):
    data = tmp_path / "i.csv"
    write_measurement(meas_I, data)
    pri = tmp_path / "p.toml"
    pri.write_text('[R0]\ndist = "lognormal"\nmedian = 2.57\nsigma_log = 0.1\n')
    js = tmp_path / "s.json"
    rc = main(["sample", str(data), "--model", "I", "--out", str(tmp_path / "r.nc"), "--json", str(js),
               "--priors", str(pri), "--plot", str(tmp_path / "figs"), "--quiet", "--seed", "2",
               "--noise", "correlated"])
    out = capsys.readouterr().out
    assert rc == 0 and "CONVERGED" in out and "L_lf (derived)" in out and "ohm" in out
    rec = json.loads(js.read_text())
    # the stopping rule stops only at one of its checks (every SamplerSettings.check_every steps)
    assert rec["model"] == "I" and rec["converged"] is True
    assert rec["n_steps"] % SamplerSettings().check_every == 0
    # the correlated likelihood adds the model discrepancy's size and correlation length
    assert set(rec["parameters"]) == {"zeta", "omega0", "phi", "R0", "L0", "sigma_rel", "sigma_abs",
                                      "sigma_disc", "ell"}
    assert rec["noise"] == "correlated"
    assert rec["tau_max"] > 0 and rec["parameters"]["R0"]["ess"] >= 1000
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == [
        "posterior_I_bode.png", "posterior_I_corner.png", "posterior_I_trace.png"]
    back = read_posterior(tmp_path / "r.nc")
    assert back.model.params["R0"].prior.to_dict()["dist"] == "lognormal"
    assert back.likelihood.noise == "correlated"
    assert back.likelihood.params.names[-2:] == ("sigma_disc", "ell")
    # the reloaded correlated likelihood reproduces the stored log-likelihood of every draw
    np.testing.assert_allclose(back.likelihood(back.draws), back.log_lik, rtol=1e-10)
    # user errors: one line, exit 2
    assert main(["sample", str(data), "--model", "I", "--out", str(tmp_path / "r.nc"), "--quiet"]) == 2
    assert "a checkpoint exists" in capsys.readouterr().err


def test_student_t_resists_outliers():
    # three gross outliers (|Y| x 1.3) in 200 points: the Gaussian likelihood explains them by a
    # tenfold noise level (and up to tenfold wider intervals); the Student-t with sampled nu keeps the
    # 0.2 % noise, heavy tails (small nu) and the truth within 3 posterior sd
    m = build_model("I")
    base = simulate(m, PAPER_TABLES["I"], OMEGA, noise=0.002, seed=5)
    Y = base.Y.copy()
    Y[[20, 21, 22]] *= 1.3
    bad = type(base)(base.omega, Y, meta=dict(base.meta))
    truth = m.vector(PAPER_TABLES["I"])
    # both white (the Student-t likelihood is white): the comparison is of the error distributions
    g = sample_posterior(bad, m, seed=3, max_steps=4000, noise="white")
    t = sample_posterior(bad, m, seed=3, max_steps=4000, likelihood="student", nu=None)
    assert g.converged and t.converged
    med = {p: dict(zip(p.names, np.median(p.flat(), axis=0), strict=True)) for p in (g, t)}
    assert med[g]["sigma_rel"] > 0.01 and 0.0015 < med[t]["sigma_rel"] < 0.003 and med[t]["nu"] < 10
    sd_t, sd_g = t.theta().std(axis=0), g.theta().std(axis=0)
    assert np.all(sd_t[2:] < sd_g[2:] / 3) and np.all(sd_t <= sd_g)  # phi, R0, L0: ~10x narrower
    assert np.all(np.abs(np.median(t.theta(), axis=0) - truth) < 3 * t.theta().std(axis=0))


@pytest.mark.slow
def test_paper_bench_nl5_converges_with_ess_1000():
    # acceptance: NL(5) on the bundled paper-bench data (Table 5, 0.2 % noise, 2000 points)
    from bayes_emt.io.datasets import load_paper_bench

    post = sample_posterior(load_paper_bench(), build_model("NL", rings=5), seed=0)
    start = post.settings["production_start"]
    assert post.converged and post.n_steps - start >= 50 * np.max(post.tau) and np.min(post.ess) >= 1000
    truth = build_model("NL").vector(PAPER_TABLES["NL"])
    rows = post.summary_rows()[: truth.size]
    inside = [r["q05"] <= t <= r["q95"] for r, t in zip(rows, truth, strict=True)]
    assert sum(inside) >= 12  # 15 parameters, 90 % intervals: a handful of misses is expected
