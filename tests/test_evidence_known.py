"""Known-answer evidence problems (issue 11, acceptance 1): nested and bridge sampling each within
3 of their own reported standard errors of the analytic log Z. (Nested sampling here runs from
the prior; the repartitioned run ``compare`` uses by default: tests/test_evidence_repartition.py.)

Analytic values (tests/evidence_problems.py):
* correlated Gaussian in a box: log Z = −Σ log w_i (the normalised Gaussian integrates to 1);
* linear-Gaussian regression with Normal priors: y ~ N(0, σ²I + τ²AAᵀ) (Bishop 2006, eq. 3.86);
* log-normal likelihood under uniform priors on (0, b): log Z = Σ [log Φ((log b − μ)/s) − log b].

Tolerance: |estimate − truth| < 3 × the estimator's reported error (dynesty's logzerr; bridge's
Frühwirth-Schnatter relative MSE), with a floor of 0.02 nat on the bridge error for exact
Gaussian targets, where the proposal is the posterior and the formula error goes to zero. Fast
low-dimensional cases run by default; 15-D ones (with emcee draws for bridge) are ``slow``.
"""

import numpy as np
import pytest
from evidence_problems import GaussianInBox, LinearGaussian, LogNormalUnderUniform, chains_of

from bayes_emt.evidence.bridge import bridge_evidence
from bayes_emt.evidence.laplace import laplace_evidence
from bayes_emt.evidence.nested import NestedSettings, run_nested

PROBLEMS = [GaussianInBox, LinearGaussian, LogNormalUnderUniform]
FLOOR = 0.02  # nats, see module docstring


def _bridge_exact(p, seed=2):
    dz = p.params.to_z(p.posterior_draws(np.random.default_rng(seed), 4000))
    return bridge_evidence(p.log_posterior_z, p.params, chains_of(dz), seed=seed)


@pytest.mark.parametrize("problem", PROBLEMS, ids=lambda c: c.__name__)
def test_bridge_recovers_the_analytic_evidence_low_dim(problem):
    p = problem(4)
    br = _bridge_exact(p)
    assert abs(br.log_z - p.truth) < 3 * max(br.err, FLOOR), (br.log_z, br.err, p.truth)
    # the reported error is an error, not zero, and the repeats agree with it
    assert 0 < br.err < 0.1
    assert br.spread < 5 * br.err + FLOOR


@pytest.mark.parametrize("problem", PROBLEMS, ids=lambda c: c.__name__)
def test_nested_recovers_the_analytic_evidence_low_dim(problem):
    p = problem(3)
    run = run_nested(p, seed=5, settings=NestedSettings(n_live=100, walks=25))
    assert run.converged
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)
    assert run.n_evaluations > 0 and run.n_batches < run.n_evaluations  # batched calls


def test_laplace_is_exact_for_a_gaussian_posterior_and_off_for_a_skewed_one():
    g = LinearGaussian(5)
    dz = g.posterior_draws(np.random.default_rng(0), 2000)
    lap = laplace_evidence(g.log_posterior_z, g.params, dz.mean(0), np.cov(dz, rowvar=False))
    assert lap.ok and abs(lap.log_z - g.truth) < 1e-3
    s = LogNormalUnderUniform(5)
    dz = s.posterior_draws(np.random.default_rng(0), 2000)
    lap = laplace_evidence(s.log_posterior_z, s.params, dz.mean(0), np.cov(dz, rowvar=False))
    assert lap.ok and 0.01 < abs(lap.log_z - s.truth) < 1.0  # a screen: close, not exact


