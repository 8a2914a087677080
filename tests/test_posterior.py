"""Likelihood, emcee driver, DataTree output, checkpoint/resume, priors (issue: posterior)."""

import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from bayes_emt import ConvergenceWarning, build_model, simulate
from bayes_emt.cli import main
from bayes_emt.errors import DataFormatError
from bayes_emt.io import write_measurement
from bayes_emt.likelihood import Likelihood
from bayes_emt.priors import apply_prior_file
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.sampling import SamplerSettings, sample_posterior

OMEGA = np.geomspace(10, 1e5, 200)


@pytest.fixture(scope="module")
def meas_I():
    return simulate(build_model("I"), PAPER_TABLES["I"], OMEGA, noise=0.002, seed=3)


@pytest.fixture(scope="module")
def post_I(meas_I):
    return sample_posterior(meas_I, build_model("I"), seed=1, max_steps=8000)


def test_pointwise_gaussian_matches_formula(meas_I):
    m = build_model("I")
    lik = Likelihood(m, meas_I)
    theta = np.r_[m.vector(PAPER_TABLES["I"]), 0.002, 1e-4]
    r = m.admittance(meas_I.omega, theta[:5]) - meas_I.Y
    sig2 = (0.002 * np.abs(meas_I.Y)) ** 2 + (1e-4 * np.median(np.abs(meas_I.Y))) ** 2
    expected = -np.log(2 * np.pi * sig2) - np.abs(r) ** 2 / (2 * sig2)
    np.testing.assert_allclose(lik.pointwise(theta), expected, rtol=1e-12)
    batch = np.stack([theta, theta * 1.01])
    np.testing.assert_allclose(lik(batch)[0], expected.sum(), rtol=1e-12)


def test_student_t_integrates_to_one_and_is_heavier_tailed():
    from scipy import integrate

    m = build_model("I")
    one = simulate(m, PAPER_TABLES["I"], np.array([50.0, 60.0, 70.0]), noise=0.0)
    lik_t = Likelihood(m, one, "student", nu=4.0)
    theta = np.r_[m.vector(PAPER_TABLES["I"]), 0.01, 1e-7]
    # shift the data's real part of point 0 by x and integrate exp(loglik) over x: density of one part
    sig = float(lik_t.sigma(0.01, 1e-7)[0])

    def dens(x):
        ll = lik_t.pointwise(theta)[0]  # at zero residual both parts contribute the peak density
        t = (x / sig) ** 2 / 4.0
        return math.exp(ll / 2 - 2.5 * math.log1p(t) + 2.5 * math.log1p(0.0))

    total, _ = integrate.quad(dens, -60 * sig, 60 * sig, limit=200)
    assert total == pytest.approx(1.0, abs=2e-3)


def test_log_posterior_is_minus_inf_outside_support_never_nan(meas_I):
    lik = Likelihood(build_model("I"), meas_I)
    z = lik.params.to_z(np.r_[build_model("I").vector(PAPER_TABLES["I"]), 0.002, 1e-4])
    bad = np.array([z, z + 1e3, np.full_like(z, np.nan)])
    out = lik.log_posterior_z(bad)
    assert np.isfinite(out[0]) and out[1] == -np.inf and out[2] == -np.inf


def test_sampler_converges_and_agrees_with_least_squares(post_I, meas_I):
    # a well-posed model with Gaussian noise: the posterior's centre and spread must match the
    # least-squares estimate and its standard errors (coverage over many datasets is the job of
    # scripts/calibrate_posterior.py)
    from bayes_emt.fitting import fit_admittance

    assert post_I.converged
    assert post_I.n_steps >= 50 * np.max(post_I.tau)
    assert np.min(post_I.ess) >= 1000
    fit = fit_admittance(meas_I, build_model("I"))
    x = post_I.flat()[:, :5]
    se = np.array(list(fit.stderr.values()))
    assert np.all(np.abs(np.median(x, axis=0) - fit.theta) < 0.3 * se)
    assert np.all(np.abs(x.std(axis=0) / se - 1) < 0.1)  # importance sampling: ratio 1.006
    truth = build_model("I").vector(PAPER_TABLES["I"])
    assert np.all(np.abs(np.median(x, axis=0) - truth) < 4 * x.std(axis=0))
    sr = post_I.summary_rows()[5]
    assert sr["name"] == "sigma_rel" and sr["q05"] < 0.002 < sr["q95"]


def test_default_moves_sample_a_gaussian_exactly():
    # known answer: a correlated 7-D Gaussian; the marginal standard deviations must come out
    # right to within Monte Carlo error (~1 % here). emcee's DESnookerMove fails this (-15 %).
    import emcee

    from bayes_emt.sampling import default_moves

    rng = np.random.default_rng(1)
    A = rng.standard_normal((7, 7))
    C = A @ A.T + 0.1 * np.eye(7)
    Ci = np.linalg.inv(C)
    s = emcee.EnsembleSampler(28, 7, lambda x: -0.5 * np.einsum("ij,jk,ik->i", x, Ci, x),
                              moves=default_moves(), vectorize=True)
    s._random.seed(3)
    s.run_mcmc(rng.multivariate_normal(np.zeros(7), C, size=28), 12000)
    ratio = s.get_chain(discard=500, flat=True).std(axis=0) / np.sqrt(np.diag(C))
    assert np.all(np.abs(ratio - 1) < 0.03), ratio


