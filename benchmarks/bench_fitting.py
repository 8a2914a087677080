"""Deterministic fitting speed: all six models on the bundled paper-bench data (target < 10 s in
total, core issue acceptance 7), and one NL(5) fit."""

import warnings

from bayes_emt import build_model
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.models import MODEL_NAMES

_data = {}


def setup():
    _data["bench"] = load_paper_bench()


def _fit_all():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in MODEL_NAMES:
            fit_admittance(_data["bench"], build_model(name))


def _fit_nl():
    fit_admittance(_data["bench"], build_model("NL"))


BENCHMARKS = {"fit_all_six_models": _fit_all, "fit_NL5": _fit_nl}
TARGETS = {"fit_all_six_models": 10.0}
