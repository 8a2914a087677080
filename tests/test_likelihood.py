"""Likelihood (noise model, Student-t, vectorisation, emcee blob contract) and prior files."""

import json
import math

import emcee
import numpy as np
import pytest
from scipy import stats

from bayes_emt import build_model, simulate
from bayes_emt.errors import DataFormatError
from bayes_emt.inference.likelihood import NOISE_PARAMS, NU_SPEC, Likelihood, noise_param_set
from bayes_emt.inference.priors import apply_prior_file, apply_priors
from bayes_emt.io.priorfile import read_prior_file
from bayes_emt.reference import PAPER_TABLES

OMEGA = np.geomspace(10, 1e5, 120)
MODEL = build_model("I")
TRUTH = MODEL.vector(PAPER_TABLES["I"])


@pytest.fixture(scope="module")
def meas():
    return simulate(MODEL, TRUTH, OMEGA, noise=0.002, seed=3)


def test_gaussian_pointwise_matches_the_formula_and_vectorises(meas):
    lik = Likelihood(MODEL, meas)
    theta = np.r_[TRUTH, 0.002, 1e-5]
    r = MODEL.admittance(meas.omega, TRUTH) - meas.Y
    sig2 = (0.002 * np.abs(meas.Y)) ** 2 + 1e-5**2  # sigma_abs in siemens
    expected = -np.log(2 * np.pi * sig2) - np.abs(r) ** 2 / (2 * sig2)
    np.testing.assert_allclose(lik.pointwise(theta), expected, rtol=1e-12)
    batch = np.stack([theta, theta * 1.01, theta * 0.99])  # (W, k) -> (W, F) and (W,)
    assert lik.pointwise(batch).shape == (3, meas.n_points)
    np.testing.assert_allclose(lik(batch)[0], expected.sum(), rtol=1e-12)
    np.testing.assert_allclose(lik(batch)[1], lik(theta * 1.01), rtol=1e-12)


def test_noise_scale_uses_the_measured_magnitude(meas):
    # sigma_k depends on the data and the noise parameters only, never on the model parameters
    lik = Likelihood(MODEL, meas)
    a = lik.sigma(0.002, 0.0)
    np.testing.assert_allclose(a, 0.002 * np.abs(meas.Y))
    far = np.r_[TRUTH * 1.5, 0.002, 0.0]
    r = lik.residuals(far)
    ll = lik.pointwise(np.r_[far[:-1], 1e-12])
    np.testing.assert_allclose(ll, -np.log(2 * np.pi * a**2) - np.abs(r) ** 2 / (2 * a**2), rtol=1e-9)


def test_weights_divide_the_noise_scale():
    w = np.linspace(0.5, 2.0, OMEGA.size)
    m0 = simulate(MODEL, TRUTH, OMEGA, noise=0.002, seed=1)
    mw = type(m0)(m0.omega, m0.Y, weights=w, meta=dict(m0.meta))
    np.testing.assert_allclose(Likelihood(MODEL, mw).sigma(0.002, 1e-6),
                               Likelihood(MODEL, m0).sigma(0.002, 1e-6) / w)


def test_normalised_residuals_are_standard_normal_at_the_truth():
    m = simulate(MODEL, TRUTH, np.geomspace(10, 1e5, 2000), noise=0.002, seed=11)
    # the simulator's noise is relative to the true |Y|, the likelihood's to the measured |Y|:
    # the difference is second order (0.2 % of 0.2 %)
    e = Likelihood(MODEL, m).normalised_residuals(np.r_[TRUTH, 0.002, 1e-12])
    parts = np.r_[e.real, e.imag]
    assert abs(parts.mean()) < 4 / math.sqrt(parts.size)
    assert abs(parts.std() - 1) < 4 / math.sqrt(2 * parts.size)


