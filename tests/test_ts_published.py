"""The manufacturer's published LS10-44 set (bayes_emt.thiele_small.published; source cited there)
is consistent with the T/S relations of bayes_emt.thiele_small.relations (R. H. Small, JAES 20(5),
1972), which is what makes it a reference for ``ts``: a plain driver built from the published fs,
Qms, Re, Le, Bl and Mms gives back the published Qes, Qts, Cms and Vas.

Tolerances: the published values have two or three significant digits (rounding alone moves the
derived values by up to about 1 %); Dayton's numbers come from their own fit, not from these
formulas, so 3 % is allowed (measured: Qes 0.6 %, Qts 0.7 %, Cms 1.9 %, Vas 0.9 %)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small.published import LS10_44, LS10_44_SOURCE
from bayes_emt.thiele_small.relations import free_air, with_mass, with_sd


def _published_driver():
    p = LS10_44
    model = parse_model_spec("I")
    values = {"zeta": 1 / (2 * p["Qms"]), "omega0": 2 * math.pi * p["fs"],
              "phi": p["Bl"] / math.sqrt(p["Mms"]), "R0": p["Re"], "L0": p["Le"]}
    theta = np.array([[values[n] for n in model.names]])
    ts = with_sd(with_mass(free_air(model, theta), model, theta, p["Mms"]), p["Sd"], p["rho"], p["c"])
    return {k: float(v[0]) for k, v in ts.items()}


def test_published_ls10_44_set_is_consistent_with_the_relations():
    ts, p = _published_driver(), LS10_44
    for name in ("fs", "Re", "Qms", "Bl", "Mms"):  # what the driver was built from comes back exactly
        assert ts[name] == pytest.approx(p[name], rel=1e-12)
    for name in ("Qes", "Qts", "Cms", "Vas"):
        assert ts[name] == pytest.approx(p[name], rel=0.03), name
    assert "daytonaudio.com" in LS10_44_SOURCE
    assert "2f7006ffcd3e9b7bb19ceca49f678a8f323b9f5a" in LS10_44_SOURCE


def test_published_qes_needs_both_coils():
    """Qes = ωs Mms Re/Bl² is the same for the coils in series (2r, 2b) and in parallel (r/2, b) but
    twice as large for one coil driven alone (r, b): the published Qes is the both-coils value."""
    p = LS10_44
    ws = 2 * math.pi * p["fs"]
    both = ws * p["Mms"] * p["Re"] / p["Bl"] ** 2
    one = ws * p["Mms"] * (p["Re"] / 2) / (p["Bl"] / 2) ** 2
    assert both == pytest.approx(p["Qes"], rel=0.03)
    assert one == pytest.approx(2 * p["Qes"], rel=0.03)
