"""Evidence building blocks: the batching pool, nested-run seeding, checkpoints and files, the
logit warp, prior widening, the Bayes-factor scale and the comparison record's JSON schema."""

import json
import math
import pickle

import numpy as np
import pytest
from evidence_problems import GaussianInBox, LinearGaussian, LogNormalUnderUniform

from bayes_emt.evidence.batching import BatchingPool, Relay, register, unregister
from bayes_emt.evidence.nested import NestedSettings, read_nested, run_nested
from bayes_emt.evidence.records import Comparison, ModelEvidence, combine_methods
from bayes_emt.evidence.rings import parse_rings, rings_by_evidence
from bayes_emt.evidence.scale import bayes_factor, verbal
from bayes_emt.evidence.sensitivity import widen_prior, widened_log_evidence
from bayes_emt.evidence.warp import Warp
from bayes_emt.params import LogNormal, LogUniform, Normal, ParamSet, ParamSpec, Uniform


# ---- batching pool ---------------------------------------------------------------------------
def test_pool_runs_jobs_in_lockstep_and_batches_their_likelihood_calls():
    seen = []

    def batch(x):
        seen.append(x.shape[0])
        return -np.sum(x**2, axis=1)

    pool = BatchingPool(batch, lambda u: u, size=8)

    def job(x):  # three dependent calls per job, as a random walk makes
        a = pool.loglike(np.array([x, 0.0]))
        b = pool.loglike(np.array([x, 1.0]))
        return a + b + pool.loglike(np.array([a, b]))

    out = pool.map(job, [float(i) for i in range(8)])
    expected = [(-i * i) + (-i * i - 1) - ((i * i) ** 2 + (i * i + 1) ** 2) for i in range(8)]
    assert np.allclose(out, expected)
    assert seen == [8, 8, 8]  # one vectorised call per step of all eight jobs
    assert pool.n_calls == 24 and pool.n_batches == 3


def test_pool_reraises_a_job_error_in_the_caller():
    pool = BatchingPool(lambda x: -np.sum(x**2, axis=1), lambda u: u, size=4)

    def job(x):
        if x == 2:
            raise ValueError("job 2 failed")
        return pool.loglike(np.array([x]))

    with pytest.raises(ValueError, match="job 2 failed"):
        pool.map(job, [0.0, 1.0, 2.0, 3.0])


def test_relay_pickles_by_name_and_needs_its_pool():
    pool = BatchingPool(lambda x: -np.sum(x**2, axis=1), lambda u: 2 * u, size=2)
    register("test-relay", pool)
    try:
        r = pickle.loads(pickle.dumps(Relay("test-relay", "prior_transform")))
        assert np.allclose(r(np.array([0.25])), [0.5])
    finally:
        unregister("test-relay")
    with pytest.raises(RuntimeError, match="no batching pool"):
        r(np.array([0.25]))


# ---- nested runs -----------------------------------------------------------------------------
def test_nested_run_is_reproducible_with_its_seed_and_saves_round_trip(tmp_path):
    p = GaussianInBox(2)
    s = NestedSettings(n_live=40, walks=20, queue_size=4)
    a, b = run_nested(p, seed=11, settings=s), run_nested(p, seed=11, settings=s)
    assert a.log_z == b.log_z and a.n_calls == b.n_calls
    c = run_nested(p, seed=12, settings=s)
    assert c.log_z != a.log_z
    path = a.save(tmp_path / "run.nc")
    back = read_nested(path)
    assert back.log_z == a.log_z and back.names == ("x0", "x1")
    np.testing.assert_allclose(back.samples, a.samples)
    assert json.loads((tmp_path / "run.json").read_text())["log_evidence"] == a.log_z
    assert np.isclose(a.weights().sum(), 1.0)


def test_nested_checkpoint_resumes_and_refuses_another_run(tmp_path):
    p = LinearGaussian(2, n_obs=10)
    ck = tmp_path / "ck.dynesty"
    s = NestedSettings(n_live=40, walks=20, queue_size=4, checkpoint_every=0.0)
    first = run_nested(p, seed=3, settings=s, checkpoint=ck)
    assert ck.exists() and (tmp_path / "ck.dynesty.json").exists()
    again = run_nested(p, seed=3, settings=s, checkpoint=ck, resume=True)  # a finished run: same answer
    assert again.log_z == pytest.approx(first.log_z, abs=1e-9)
    with pytest.raises(ValueError, match="cannot resume"):
        run_nested(p, seed=4, settings=s, checkpoint=ck, resume=True)


def test_nested_settings_reject_bad_values():
    with pytest.raises(ValueError, match="unknown nested sampling method"):
        NestedSettings(sample="hmc")
    with pytest.raises(ValueError, match="n_live"):
        NestedSettings(n_live=1)


