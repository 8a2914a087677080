"""Effective samples per second against lmfit's ``Minimizer.emcee``, and the checkpoint's size.

Side by side in one process, on the bundled data, for UD and NL(5):

* **bayes_emt**: :func:`~bayes_emt.inference.sampling.sample_posterior` with its defaults, as the
  demo calls it (seed 0, an HDF5 checkpoint), from the least-squares fit; the time is the whole
  call (start refinement, warm-up, sampling to the stopping rule, the posterior record);
* **lmfit 1.3.4** ``Minimizer.emcee`` (emcee's stretch move, one walker per call, 100 walkers, the
  parameters in physical units bounded by the prior support) with an objective returning the
  same log posterior as a float (``float_behavior='posterior'``): same data, same model function
  (:class:`~bayes_emt.inference.likelihood.Likelihood`, including its fast path), same noise model
  and priors, and the same start: its 100 walkers drawn like ours (:func:`initial_walkers`, whose
  start refinement lmfit would not have); it runs for ``BAYES_EMT_BENCH_LMFIT_SECONDS`` (180 s)
  worth of steps.

Effective sample size per parameter ``ESS = walkers · (steps − burn)/τ`` with emcee's τ computed
in the same (sampling-space) coordinates for both, burn-in ``2 τ_max``; the figure is the
smallest over all sampled parameters, per second of wall time.

lmfit's chain within the budget is far shorter than the 50 τ that make τ trustworthy, and a short
chain's τ is underestimated (its ESS overestimated). So its τ is measured on the same Markov chain
run long: emcee's stretch move, 100 walkers, the same log posterior in the same physical
coordinates from the same start, with the log posterior evaluated for all walkers at once
(which changes the cost, not the chain), until the chain is 50 τ_max long (or
``BAYES_EMT_BENCH_STRETCH_SECONDS``, 600 s, ran out: then reported). lmfit's ESS per second is then
``walkers / (τ_max · seconds per step of the lmfit run)``, which also ignores lmfit's burn-in (in
its favour); the ratio from lmfit's own short chain is reported as ``*_direct``, a lower bound.
``checkpoint_bytes_per_step`` is the size of our NL(5) checkpoint (the demo's run) over its steps.
"""

import math
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from bayes_emt import build_model
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.inference.sampling import initial_walkers, integrated_time, sample_posterior
from bayes_emt.io.datasets import load_paper_bench

LMFIT_WALKERS = 100


