"""Issue 12 acceptance point 2 on a real emcee posterior, and the convergence of the 2 % noise
posterior acceptance point 3 needs (slow: each samples an NL(5) posterior, ≈ 3-6 min on 2 quiet
cores; ``scripts/robust_shunt_study.py`` prints the same and more).

Acceptance 3 (the robust Rs moves to the less negative side with 2 % noise) is not asserted here:
the stored study shows it (+0.83 mOhm), but a test run of the same 40000-step, unconverged posterior
in a fresh clone put the robust Rs on the other side. The shift is small against the draws' own
spread (+-3.6 mOhm) and follows an unconverged chain; it is an open point of issue 12, not a
property this code guarantees."""

import pytest

from bayes_emt import build_model, simulate
from bayes_emt.inference.sampling import sample_posterior
from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.shunt.draws import sample_mixture
from bayes_emt.shunt.robust import design_robust_shunt

pytestmark = pytest.mark.slow


def robust_on(post, seed=0):
    groups, _ = sample_mixture([(post.model, post.theta(), "posterior")], [1.0], 1000, seed=seed)
    return design_robust_shunt(groups, seed=seed)


def test_acceptance_2_bundled_nl_posterior():
    # issue 12, acceptance 2: on the held-back draws the robust shunt's worst 5 % attenuation (q95)
    # is better than the nominal's, its P(unstable) <= 1e-3, with the Clopper-Pearson interval
    post = sample_posterior(load_paper_bench(), build_model("NL"), seed=1, progress=False)
    assert post.converged
    rep = robust_on(post).to_json_dict()
    assert rep["robust"]["attenuation_db"]["q95"] < rep["nominal"]["attenuation_db"]["q95"]
    assert rep["robust"]["p_unstable"] <= 1e-3
    lo, hi = rep["robust"]["p_unstable_ci"]
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 500), rel=1e-9)  # 0 of 500, 95 %


@pytest.fixture(scope="module")
def noisy_posterior():
    # the study's budget (scripts/robust_shunt_study.py): 40000 steps, ~6 min here
    meas = simulate(build_model("NL"), PAPER_TABLES["NL"], noise=0.02, seed=20261124)
    return sample_posterior(meas, build_model("NL"), seed=1, progress=False, max_steps=40_000)


@pytest.mark.xfail(strict=True, reason=(
    "known sampler limitation (issue 14's sampler): the 2 % noise NL(5) posterior mixes slowly in its "
    "ring parameters (tau_max ~ 400 steps); measured: 40000 steps end at 36 tau of the 50 the stopping "
    "rule asks (scripts/results/robust_shunt_study.txt), and 100000 steps did not finish within 20 min "
    "here. Strict: a sampler that converges here makes this test fail, to be turned into an assert."))
def test_the_two_percent_noise_posterior_converges(noisy_posterior):
    assert noisy_posterior.converged, noisy_posterior.message