# ---- warp ------------------------------------------------------------------------------------
def test_warp_round_trips_and_its_jacobian_is_the_derivative():
    params = ParamSet([ParamSpec("a", "1", "a", LogUniform(1e-3, 1e3)),
                       ParamSpec("b", "1", "b", Normal(0, 1))])
    w = Warp.of(params)
    assert list(w.bounded) == [True, False]
    z = np.array([[0.5, -2.0], [-6.0, 3.0]])
    xi = w.to_xi(z)
    np.testing.assert_allclose(w.from_xi(xi), z, rtol=1e-12)
    h = 1e-6
    num = (w.from_xi(xi + [h, 0])[:, 0] - w.from_xi(xi - [h, 0])[:, 0]) / (2 * h)
    np.testing.assert_allclose(np.exp(w.log_jacobian(xi)), num, rtol=1e-6)


# ---- prior sensitivity -------------------------------------------------------------------------
def test_widen_prior_doubles_the_sampling_space_width_of_each_type():
    lu = widen_prior(LogUniform(1e-2, 1e2))
    assert math.log(lu.upper / lu.lower) == pytest.approx(2 * math.log(1e4))
    assert math.sqrt(lu.lower * lu.upper) == pytest.approx(1.0)
    u = widen_prior(Uniform(1.0, 3.0))
    assert (u.lower, u.upper) == (0.0, 4.0)
    assert widen_prior(Normal(1.0, 0.5)).sigma == 1.0
    assert widen_prior(LogNormal(2.0, 0.1)).sigma_log == pytest.approx(0.2)


def test_widened_evidence_of_a_box_prior_loses_log2_per_axis():
    """A posterior far inside uniform priors: doubling each width halves each prior density, so
    log Z drops by exactly k log 2 (Z = Π 1/w_i for the Gaussian in a box)."""
    p = GaussianInBox(3)
    draws = p.posterior_draws(np.random.default_rng(0), 3000)
    lz2, notes = widened_log_evidence(p.truth, p.params, p.params.to_z(draws))
    assert lz2 == pytest.approx(p.truth - 3 * math.log(2), abs=1e-9)
    assert notes == []


def test_widened_evidence_of_a_posterior_flat_against_a_bound_adds_the_extension():
    """Likelihood flat on z in [0, 1] (posterior uniform there) under a U(0, 4) prior: Z = 1/4.
    Doubled prior U(-2, 6): Z' = 3/8 if the likelihood stays flat below 0 (the stated
    assumption), up to the density estimate's noise."""
    params = ParamSet([ParamSpec("s", "1", "s", Uniform(0.0, 4.0))])
    draws = np.random.default_rng(1).uniform(0, 1, (20000, 1))
    lz2, notes = widened_log_evidence(math.log(0.25), params, draws)
    assert lz2 == pytest.approx(math.log(3 / 8), abs=0.05)
    assert any("reaches its lower prior bound" in n for n in notes)


# ---- scale and records -----------------------------------------------------------------------------
def test_verbal_scale_follows_kass_raftery_on_ln_b():
    assert [verbal(x) for x in (0.5, -0.99, 1.5, -3.5, 6.0)] == \
        ["inconclusive", "inconclusive", "positive", "strong", "very strong"]
    assert verbal(2.0, err=1.5) == "inconclusive"  # within two standard errors of zero
    bf = bayes_factor({"name": "A", "log_evidence": 10.0, "log_evidence_err": 0.3},
                      {"name": "B", "log_evidence": 6.0, "log_evidence_err": 0.4})
    assert bf["log_bayes_factor"] == 4.0 and bf["err"] == pytest.approx(0.5)
    assert bf["verdict"] == "strong" and bf["favours"] == "A"


def test_combined_evidence_weights_the_estimators_and_widens_on_disagreement():
    lz, err = combine_methods({"nested": {"log_evidence": 10.0, "err": 1.0},
                               "bridge": {"log_evidence": 10.2, "err": 0.1, "spread": 0.05},
                               "laplace": {"log_evidence": 50.0, "err": None}})
    assert 10.19 < lz < 10.2 and err == pytest.approx(0.1)
    lz, err = combine_methods({"nested": {"log_evidence": 7.0, "err": 0.5},
                               "bridge": {"log_evidence": 10.0, "err": 0.1}})
    assert err == pytest.approx(1.5)  # half the disagreement


def _record(name, lz, rings=None, widened=None):
    return ModelEvidence(name, name, rings, 9, {"bridge": {"log_evidence": lz, "err": 0.05}}, lz, 0.05,
                         elpd_loo=100.0, elpd_loo_se=3.0, widened={"log_evidence": widened or lz - 1},
                         key=name)


def test_comparison_json_has_the_issue_schema():
    cmp = Comparison((_record("UD", 100.0, widened=97.0), _record("NL", 103.0, 5, widened=99.5),
                      _record("II", 60.0)))
    d = cmp.to_json_dict()
    json.dumps(d)  # serialisable
    assert set(d) >= {"models", "best", "bayes_factors", "warnings"}
    for m in d["models"]:
        assert set(m) >= {"name", "rings", "log_evidence", "log_evidence_err", "by_method", "elpd_loo",
                          "elpd_loo_se"}
        assert set(m["by_method"]["bridge"]) >= {"log_evidence", "err"}
    assert d["best"] == "NL"
    assert d["bayes_factors"] == {"UD/NL": -3.0, "UD/II": 40.0, "NL/II": 43.0}
    # with widths doubled UD/NL becomes -2.5 (still favours NL): survives
    assert d["prior_sensitivity"]["survives"]["UD/NL"] is True
    back = ModelEvidence.from_json_dict(d["models"][1])
    assert back.log_evidence == 103.0 and back.rings == 5