def test_same_seed_same_numbers(meas_I):
    a = sample_posterior(meas_I, build_model("I"), seed=7, max_steps=300)
    b = sample_posterior(meas_I, build_model("I"), seed=7, max_steps=300)
    np.testing.assert_array_equal(a.draws, b.draws)


def test_non_converging_run_says_so(meas_I, tmp_path):
    with pytest.warns(ConvergenceWarning, match="not converged"):
        p = sample_posterior(meas_I, build_model("I"), seed=1, max_steps=200)
    assert not p.converged and p.to_json_dict()["converged"] is False
    data = tmp_path / "i.csv"
    write_measurement(meas_I, data)
    js = tmp_path / "s.json"
    rc = main(["sample", str(data), "--model", "I", "--max-steps", "200", "--out", str(tmp_path / "r.nc"),
               "--json", str(js), "--quiet"])
    assert rc == 1
    assert json.loads(js.read_text())["converged"] is False


def test_datatree_round_trip_and_summary(post_I, tmp_path):
    import arviz as az

    path = tmp_path / "run.nc"
    post_I.save(path)
    dt = az.from_netcdf(path)
    groups = {"posterior", "log_likelihood", "sample_stats", "observed_data", "constant_data"}
    assert groups <= set(dt.children)
    assert dt["log_likelihood"]["Y"].dims == ("chain", "draw", "omega")
    np.testing.assert_allclose(dt["constant_data"]["omega_rad_s"].values, OMEGA)
    s = az.summary(dt)
    assert "R0" in s.index and np.all(np.isfinite(s["mean"].to_numpy(dtype=float)))
    assert dt.attrs["model"] == "I" and json.loads(dt.attrs["priors"])[0]["name"] == "zeta"
    loo = az.loo(dt)
    assert np.isfinite(loo.elpd)


def _iteration(path):
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return int(f["mcmc"].attrs["iteration"])
    except (OSError, KeyError):
        return 0


def test_sigkill_and_resume_loses_nothing(meas_I, tmp_path):
    data = tmp_path / "i.csv"
    write_measurement(meas_I, data)
    env = {**os.environ, "HDF5_USE_FILE_LOCKING": "FALSE", "OMP_NUM_THREADS": "1"}
    base = [sys.executable, "-m", "bayes_emt.cli", "sample", str(data), "--model", "I", "--seed", "5",
            "--max-steps", "1500", "--quiet"]
    ref = subprocess.run(base + ["--out", str(tmp_path / "ref.nc")], env=env, capture_output=True, text=True)
    assert ref.returncode in (0, 1), ref.stderr
    ck = tmp_path / "cut.h5"
    proc = subprocess.Popen(base + ["--out", str(tmp_path / "cut.nc"), "--checkpoint", str(ck)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while _iteration(ck) < 300 and time.time() - t0 < 120:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    killed_at = _iteration(ck)
    assert 0 < killed_at < 1500
    res = subprocess.run(base + ["--out", str(tmp_path / "cut.nc"), "--checkpoint", str(ck), "--resume"],
                         env=env, capture_output=True, text=True)
    assert res.returncode in (0, 1), res.stderr
    import h5py

    with h5py.File(tmp_path / "ref.h5", "r") as a, h5py.File(ck, "r") as b:
        na, nb = a["mcmc"].attrs["iteration"], b["mcmc"].attrs["iteration"]
        assert na == nb
        np.testing.assert_array_equal(a["mcmc"]["chain"][:na], b["mcmc"]["chain"][:nb])


def test_resume_refuses_a_different_run(meas_I, tmp_path):
    ck = tmp_path / "c.h5"
    sample_posterior(meas_I, build_model("I"), seed=1, max_steps=50, checkpoint=ck,
                     settings=SamplerSettings(check_every=50))
    with pytest.raises(ValueError, match="seed"):
        sample_posterior(meas_I, build_model("I"), seed=2, max_steps=100, checkpoint=ck, resume=True)


def test_prior_file_overrides_and_errors(tmp_path):
    good = tmp_path / "p.toml"
    good.write_text('[R0]\ndist = "lognormal"\nmedian = 2.6\nsigma_log = 0.05\n')
    m = apply_prior_file(build_model("I"), good)
    assert m.params["R0"].prior.median == 2.6
    bad = tmp_path / "b.toml"
    bad.write_text('[Rzero]\ndist = "uniform"\nlower = 1\nupper = 2\n')
    with pytest.raises(DataFormatError, match="b.toml: unknown parameter"):
        apply_prior_file(build_model("I"), bad)
    worse = tmp_path / "w.json"
    worse.write_text('{"R0": {"dist": "gamma"}}')
    with pytest.raises(DataFormatError, match="w.json: R0: unknown prior dist"):
        apply_prior_file(build_model("I"), worse)
