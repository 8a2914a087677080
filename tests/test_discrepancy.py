"""The correlated model-discrepancy likelihood (bayes_emt.inference.discrepancy): exact against a
dense multivariate normal, the white likelihood as its limit, vectorised equal to per row, the
Kalman pointwise terms summing to the total, never NaN."""

import math

import numpy as np
import pytest
from scipy import stats

from bayes_emt import build_model, simulate
from bayes_emt.inference.discrepancy import NoiseCorrelation, ou_rho
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.measurement import Measurement
from bayes_emt.params import DISCREPANCY_PARAMS, noise_param_set
from bayes_emt.reference import PAPER_TABLES


def _paper(name, n_points, noise, seed):
    model = build_model(name)
    theta = model.vector(PAPER_TABLES[name])
    return model, theta, simulate(model, theta, np.geomspace(10, 1e5, n_points), noise=noise, seed=seed)


def _dense(x, absY, r, sigma, sd, ell):
    """The same model written out: real and imaginary parts each ~ N(0, D + G K G)."""
    K = np.exp(-np.abs(x[:, None] - x[None, :]) / ell)
    g = sd * absY
    C = g[:, None] * K * g[None, :] + np.diag(sigma**2)
    mvn = stats.multivariate_normal(np.zeros(x.size), C)
    return mvn.logpdf(r.real) + mvn.logpdf(r.imag)


@pytest.fixture(scope="module")
def setup():
    rng = np.random.default_rng(3)
    f = np.sort(10 ** rng.uniform(1, 3, 40))  # an uneven grid, as after --exclude-band or a linear sweep
    omega = 2 * math.pi * f
    absY = 0.1 + 0.05 * np.sin(np.log10(f))
    r = (rng.standard_normal(40) + 1j * rng.standard_normal(40)) * 1e-3
    sigma = 1e-3 * (0.5 + rng.uniform(size=40))
    return NoiseCorrelation(omega, absY), r, sigma


@pytest.mark.parametrize(("sd", "ell"), [(0.01, 1e-3), (0.01, 0.05), (0.03, 0.5), (0.2, 1.0)])
def test_total_and_pointwise_equal_the_dense_gaussian(setup, sd, ell):
    nc, r, sigma = setup
    want = _dense(nc.x, nc.absY, r, sigma, sd, ell)
    tot = nc.total(r[None], sigma[None], np.array([sd]), np.array([ell]))[0]
    pw = nc.pointwise(r[None], sigma[None], np.array([sd]), np.array([ell]))[0]
    assert tot == pytest.approx(want, rel=1e-10, abs=1e-8)
    assert pw.sum() == pytest.approx(want, rel=1e-10, abs=1e-8)


def test_ou_correlation_on_an_uneven_grid():
    x = np.array([0.0, 0.1, 0.25, 0.26])
    np.testing.assert_allclose(ou_rho(x, 0.1), np.exp(-np.array([0.1, 0.15, 0.01]) / 0.1), rtol=1e-15)


def test_no_discrepancy_is_the_white_likelihood_exactly():
    """sigma_disc = 0 (and any ell) gives the white Gaussian likelihood (same noise scales)."""
    model, theta, meas = _paper("UD", 200, 0.01, 2)
    white = Likelihood(model, meas)
    corr = Likelihood(model, meas, noise="correlated")
    assert corr.params.names[-2:] == ("sigma_disc", "ell")
    th = np.r_[theta, 0.01, 1e-9]
    for ell in (1e-4, 0.03, 1.0):
        t = np.r_[th, 0.0, ell][None]
        assert corr(t)[0] == pytest.approx(white(th[None])[0], rel=1e-12)
        np.testing.assert_allclose(corr.pointwise(t), white.pointwise(th[None]), rtol=1e-12)


def test_vectorised_equals_per_row_and_never_nan():
    model, theta, meas = _paper("II", 120, 0.005, 1)
    lik = Likelihood(model, meas, noise="correlated")
    rng = np.random.default_rng(0)
    base = np.r_[theta, 0.005, 1e-9, 0.01, 0.1]
    th = base * np.exp(0.05 * rng.standard_normal((12, base.size)))
    rows = np.array([lik(t[None])[0] for t in th])
    np.testing.assert_allclose(lik(th), rows, rtol=1e-12)
    np.testing.assert_allclose(lik.pointwise(th).sum(-1), rows, rtol=1e-9)
    bad = th[:6].copy()
    bad[0, -1] = np.nan
    bad[1, -2] = np.inf
    bad[2, -1] = 0.0
    bad[3, -4] = 0.0  # sigma_rel and sigma_abs zero: a zero noise scale
    bad[3, -3] = 0.0
    bad[4, 0] = -1.0
    bad[5, -2] = -0.1
    for v in (lik(bad), lik.pointwise(bad).sum(-1), lik.log_posterior_z(lik.params.to_z(np.abs(bad)))):
        assert not np.any(np.isnan(v))
    assert np.all(lik(bad)[[0, 1, 3]] == -np.inf)


def test_noise_parameters_and_student_refused():
    names = noise_param_set("gaussian", None, "correlated").names
    assert names == ("sigma_rel", "sigma_abs", "sigma_disc", "ell")
    assert [p.prior.lower for p in DISCREPANCY_PARAMS] == [1e-6, 1e-4]
    model, _, meas = _paper("II", 50, 0.005, 1)
    with pytest.raises(ValueError, match="gaussian likelihood"):
        Likelihood(model, meas, "student", 4.0, noise="correlated")
    with pytest.raises(ValueError, match="unknown noise"):
        Likelihood(model, meas, noise="pink")


def test_predictive_draws_carry_the_ou_correlation():
    """Replicated residuals at the posterior point: lag correlation exp(-dx/ell) when the
    discrepancy dominates the noise."""
    f = np.logspace(1, 3, 201)
    model = build_model("II")
    th = model.vector(PAPER_TABLES["II"])
    Y = model.admittance(2 * math.pi * f, th)
    lik = Likelihood(model, Measurement.from_hz(f, Y), noise="correlated")
    ell = 0.05
    theta = np.tile(np.r_[th, 1e-6, 1e-12, 0.01, ell], (4000, 1))
    Ym, Yr = lik.predictive(theta, np.random.default_rng(0))
    u = ((Yr - Ym) / np.abs(Y)).real
    lag = np.mean(u[:, 100] * u[:, 101]) / np.mean(u[:, 100] ** 2)
    want = math.exp(-(np.log10(f[101]) - np.log10(f[100])) / ell)
    assert lag == pytest.approx(want, abs=0.03)  # 4000 draws: sd of the estimate ~ 0.005
    assert np.std(u[:, 50]) == pytest.approx(0.01, rel=0.05)