def test_student_t_fixed_nu_is_two_independent_t_densities(meas):
    lik = Likelihood(MODEL, meas, "student", nu=3.0)
    theta = np.r_[TRUTH, 0.004, 1e-6]
    r = lik.residuals(theta)
    s = lik.sigma(0.004, 1e-6)
    expected = stats.t.logpdf(r.real, 3.0, scale=s) + stats.t.logpdf(r.imag, 3.0, scale=s)
    np.testing.assert_allclose(lik.pointwise(theta), expected, rtol=1e-10)
    assert lik.params.names[-2:] == ("sigma_rel", "sigma_abs")


def test_student_t_sampled_nu_is_a_parameter(meas):
    lik = Likelihood(MODEL, meas, "student", nu=None)
    assert lik.sample_nu and lik.params.names[-1] == "nu" and lik.params["nu"] == NU_SPEC
    thetas = np.array([np.r_[TRUTH, 0.004, 1e-6, nu] for nu in (2.0, 30.0)])
    for th, nu in zip(thetas, (2.0, 30.0), strict=True):
        fixed = Likelihood(MODEL, meas, "student", nu=nu)
        np.testing.assert_allclose(lik.pointwise(thetas)[list(thetas[:, -1]).index(nu)],
                                   fixed.pointwise(th[:-1]), rtol=1e-12)


def test_minus_inf_outside_the_support_and_never_nan(meas):
    lik = Likelihood(MODEL, meas)
    z = lik.params.to_z(np.r_[TRUTH, 0.002, 1e-6])
    bad = np.array([z, z + 1e3, np.full_like(z, np.nan), np.where(np.arange(z.size) == 1, np.inf, z)])
    post, ll = lik.log_prob_z(bad)
    assert np.isfinite(post[0]) and np.all(post[1:] == -np.inf) and not np.any(np.isnan(ll))
    # inside the prior support but where the model degenerates (omega0 at its bound, tiny R0)
    lo, hi = lik.params.bounds_z()
    edge = np.clip(z.copy(), lo, hi)
    edge[: MODEL.ndim] = hi[: MODEL.ndim]
    assert not np.isnan(lik.log_posterior_z(edge[None])).any()


def test_emcee_vectorised_blob_contract(meas):
    # STACK.md: with vectorize=True emcee needs one (lp, blob) pair per walker; returning
    # (lp_array, blob_array) fails. Check both, and that our blob is the total log-likelihood.
    lik = Likelihood(MODEL, meas)
    rng = np.random.default_rng(0)
    z0 = lik.params.to_z(np.r_[TRUTH, 0.002, 1e-6]) + 1e-4 * rng.standard_normal((16, lik.ndim))
    s = emcee.EnsembleSampler(16, lik.ndim, lik.emcee_log_prob, vectorize=True)
    s.run_mcmc(z0, 5)
    blobs = s.get_blobs()
    assert blobs.shape == (5, 16)
    np.testing.assert_allclose(blobs, lik(lik.params.from_z(s.get_chain())), rtol=1e-12)
    np.testing.assert_allclose(s.get_log_prob() - blobs, lik.params.log_prior_z(s.get_chain()), rtol=1e-9)

    def arrays(z):
        return lik.log_prob_z(z)

    with pytest.raises(ValueError, match="incompatible input dimensions"):
        emcee.EnsembleSampler(16, lik.ndim, arrays, vectorize=True).run_mcmc(z0, 1)


def test_noise_priors_are_identical_across_models():
    assert NOISE_PARAMS.names == ("sigma_rel", "sigma_abs")
    assert NOISE_PARAMS["sigma_abs"].unit == "S" and NOISE_PARAMS["sigma_rel"].unit == "1"
    m = simulate(MODEL, TRUTH, OMEGA[:10])
    tails = {name: Likelihood(build_model(name), m).params[-2:] for name in ("I", "UD", "NL")}
    assert tails["I"] == tails["UD"] == tails["NL"]
    with pytest.raises(ValueError, match="noise parameters must be"):
        Likelihood(MODEL, m, "student", None, NOISE_PARAMS)


# ---- prior files ------------------------------------------------------------------------------


