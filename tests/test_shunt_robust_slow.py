"""Issue 12 acceptance points 2 and 3 on real emcee posteriors (slow: each samples an NL(5)
posterior, ≈ 3-5 min on 2 quiet cores; ``scripts/robust_shunt_study.py`` prints the same and more)."""

import numpy as np
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
    "here. Acceptance 3 below is therefore checked on the draws of an unconverged chain, as the study "
    "reports. Strict: a sampler that converges here makes this test fail, to be turned into an assert."))
def test_the_two_percent_noise_posterior_converges(noisy_posterior):
    assert noisy_posterior.converged, noisy_posterior.message


def test_acceptance_3_two_percent_noise_moves_rs_up_because_of_the_boundary(noisy_posterior):
    # issue 12, acceptance 3: with 2 % noise the robust Rs lies on the less negative side of the
    # nominal Rs and the report names the stability boundary as the reason
    res = robust_on(noisy_posterior)
    why = res.to_json_dict()["why"]
    assert res.robust.Rs > res.nominal.Rs and why["side"] == "less negative"
    assert why["boundary_explains"] and "stability boundary" in why["text"]
    assert np.min(res.robust.margin[~res.held]) > np.min(res.nominal.margin[~res.held])
