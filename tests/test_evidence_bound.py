"""The evidence lower bound (bayes_emt.evidence.bound) and its use as a check on the estimators.

Known answers: a normalised density times exp(c) has log Z = c exactly (a correlated Gaussian, and
a half-normal truncated at the support's edge); Jensen's inequality makes the bound at most log Z
for any q, so the estimate may exceed c only by its own noise (3 standard errors here).
"""

import math

import numpy as np
import pytest
from scipy import stats

from bayes_emt.evidence.bound import below_bound, evidence_lower_bound
from bayes_emt.evidence.records import combine_methods

C = 123.4  # log Z of every target below [nats]


def _gaussian(k, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(k, k))
    cov = A @ A.T + 0.5 * np.eye(k)
    mu = rng.normal(size=k)
    dist = stats.multivariate_normal(mu, cov)
    return (lambda z: dist.logpdf(z) + C), dist.rvs(size=4000, random_state=rng)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_bound_is_tight_when_q_is_the_posterior(seed):
    logp, draws = _gaussian(6, seed)
    b = evidence_lower_bound(logp, draws, seed=seed)
    assert b.inside == 1.0
    assert b.log_evidence <= C + 3 * b.err
    # q fitted to 4000 exact draws: the KL gap is about k(k+3)/(4 N) ~ 0.007 nats
    assert b.log_evidence == pytest.approx(C, abs=0.05)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_bound_holds_on_a_truncated_skewed_posterior(seed):
    # half-normal on z > 0 in two coordinates (the prior's support ends at 0): q, a Gaussian, is
    # truncated and renormalised by its fraction inside
    def logp(z):
        z = np.atleast_2d(z)
        out = np.sum(stats.halfnorm.logpdf(z, scale=[1.0, 0.3]), axis=1) + C
        return np.where(np.all(z > 0, axis=1), out, -np.inf)

    rng = np.random.default_rng(seed)
    draws = np.abs(rng.normal(size=(4000, 2))) * [1.0, 0.3]
    b = evidence_lower_bound(logp, draws, seed=seed)
    assert 0.1 < b.inside < 1.0
    assert b.log_evidence <= C + 3 * b.err
    assert b.log_evidence > C - 1.0  # a loose bound, but a bound near the answer


def test_bound_refuses_draws_it_cannot_use():
    logp = lambda z: np.where(np.atleast_2d(z)[:, 0] > 10.0, 0.0, -np.inf)  # noqa: E731
    draws = np.random.default_rng(0).normal(size=(500, 3))
    assert evidence_lower_bound(logp, draws) is None  # almost no q draw inside the support
    flat = np.ones((100, 2))
    assert evidence_lower_bound(lambda z: np.zeros(len(z)), flat) is None  # singular covariance


def test_an_estimate_far_below_the_bound_is_refused_and_left_out():
    logp, draws = _gaussian(4, 5)
    b = evidence_lower_bound(logp, draws, seed=5)
    assert below_bound(C, 0.3, b) is None
    assert below_bound(C - 0.5, 0.01, b) is None  # less than 1 nat: never refused
    sig = below_bound(C - 50.0, 1.0, b)
    assert sig is not None and sig > 40
    by_method = {"nested": {"log_evidence": C - 50.0, "err": 1.0, "excluded": "below the bound"},
                 "bridge": {"log_evidence": C, "err": 0.1}}
    assert combine_methods(by_method) == pytest.approx((C, 0.1))
    del by_method["nested"]["excluded"]
    lz, err = combine_methods(by_method)
    assert lz < C and err == pytest.approx(25.0)  # half the estimators' difference
    assert math.isfinite(lz)


def test_bound_when_most_of_q_falls_outside_the_support():
    # 15 exponential coordinates piled against their prior bound at 0 (spare-ring parameters of an
    # over-sized NL model look like this): most of the fitted Gaussian falls outside, and q is
    # drawn until enough land inside. log Z = C + 15 log s exactly
    s, k = 0.01, 15

    def logp(z):
        z = np.atleast_2d(z)
        return np.where(np.all(z > 0, axis=1), C - np.sum(z, axis=1) / s, -np.inf)

    draws = np.random.default_rng(4).exponential(s, size=(4000, k))
    b = evidence_lower_bound(logp, draws, seed=4)
    truth = C + k * math.log(s)
    assert b is not None and b.inside < 0.1
    assert b.log_evidence <= truth + 3 * b.err
    assert b.log_evidence > truth - 10.0


def test_comparison_leaves_out_an_estimate_below_the_bound_and_says_why():
    # the step of bayes_emt.evidence.compare that checks the sampled estimates, on a known answer
    # (the 6-D log-normal under uniform priors, exact posterior draws): a nested estimate 40 nats
    # low is excluded with a warning, a right one is kept
    from evidence_problems import LogNormalUnderUniform

    from bayes_emt.evidence.compare import _check_against_bound

    p = LogNormalUnderUniform(6)
    draws = p.posterior_draws(np.random.default_rng(2), 4000)
    by_method = {"nested": {"log_evidence": p.truth - 40.0, "err": 0.4},
                 "bridge": {"log_evidence": p.truth, "err": 0.05}}
    bound, notes = _check_against_bound(by_method, p.log_posterior_z, p.params.to_z(draws), seed=2)
    assert bound["log_evidence"] <= p.truth + 3 * bound["err"]
    assert "excluded" in by_method["nested"] and "excluded" not in by_method["bridge"]
    assert len(notes) == 1 and notes[0].startswith("nested log Z") and "left out" in notes[0]
    assert combine_methods(by_method)[0] == pytest.approx(p.truth)
