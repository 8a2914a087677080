"""Shared fixtures: the real recordings beside the repository, the bundled data, simulated
measurements. Real recordings are read from ``../shared/realdata`` and never copied here; a test
that needs one is skipped, with the reason, where they are absent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bayes_emt.io.datasets import load_paper_bench, load_realdata
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec

#: the real loudspeaker recordings (../shared/realdata/README.md)
REALDATA = Path(__file__).resolve().parents[2] / "shared" / "realdata"


@pytest.fixture
def realdata() -> Path:
    """The real-recordings folder; the test is skipped when it is absent."""
    if not REALDATA.is_dir():
        pytest.skip("../shared/realdata not present")
    return REALDATA


@pytest.fixture
def real_recording(realdata):
    """``real_recording(name)``: one real recording as a Measurement (its README's conventions:
    :func:`bayes_emt.io.datasets.load_realdata`); skipped when the file is absent."""

    def load(name: str):
        if not (realdata / name).is_file():
            pytest.skip(f"../shared/realdata/{name} not present")
        return load_realdata(realdata, name)

    return load


@pytest.fixture(scope="session")
def paper_bench():
    """The bundled 2000-point recording (NL(5), Table 5 parameters, 0.2 % noise; data/README.md)."""
    return load_paper_bench()


@pytest.fixture(scope="session")
def simulated():
    """``simulated(spec, params, grid=None, noise=0.002, seed=0)``: a measurement simulated from a
    model spec (default grid: 300 points, 10..1e5 rad/s)."""

    def make(spec: str, params, grid=None, noise: float = 0.002, seed: int = 0):
        omega = np.geomspace(1e1, 1e5, 300) if grid is None else np.asarray(grid, float)
        return simulate(parse_model_spec(spec), params, omega, noise=noise, seed=seed)

    return make