def _ess(chain_z: np.ndarray) -> tuple[np.ndarray, int, float]:
    """ESS per parameter, burn-in and chain length in τ_max of a sampling-space chain."""
    n, w = chain_z.shape[:2]
    tau0 = integrated_time(chain_z)
    burn = min(int(math.ceil(2 * np.max(tau0))), n // 2)
    tau = integrated_time(chain_z[burn:])
    return w * (n - burn) / tau, burn, float((n - burn) / np.max(tau))


def _ours(meas, model, fit, checkpoint: Path) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = sample_posterior(meas, model, fit=fit, seed=0, checkpoint=checkpoint, overwrite=True,
                                progress=False)
    return {"ess_min": float(np.min(post.ess)), "seconds": float(post.wall_time),
            "ess_per_s": float(np.min(post.ess)) / post.wall_time, "steps": int(post.n_steps),
            "walkers": int(post.n_walkers), "tau_max": float(np.max(post.tau)),
            "converged": bool(post.converged),
            "checkpoint_bytes": os.path.getsize(checkpoint), "acceptance": float(post.acceptance)}


def _stretch_tau(lik, x0, budget: float) -> dict:
    """τ of lmfit's Markov chain (stretch move, physical coordinates), run to 50 τ_max."""
    import emcee

    def logpost(x):
        with np.errstate(all="ignore"):
            lp = lik.params.log_prior(x)
            out = np.full(x.shape[0], -np.inf)
            ok = np.isfinite(lp)
            if np.any(ok):
                out[ok] = lp[ok] + lik(x[ok])
        return np.where(np.isfinite(out), out, -np.inf)

    sampler = emcee.EnsembleSampler(x0.shape[0], x0.shape[1], logpost, vectorize=True)
    sampler.random_state = np.random.RandomState(0).get_state()
    t0, state, n_tau, tau = time.perf_counter(), x0, 0.0, None
    while time.perf_counter() - t0 < budget:
        state = sampler.run_mcmc(state, 2000, skip_initial_state_check=True)
        chain_z = lik.params.to_z(sampler.get_chain())
        _, burn, n_tau = _ess(chain_z)
        tau = integrated_time(chain_z[burn:])
        if n_tau >= 50:
            break
    return {"tau_max": float(np.max(tau)), "steps": int(sampler.iteration), "chain_over_tau_max": n_tau,
            "seconds": time.perf_counter() - t0}


def _lmfit(lik, fit, budget: float) -> dict:
    import lmfit

    names = list(lik.params.names)
    z0 = initial_walkers(lik, fit, LMFIT_WALKERS, np.random.default_rng(0))
    x0 = lik.params.from_z(z0)
    params = lmfit.Parameters()
    for i, spec in enumerate(lik.params):
        params.add(spec.name, value=float(np.median(x0[:, i])), min=spec.prior.lower, max=spec.prior.upper)

    def objective(p):
        x = np.array([p[n].value for n in names])
        v = float(lik.params.log_prior(x) + lik(x))
        return v if math.isfinite(v) else -np.inf

    def run(steps):
        mini = lmfit.Minimizer(objective, params.copy(), nan_policy="propagate")
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = mini.emcee(steps=steps, nwalkers=LMFIT_WALKERS, pos=x0, seed=0, progress=False,
                             float_behavior="posterior")
        return res, time.perf_counter() - t0

    _, t_pilot = run(10)
    steps = int(np.clip(budget / (t_pilot / 10), 200, 50000))
    res, seconds = run(steps)
    chain_z = lik.params.to_z(np.asarray(res.chain))
    ess, burn, n_tau = _ess(chain_z)
    long = _stretch_tau(lik, x0, float(os.environ.get("BAYES_EMT_BENCH_STRETCH_SECONDS", "600")))
    return {"ess_min": float(np.min(ess)), "seconds": seconds,
            "ess_per_s_direct": float(np.min(ess)) / seconds,
            "ess_per_s": LMFIT_WALKERS / (long["tau_max"] * seconds / steps),
            "steps": steps, "walkers": LMFIT_WALKERS, "burn": burn, "chain_over_tau_max": n_tau,
            "acceptance": float(np.mean(res.acceptance_fraction)), "long_chain": long}


def measure() -> dict:
    budget = float(os.environ.get("BAYES_EMT_BENCH_LMFIT_SECONDS", "180"))
    meas = load_paper_bench()
    details, ratios = {}, {}
    bytes_per_step = None
    with tempfile.TemporaryDirectory(prefix="bayes_emt_bench_") as tmp:
        for name in ("UD", "NL"):
            model = build_model(name)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_admittance(meas, model)
            ours = _ours(meas, model, fit, Path(tmp) / f"{name}.h5")
            theirs = _lmfit(Likelihood(model, meas), fit, budget)
            ratios[name] = ours["ess_per_s"] / theirs["ess_per_s"]
            ratios[name + "_direct"] = ours["ess_per_s"] / theirs["ess_per_s_direct"]
            details[name] = {"bayes_emt": ours, "lmfit": theirs}
            if name == "NL":
                bytes_per_step = ours["checkpoint_bytes"] / ours["steps"]
    nl = details["NL"]["bayes_emt"]
    return {
        "results": {"ess_per_s_ratio_vs_lmfit_UD": ratios["UD"], "ess_per_s_ratio_vs_lmfit_NL": ratios["NL"],
                    "ess_per_s_ratio_vs_lmfit_UD_direct": ratios["UD_direct"],
                    "ess_per_s_ratio_vs_lmfit_NL_direct": ratios["NL_direct"],
                    "checkpoint_bytes_per_step": bytes_per_step,
                    "checkpoint_mb_demo_NL5": nl["checkpoint_bytes"] / 1e6},
        "targets": {"ess_per_s_ratio_vs_lmfit_UD": [">=", 10.0], "ess_per_s_ratio_vs_lmfit_NL": [">=", 10.0],
                    "checkpoint_mb_demo_NL5": ["<=", 25.0]},
        "details": {**details, "lmfit_budget_seconds": budget,
                    "notes": ["ESS = walkers (steps - burn)/tau per parameter, the smallest over all "
                              "sampled parameters, per second of wall time; tau by emcee's estimator in "
                              "sampling space",
                              "lmfit: seconds per step from its own run; tau from the same chain (stretch "
                              "move, physical coordinates, same posterior and start) run to 50 tau_max with "
                              "batched evaluations (lmfit.long_chain); *_direct: from lmfit's own short "
                              "chain (chain_over_tau_max < 50: tau underestimated), a lower bound",
                              "checkpoint: the NL(5) run as the demo makes it (seed 0, bundled data)"]},
    }
