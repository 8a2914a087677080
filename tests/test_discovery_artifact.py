"""Instrument-step recall (slow): a range switch the data show clearly is named
``measurement_artifact`` by a full diagnosis, whichever plant it sits on. Cases of the concealed
benchmark's recall grid (NL(5) and UD plants, 0.2 % noise, 500 points over 10-1e5 rad/s, the switch
at 3000 rad/s): the weakest phase step the acceptance counts (10x the noise, magnitude 1x) on both
plants, and the issue's own switch on NL(5) (0.4 % in magnitude, 0.05 rad in phase: 2x and 25x),
which a warm-started polish once lost to the NL rings."""

import numpy as np
import pytest

from bayes_emt.discovery import diagnose
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

GRID = np.geomspace(1e1, 1e5, 500)
NOISE = 0.002


@pytest.mark.slow
@pytest.mark.parametrize(("base", "phase_x", "mag_x", "seed"),
                         [("NL", 25, 2, 1), ("NL", 10, 1, 1), ("UD", 10, 1, 1)])
def test_a_clear_range_switch_is_named_an_instrument_artifact(base, phase_x, mag_x, seed):
    start = "NL(5)" if base == "NL" else base
    model = parse_model_spec(start + "+measurement_artifact")
    vals = {**PAPER_TABLES[base], "omegas": 3000.0, "delta_s": mag_x * NOISE, "psi_s": phase_x * NOISE}
    meas = simulate(model, vals, GRID, noise=NOISE, seed=seed)
    d = diagnose(meas, parse_model_spec(start), seed=0, workers=1)
    step = [f for f in d.findings if "measurement_artifact" in f.physics.split("+")]
    assert step, (d.final_model, d.warnings)
    added = step[0].parameters["added"]
    # the switch between the right two points (3000 rad/s lies between 2999 and 3055; a step is flat
    # between them, so it carries no standard error) and its phase step within half the point noise
    # (each side's ~250 points average it to about 0.2 % / sqrt(250) = 1.3e-4 rad; 1e-3 rad is 10 % of
    # the 10x step)
    assert 2900.0 < added["omegas"]["value"] < 3100.0
    assert added["psi_s"]["value"] == pytest.approx(phase_x * NOISE, abs=1e-3)