def _emcee_draws(p, seed, steps=6000):
    """(chains, draws, k) sampling-space draws and log densities from the package's emcee driver."""
    from bayes_emt.inference.posterior import Posterior
    from bayes_emt.inference.sampling import SamplerSettings, run_ensemble

    p.identity = lambda: {"problem": p.label, "ndim": p.ndim}
    rng = np.random.default_rng(seed)
    run = run_ensemble(p, lambda n: p.params.to_z(p.posterior_draws(rng, n)), seed=seed, max_steps=steps,
                       settings=SamplerSettings(max_steps=steps, ess_target=2000, max_draws=6000))
    chain = run["chain"]
    tau, burn = run["tau"], run["burn"]
    thin = max(1, int(np.min(tau) // 2))
    sl = slice(burn, None, thin)
    return (np.swapaxes(chain[sl], 0, 1), np.swapaxes(run["log_prob"][sl], 0, 1),
            max(1.0, float(np.max(tau)) / thin), Posterior)


@pytest.mark.slow
@pytest.mark.parametrize("problem", PROBLEMS, ids=lambda c: c.__name__)
def test_bridge_on_emcee_draws_recovers_the_evidence_15d(problem):
    p = problem(15)
    draws, lp, tau_floor, _ = _emcee_draws(p, seed=3)
    br = bridge_evidence(p.log_posterior_z, p.params, draws, seed=4, log_density_draws=lp,
                         tau_floor=tau_floor)
    assert abs(br.log_z - p.truth) < 3 * max(br.err, FLOOR), (br.log_z, br.err, p.truth)


# Nested sampling FROM THE PRIOR (``compare --nested-prior prior``; the default, repartitioned onto
# the emcee draws, passes all three: tests/test_evidence_repartition.py) with NestedSettings()
# (n_live 100, rwalk, walks 100, bound multi): the 15-D log-normal under uniform priors comes out
# low. Measured (truth -44.94 nats, (log Z - truth)/err): seeds 1, 2, 3, 4, 7 -> -7.2, -12.4, -0.6, -2.9, -6.0
# (log Z -49.9, -53.9, -45.3, -46.8, -49.2 +- 0.65-0.72), while the Gaussian in a box (-0.9..+1.7)
# and the linear-Gaussian (-0.4..+1.1) pass with the same settings and seeds. Comparing the dead
# points' log X with the exact X(L) (a 15-fold convolution) puts the error in the phase
# -50 < log L < -20 (log X -17 to -29), where the constrained region is most skewed in the unit
# cube (per-coordinate skewness 1.5-1.7, tails out to u ~ 0.5 against a bulk at u ~ 0.05): 100
# random-walk steps do not decorrelate a new point from its start there. More steps cure it
# (walks 200: -1.8, -1.5, -3.7, +1.1 (seeds 1, 2, 3, 7); walks 300: -0.9, -2.5, -0.7, +1.9, +0.4
# (seeds 1, 2, 3, 4, 7) at 3x the calls), but 3x the calls on the 17-parameter NL model (158 s,
# 2.2 M calls for its nested run on the bundled data) would break the 10-minute budget of
# acceptance 5; slice sampling also recovers it (dynesty's own: +0.5, +0.6, +0.5, +1.8, seeds 1, 2,
# 3, 7, at 2.3x the calls, 86 s against 6 s; batched here, NestedSettings(sample="slice"): -0.4,
# +0.8, -0.8, +2.3, +2.3 on seeds 1, 2, 3, 4, 7 at 2.2x the evaluations, 17 s against 6.7 s; the
# test below), but on the bundled NL(5) data its nested run takes 522 s against 158 s.
# Changes at the same cost do not:
# target acceptance 0.234 (2 of 4 seeds beyond 3 sigma) or 0.15 (1 of 8, mean -1.9), faster
# scale tuning (-6.9 to -10.6 on seeds 1, 2, 4, 7), bound single (-12 on seed 7); bound none is unbiased
# here (10 seeds, mean +0.2) but puts model I on the bundled data 160 and 1560 nats below the
# default runs, which agree within 2. Strict, so a fix shows up.
_LOGNORMAL_15D = pytest.param(LogNormalUnderUniform, marks=pytest.mark.xfail(
    strict=True, reason="with NestedSettings() (walks 100) dynesty's rwalk comes out 2-12 sigma low on "
                        "the 15-D log-normal under uniform priors; walks 300 recovers it at 3x the cost"))


@pytest.mark.slow
@pytest.mark.parametrize("problem", [GaussianInBox, LinearGaussian, _LOGNORMAL_15D],
                         ids=["GaussianInBox", "LinearGaussian", "LogNormalUnderUniform"])
def test_nested_recovers_the_evidence_15d(problem):
    """The package's own nested settings, run from the prior (``compare --nested-prior prior``)."""
    p = problem(15)
    run = run_nested(p, seed=7, settings=NestedSettings())
    assert run.converged
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)


@pytest.mark.slow
def test_nested_recovers_the_15d_lognormal_with_longer_walks():
    """The remedy the xfail above names (``--walks 300``, 3x the calls): measured within 3 errors for
    seeds 1, 2, 3, 4, 7 ((log Z - truth)/err = -0.9, -2.5, -0.7, +1.9, +0.4)."""
    p = LogNormalUnderUniform(15)
    run = run_nested(p, seed=7, settings=NestedSettings(walks=300))
    assert run.converged
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)


@pytest.mark.slow
@pytest.mark.parametrize("problem", PROBLEMS, ids=lambda c: c.__name__)
def test_nested_with_slice_sampling_recovers_the_evidence_15d(problem):
    """``NestedSettings(sample="slice")`` (``compare --sample slice``, the batched slice sampler) on
    all three 15-D problems. Measured (log Z - truth)/err: log-normal -0.4, +0.8, -0.8, +2.3, +2.3
    (seeds 1, 2, 3, 4, 7); Gaussian in a box +1.0, -0.6 and linear-Gaussian -1.1, +2.5 (seeds 1, 7)."""
    p = problem(15)
    run = run_nested(p, seed=7, settings=NestedSettings(sample="slice"))
    assert run.converged
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)
