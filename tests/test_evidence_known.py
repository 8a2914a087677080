"""Known-answer evidence problems (issue 11, acceptance 1): nested and bridge sampling each within
3 of their own reported standard errors of the analytic log Z.

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


# NOT MET (issue 11, acceptance 1): on the 15-D log-normal under uniform priors, dynesty's random
# walk comes out far low; measured (n_live 200, seed 7, truth −44.94 nats): walks 35 −63.9 ± 0.55,
# walks 100 −49.9 ± 0.50, rslice −55.0 ± 0.53, and dynesty's own unbatched rwalk (walks 35)
# −59.1 ± 0.53, so it is the sampler on this skewed, cube-edge target, not the batching. Kept as
# a strict xfail so that a fix shows up.
_LOGNORMAL_15D = pytest.param(LogNormalUnderUniform, marks=pytest.mark.xfail(
    strict=True, reason="dynesty rwalk/rslice underestimate log Z by 5-19 nats on the 15-D log-normal"))


@pytest.mark.slow
@pytest.mark.parametrize("problem", [GaussianInBox, LinearGaussian, _LOGNORMAL_15D],
                         ids=["GaussianInBox", "LinearGaussian", "LogNormalUnderUniform"])
def test_nested_recovers_the_evidence_15d(problem):
    p = problem(15)
    run = run_nested(p, seed=7, settings=NestedSettings(n_live=200, walks=35))
    assert abs(run.log_z - p.truth) < 3 * run.log_z_err, (run.log_z, run.log_z_err, p.truth)
