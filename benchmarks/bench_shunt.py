"""Shunt design speed: one model's H∞-optimal RC shunt (target < 1 s each, issue 3)."""

from bayes_emt import build_model
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.shunt import design_rc_shunt


def _design(name):
    def run():
        m = build_model(name)
        return design_rc_shunt(m, m.vector(PAPER_TABLES[name]))

    return run


BENCHMARKS = {f"design_{name}": _design(name) for name in ("I", "II", "III", "UD", "NL")}
TARGETS = {f"design_{name}": 1.0 for name in ("I", "II", "III", "UD", "NL")}
