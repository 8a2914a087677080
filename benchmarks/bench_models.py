"""Model evaluation throughput: one vectorised admittance call over an emcee-sized ensemble."""

import numpy as np

from bayes_emt import build_model
from bayes_emt.reference import PAPER_TABLES

OMEGA = np.geomspace(10, 1e5, 2000)
_cases = {}


def setup():
    rng = np.random.default_rng(0)
    for name, rings in (("UD", None), ("NL", 5)):
        m = build_model(name, rings=rings)
        th = m.vector(PAPER_TABLES[name])
        _cases[name] = (m, th * np.exp(0.01 * rng.standard_normal((64, th.size))))


def _eval(name):
    def run():
        m, th = _cases[name]
        return m.admittance(OMEGA, th)

    return run


BENCHMARKS = {
    "admittance_UD_64x2000": _eval("UD"),
    "admittance_NL5_64x2000": _eval("NL"),
}