def test_rings_by_evidence_prefers_the_fewest_rings_within_one_nat():
    ms = [_record(f"NL({n})", lz, n) for n, lz in ((1, 10.0), (2, 30.0), (3, 35.0), (4, 35.6), (5, 34.0))]
    r = rings_by_evidence(ms)
    assert r["argmax"] == 4 and r["by_evidence"] == 3
    assert parse_rings("1-3,5") == (1, 2, 3, 5)
    with pytest.raises(ValueError, match="--rings"):
        parse_rings("3-1")


def test_bridge_proposal_survives_parameters_on_scales_decades_apart():
    """The demo's NL(5) posterior (a noise floor spread over decades beside 1e-12-scale ring
    parameters) gave a covariance scipy refused as not positive definite (condition ≈ 1e11). The
    proposal is fitted in standardised coordinates: on well-scaled draws it is the plain
    multivariate normal (to round-off), and rescaling the draws by 1e-6 and 1e4 only shifts its
    log density by the log-Jacobian (to 1e-8)."""
    from scipy import stats

    from bayes_emt.evidence.bridge import _Proposal

    rng = np.random.default_rng(3)
    cov = np.array([[1.0, 0.95], [0.95, 1.0]])
    draws = rng.multivariate_normal([0.0, 0.0], cov, size=3000) * [2.0, 3.0] + [3.0, 5.0]
    x = draws[:7]
    direct = stats.multivariate_normal(draws.mean(0), np.cov(draws, rowvar=False)).logpdf(x)
    assert np.allclose(_Proposal(draws, "normal").logpdf(x), direct, rtol=0, atol=1e-10)
    scale = np.array([1e-6, 1e4])
    for kind in ("normal", "t"):
        base, wide = _Proposal(draws, kind), _Proposal(draws * scale, kind)
        shift = np.sum(np.log(scale))
        assert np.allclose(wide.logpdf(x * scale), base.logpdf(x) - shift, rtol=0, atol=1e-8)
        assert np.all(np.isfinite(wide.logpdf(wide.sample(50, rng))))


def test_batched_slice_draws_uniformly_from_the_constrained_region():
    # dynesty hands each queued job a live point inside {log L > L*}; a correct slice kernel leaves
    # the uniform distribution on that region invariant. Region: the disc of radius 0.3 about the
    # cube's centre; 4000 jobs start at uniform draws from it, and after one slice round (a step
    # along each axis) the fraction within radius 0.15 must still be 1/4 and the mean the centre
    # (binomial and sample-mean standard errors, 4 sigma)
    from types import SimpleNamespace

    from bayes_emt.evidence.batching import batched_slice

    n_jobs, r = 4000, 0.3
    rng = np.random.default_rng(3)
    ang, rad = rng.uniform(0, 2 * np.pi, n_jobs), r * np.sqrt(rng.uniform(size=n_jobs))
    starts = 0.5 + np.c_[rad * np.cos(ang), rad * np.sin(ang)]
    calls = []

    def evaluate(v):
        calls.append(len(v))
        return -np.sum((v - 0.5) ** 2, axis=1)

    args = [SimpleNamespace(u=u0, loglstar=-r**2, axes=np.eye(2) * 0.2, scale=1.0, rseed=11,
                            kwargs={"slices": 1}) for u0 in starts]
    out = batched_slice(args, lambda u: u, evaluate)
    pts = np.array([o.u for o in out])
    d = np.linalg.norm(pts - 0.5, axis=1)
    assert np.all(d < r)
    assert np.all([o.logl > -r**2 for o in out])
    assert np.all(np.any(pts != starts, axis=1))  # every job moved
    frac = np.mean(d < r / 2)
    assert abs(frac - 0.25) < 4 * np.sqrt(0.25 * 0.75 / n_jobs)
    assert np.all(np.abs(pts.mean(axis=0) - 0.5) < 4 * (r / 2) / np.sqrt(n_jobs))  # sd of a coordinate: r/2
    # every point's calls are counted, and they were evaluated in a few batched calls
    n_calls = sum(o.ncalls for o in out)
    assert sum(calls) <= n_calls and len(calls) < 0.01 * n_calls


@pytest.mark.parametrize("seed", [1, 2])
def test_nested_with_the_batched_slice_sampler_recovers_a_known_evidence(seed):
    p = LogNormalUnderUniform(3)
    run = run_nested(p, seed=seed, settings=NestedSettings(sample="slice"))
    assert run.converged
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)
    assert run.n_batches < run.n_evaluations / 4  # batched calls (a queue of 16)
