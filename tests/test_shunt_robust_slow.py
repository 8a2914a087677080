"""Issue 12 acceptance points 2 and 3 on real emcee posteriors (slow: they sample NL posteriors;
``scripts/robust_shunt_study.py`` prints the same and more, stored in
``scripts/results/robust_shunt_study.txt``).

Acceptance 3 uses the ring count the 2 % noise data support (Hankel singular values: 4 rings); its
posterior converges in about 1000 steps. NL(5) on the same data does not converge in 40000 steps
(the last test): its fifth ring is below the noise floor, so the data do not determine it."""

import pytest

from bayes_emt import build_model, simulate
from bayes_emt.estimation.hankel import select_rings
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


NOISY_SEED = 20261124  # the study's 2 % noise recording


@pytest.fixture(scope="module")
def noisy_data():
    return simulate(build_model("NL"), PAPER_TABLES["NL"], noise=0.02, seed=NOISY_SEED)


def test_acceptance_3_two_percent_noise_moves_robust_rs_up_and_says_why(noisy_data):
    # issue 12, acceptance 3: with 2 % noise the robust Rs moves to the less negative side of the
    # nominal Rs, and the report says why (the stability boundary). Measured with
    # scripts/robust_shunt_study.py (scripts/results/robust_shunt_study.txt) on this recording and 4
    # more, 5 splits each: the robust Rs is +0.95 .. +1.97 mOhm above the nominal in all 25 splits, and
    # missing a draw's own optimum by the draws' 90 % half-spread (~4 mOhm) costs more towards the
    # boundary than away from it in all 25. The report's boundary test (the nominal's worst 10 % of
    # the design half, 50 draws, enriched in boundary-side draws by more than two binomial standard
    # errors) has finite power: it held in 24 of the 25 splits, so 3 of 5 is asked here and the
    # words are checked wherever it holds.
    choice = select_rings(noisy_data)
    assert choice.rings < 5  # the fifth ring is not resolved at 2 % noise
    post = sample_posterior(noisy_data, build_model("NL", rings=choice.rings), seed=1, progress=False)
    assert post.converged, post.message
    explained = 0
    for split in range(5):
        why = robust_on(post, seed=split).to_json_dict()["why"]
        assert why["delta_Rs_ohm"] > 0 and why["side"] == "less negative", why["text"]
        st = why["steepness"]
        assert st["loss_down_db"] > st["loss_up_db"] > 0, st
        if why["boundary_explains"]:
            explained += 1
            assert "stability boundary" in why["text"]
            assert "moves Rs up, away from the boundary" in why["text"]
    assert explained >= 3, explained


@pytest.fixture(scope="module")
def noisy_posterior(noisy_data):
    # the study's budget (scripts/robust_shunt_study.py): 40000 steps, ~6 min here
    return sample_posterior(noisy_data, build_model("NL"), seed=1, progress=False, max_steps=40_000)


@pytest.mark.xfail(strict=True, reason=(
    "known sampler limitation (issue 14's sampler): the 2 % noise NL(5) posterior mixes slowly in its "
    "ring parameters (tau_max ~ 400 steps); measured: 40000 steps end at 36 tau of the 50 the stopping "
    "rule asks, and 100000 steps did not finish within 20 min here. Its fifth ring is below the noise "
    "floor (Hankel singular values choose 4 rings, whose posterior converges in ~1000 steps). Strict: a "
    "sampler that converges here makes this test fail, to be turned into an assert."))
def test_the_two_percent_noise_posterior_converges(noisy_posterior):
    assert noisy_posterior.converged, noisy_posterior.message