def test_prior_file_overrides_model_and_noise_priors(tmp_path):
    good = tmp_path / "p.toml"
    good.write_text('[R0]\ndist = "lognormal"\nmedian = 2.6\nsigma_log = 0.05\n\n'
                    '[sigma_rel]\ndist = "loguniform"\nlower = 1e-4\nupper = 1e-2\n')
    model, noise = apply_prior_file(MODEL, good)
    assert model.params["R0"].prior.median == 2.6 and noise["sigma_rel"].prior.upper == 1e-2
    assert model.params["L0"] == MODEL.params["L0"] and noise["sigma_abs"] == NOISE_PARAMS["sigma_abs"]
    js = tmp_path / "p.json"
    js.write_text(json.dumps({"omega0": {"dist": "uniform", "lower": 40, "upper": 60}}))
    model, _ = apply_prior_file(MODEL, js)
    assert model.params["omega0"].prior.lower == 40.0
    assert read_prior_file(js) == {"omega0": {"dist": "uniform", "lower": 40, "upper": 60}}
    _, noise = apply_priors(MODEL, {"nu": {"dist": "uniform", "lower": 2, "upper": 50}},
                            noise_params=noise_param_set("student", None))
    assert noise["nu"].prior.upper == 50.0


@pytest.mark.parametrize("name,text,message", [
    ("a.toml", '[Rzero]\ndist = "uniform"\nlower = 1\nupper = 2\n',
     r"a.toml: unknown parameter\(s\) \['Rzero'\]"),
    ("b.json", '{"R0": {"dist": "gamma"}}', "b.json: R0: unknown prior dist 'gamma'"),
    ("c.toml", '[L0]\ndist = "loguniform"\nlower = 1e-3\nupper = 1e-5\n', "c.toml: L0: LogUniform needs"),
    ("d.toml", '[L0]\ndist = "loguniform"\nlow = 1e-6\nupper = 1e-2\n', "d.toml: L0: bad fields"),
    ("e.json", '{"R0": [1, 2]}', "e.json: R0: expected a table"),
    ("f.json", '{"R0": {"dist": "normal", "mu": 2.6', r"f.json: line 1: invalid JSON"),
    ("g.toml", "[R0\n", "g.toml: invalid TOML"),
    ("h.toml", '[nu]\ndist = "uniform"\nlower = 1\nupper = 9\n', "h.toml: unknown parameter.*--nu sample"),
    ("i.toml", '[R0]\ndist = "normal"\nmu = "abc"\nsigma = 1\n', "i.toml: R0: could not convert"),
])
def test_prior_file_errors_name_the_file_and_the_parameter(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(DataFormatError, match=message):
        apply_prior_file(MODEL, path)


def test_missing_prior_file(tmp_path):
    with pytest.raises(DataFormatError, match="no such prior file"):
        apply_prior_file(MODEL, tmp_path / "nope.toml")


@pytest.mark.parametrize("kind,nu", [("gaussian", 4.0), ("student", 5.0)])
def test_replicated_data_carry_the_likelihoods_noise(meas, kind, nu):
    # predictive replicas at one parameter set: (Y_rep - Y_model)/sigma has, per part, the
    # likelihood's distribution: standard normal, or Student-t with variance nu/(nu - 2) = 5/3.
    # 4000 replicas x 2 parts x F points: the sample variance is within 3 % of it
    lik = Likelihood(MODEL, meas, kind, nu)
    theta = np.concatenate([TRUTH, [0.002, 1e-6]])
    Ym, Yr = lik.predictive(np.broadcast_to(theta, (4000, theta.size)), np.random.default_rng(1))
    np.testing.assert_allclose(Ym, np.broadcast_to(MODEL.admittance(meas.omega, theta[:-2]), Ym.shape))
    z = (Yr - Ym) / lik.sigma(0.002, 1e-6)
    var = np.var(np.concatenate([z.real.ravel(), z.imag.ravel()]))
    assert abs(var / (1.0 if kind == "gaussian" else nu / (nu - 2)) - 1) < 0.03
    a, b = (lik.predictive(theta[None], np.random.default_rng(7))[1] for _ in range(2))
    np.testing.assert_array_equal(a, b)  # seeded
