"""One fs/Qms convention: every ``fs``/``Qms`` the package names (the fit JSON's ``derived``, a
posterior's derived quantities, the T/S table) is the Thiele–Small one of
:func:`~bayes_emt.models.derived.mechanical_resonance` (fs where the mechanical reactance vanishes,
Qms with all mechanical loss at fs; Knudsen & Jensen, JAES 41(1/2), 1993); ω0/2π and 1/(2ζ) stay
model parameters. Tolerance 1e-9 relative: the same Newton solve, evaluated twice."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_emt.models import parse_model_spec
from bayes_emt.models.derived import DERIVED, derived_values
from bayes_emt.thiele_small.relations import free_air


def _creep_theta(model):
    v = dict(zeta=1 / 6, omega0=2 * math.pi * 42, phi=7 / math.sqrt(0.015), R0=5.7, L0=2e-4,
             lambda_creep=0.08)
    return np.array([v[n] for n in model.names])


def test_derived_fs_qms_are_the_thiele_small_ones_under_creep():
    model = parse_model_spec("I+suspension_creep")
    th = _creep_theta(model)
    d = derived_values(model, th)
    ts = free_air(model, th[None, :])
    assert d["fs"] == pytest.approx(float(ts["fs"][0]), rel=1e-9)
    assert d["Qms"] == pytest.approx(float(ts["Qms"][0]), rel=1e-9)
    # and they are not the model parameters' omega0/2pi and 1/(2 zeta): creep moves both
    assert abs(d["fs"] - 42.0) > 0.2 and abs(d["Qms"] - 3.0) > 0.1  # 41.66 Hz, Q 2.17


def test_derived_is_vectorised_over_chains_and_draws():
    model = parse_model_spec("I+suspension_creep")
    th = np.broadcast_to(_creep_theta(model), (3, 4, model.ndim))
    fs = DERIVED["fs"][2](model, th)
    assert fs.shape == (3, 4)
    assert np.allclose(fs, derived_values(model, th[0, 0])["fs"], rtol=1e-12)


def test_without_creep_fs_is_omega0_over_two_pi():
    model = parse_model_spec("I")
    v = {"zeta": 0.1, "omega0": 300.0, "phi": 50.0, "R0": 6.0, "L0": 1e-3}
    th = np.array([v[n] for n in model.names])
    d = derived_values(model, th)
    assert d["fs"] == pytest.approx(300.0 / (2 * math.pi), rel=1e-12)
    assert d["Qms"] == pytest.approx(5.0, rel=1e-12)
