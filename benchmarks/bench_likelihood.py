"""Posterior evaluation speed on the bundled 2000-point data.

Side by side with the baseline revision: one vectorised log-posterior call over an emcee ensemble
(the cost of one sampler step). Figures of merit (``measure``), for each of the six models at 64
walkers placed as the sampler places them (around the posterior mode, :func:`initial_walkers`):

* ``loglike_evals_per_s``: log-posterior evaluations per second, batched (64 walkers per call);
* ``floor_fraction``: the floor's time over the package's for the same batch, the floor being the
  hand-written fewest-operation evaluation of the same likelihood (``floors.py``, checked equal to
  1e-9); the package's call also evaluates the prior, so the fraction is a little pessimistic;
* details: the same evaluations one walker per call (what a per-walker sampler such as lmfit's
  pays) and the likelihood alone.
"""

import warnings

import numpy as np
from floors import Floors
from timing import best_interleaved

from bayes_emt import build_model
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.reference import PAPER_TABLES

MODELS = ("I", "II", "III", "UD", "NL", "UL")
WALKERS = 64
_cases = {}


def setup():
    meas = load_paper_bench()
    rng = np.random.default_rng(0)
    for name in ("UD", "NL"):
        lik = Likelihood(build_model(name), meas)
        theta = np.r_[lik.model.vector(PAPER_TABLES[name]), 0.002, 1e-5]
        z = lik.params.to_z(theta) + 1e-3 * rng.standard_normal((4 * lik.ndim, lik.ndim))
        _cases[name] = (lik, z)


def _step(name):
    def run():
        lik, z = _cases[name]
        return lik.log_posterior_z(z)

    return run


BENCHMARKS = {"log_posterior_UD_ensemble": _step("UD"), "log_posterior_NL5_ensemble": _step("NL")}


def _walkers(lik, meas):
    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.inference.sampling import initial_walkers

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_admittance(meas, lik.model)
    return initial_walkers(lik, fit, WALKERS, np.random.default_rng(1))


def measure() -> dict:
    meas = load_paper_bench()
    floors = Floors(meas.omega, meas.Y)
    evals, fraction, loop, lik_only, points = {}, {}, {}, {}, {}
    for name in MODELS:
        model = build_model(name)
        lik = Likelihood(model, meas)
        z = _walkers(lik, meas)
        x = lik.params.from_z(z)
        floor = getattr(floors, name)
        ref = lik(x)
        got = floor(x)
        if not np.allclose(got, ref, rtol=1e-9, atol=0):
            raise RuntimeError(f"the floor of {name} disagrees with the likelihood: {got[:3]} vs {ref[:3]}")
        t = best_interleaved({"package": lambda lik=lik, z=z: lik.log_posterior_z(z),
                              "likelihood": lambda lik=lik, x=x: lik(x),
                              "floor": lambda f=floor, x=x: f(x)})
        rows = [z[i : i + 1] for i in range(WALKERS)]
        t_loop = best_interleaved({"loop": lambda lik=lik, rows=rows: [lik.log_posterior_z(r) for r in rows]},
                                  min_calls=3, min_time=0.5)["loop"]
        evals[name] = WALKERS / t["package"]
        fraction[name] = t["floor"] / t["package"]
        loop[name] = WALKERS / t_loop
        lik_only[name] = WALKERS / t["likelihood"]
        points[name] = "fast path" if lik._plan is not None else "model path"
    return {
        "results": {"loglike_evals_per_s": evals, "floor_fraction": fraction},
        "targets": {"loglike_evals_per_s.NL": [">=", 10000.0],
                    **{f"floor_fraction.{m}": [">=", 0.5] for m in MODELS}},
        "details": {"per_walker_loop_evals_per_s": loop, "likelihood_only_evals_per_s": lik_only,
                    "evaluation": points, "walkers": WALKERS, "points": int(meas.n_points),
                    "notes": [f"{WALKERS} walkers around each model's posterior mode on the bundled "
                              f"data ({meas.n_points} frequencies), one core; evaluations per second "
                              "of the log posterior (prior + likelihood); NL and UL with 5 rings",
                              "floor_fraction = floor time / package time, same batch, best of >= 7 "
                              "interleaved calls; the floor (benchmarks/floors.py) is the hand-written "
                              "fewest-operation evaluation of the same likelihood"]},
    }
