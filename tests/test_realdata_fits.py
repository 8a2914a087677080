"""Every real recording fits with every model (acceptance 5 of the core issue).

The recordings are read from ../shared/realdata (never copied here); bands per its README.
Residual table: scripts/realdata_table.py.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

from bayes_emt import build_model
from bayes_emt.datasets import REALDATA_FILES, load_realdata
from bayes_emt.fitting import fit_admittance
from bayes_emt.models import MODEL_NAMES

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
pytestmark = pytest.mark.skipif(not REAL.exists(), reason="../shared/realdata not present")


@pytest.mark.parametrize("name", sorted(REALDATA_FILES))
def test_every_model_fits_every_recording(name):
    meas = load_realdata(REAL, name)
    rms = {}
    for m in MODEL_NAMES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_admittance(meas, build_model(m))
        assert np.all(np.isfinite(fit.theta))
        rms[m] = fit.rms_rel_residual
    # real voice coils have eddy currents: the distributed models beat the plain inductor
    assert rms["UD"] < rms["I"] and rms["NL"] < rms["I"]
    assert rms["NL"] < 0.05
