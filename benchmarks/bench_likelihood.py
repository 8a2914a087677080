"""Posterior evaluation speed: one vectorised log-posterior call over an emcee ensemble
(the cost of one sampler step), on the bundled 2000-point data."""

import numpy as np

from bayes_emt import build_model
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.reference import PAPER_TABLES

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
