"""The truth study's measured blocked impedance (scripts/truth_study, issue 23).

Fast invariants on a synthetic U/I/V recording whose blocked impedance is known exactly, and, when
the public recording is placed (``$BAYES_EMT_TRUTH_DIR``, scripts/truth_study/SOURCES.md), the
truth it derives against its author's own readings of the same file.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.models import parse_model_spec

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "truth_study", ROOT / "scripts" / "truth_study" / "truth_study.py")
ts = importlib.util.module_from_spec(_spec)
sys.modules["truth_study"] = ts  # dataclasses look their module up there
_spec.loader.exec_module(ts)

REC = ts.Recording(name="synthetic", path="-", sha256="-", f_lo=10.0, f_hi=20000.0, v_max_hz=1000.0,
                   device="synthetic")


def _synthetic(f):
    """A Leach-coil driver: Ze = Re + K (jω)^n, Zm = jωM + R + Kms/(jω), I = U/(Ze + Bl²/Zm)."""
    w = 2 * np.pi * f
    Re, K, n, Bl, M, R, Km = 4.95, 2.7e-3, 0.8, 10.8, 0.0115, 2.5, 12000.0
    Ze = Re + K * (1j * w) ** n
    Zm = 1j * w * M + R + Km / (1j * w)
    U = np.full(f.shape, 0.6 + 0j)
    I = U / (Ze + Bl**2 / Zm)
    V = Bl * I / Zm
    return U, I, V, Ze, dict(Re=Re, Bl=Bl, fs=np.sqrt(Km / M) / (2 * np.pi))


def test_truth_recovers_a_known_driver():
    f = np.arange(1.0, 20001.0)
    U, I, V, Ze, p = _synthetic(f)
    tr = ts.measured_truth(f, U, I, V, REC)
    # Bl: the polynomial stands in for K (jω)^0.8 over [fs/3, 3 fs]; tolerance 0.5 % (measured 0.004 %)
    assert tr.Bl == pytest.approx(p["Bl"], rel=5e-3)
    # fs: the sign change of Im(I/V) on a 1 Hz grid, interpolated: within 0.1 Hz
    assert tr.fs == pytest.approx(p["fs"], abs=0.1)
    # R0: Re Ze over 10-30 Hz carries K ω^0.8 cos(0.4π) ≈ 0.04 ohm: within 1 % (measured +0.8 %)
    assert tr.R0 == pytest.approx(p["Re"], rel=1e-2)
    # below v_max the truth is Z − Bl V/I: exact up to the Bl error
    m = (f >= 10) & (f <= 1000)
    assert np.max(np.abs(tr.Ze[m] - Ze[m]) / np.abs(Ze[m])) < 5e-3
    # above it the piston extrapolation from the velocity is exact for a piston (same Bl error)
    m = f > 1000
    assert np.max(np.abs(tr.Ze[m] - Ze[m]) / np.abs(Ze[m])) < 5e-3


def test_blocked_impedance_is_the_series_coil_without_motional_terms():
    model = parse_model_spec("UD+second_resonance")
    base = parse_model_spec("UD")
    theta = model.vector({"zeta": 0.1, "omega0": 1000.0, "phi": 100.0, "R0": 5.0, "Lg": 1e-4,
                          "alpha": 5e-4, "beta": 0.04, "zeta2": 0.05, "omega2": 3e4, "phi2": 50.0})
    omega = np.geomspace(60.0, 1.2e5, 50)
    zb = ts.blocked_impedance(model, theta, omega)
    expected = 5.0 + model.coil_impedance(omega, theta)
    np.testing.assert_allclose(zb, expected, rtol=1e-12)
    tb = base.vector({k: v for k, v in model.as_dict(theta).items() if k in base.names})
    np.testing.assert_allclose(zb, ts.blocked_impedance(base, tb, omega), rtol=1e-12)


def _placed():
    root = os.environ.get("BAYES_EMT_TRUTH_DIR")
    if not root:
        return None
    path = Path(root) / ts.RECORDINGS[0].path
    return path if path.is_file() else None


@pytest.mark.skipif(_placed() is None, reason="the public U/I/V recording is not placed (SOURCES.md)")
def test_novak_recording_truth_matches_its_author():
    path = _placed()
    rec = ts.RECORDINGS[0]
    assert ts.sha256(path) == rec.sha256
    tr = ts.measured_truth(*ts.read_uiv(path), rec)
    # the author (antonin-novak/IMDEA, IMDEA_06/07 scripts) reads Bl = 10.8 T m by eye and
    # Re = 4.92-4.95 ohm from the same file; tolerances: 1 % on Bl, 1 % on Re
    assert tr.Bl == pytest.approx(10.8, rel=1e-2)
    assert 4.92 * 0.99 < tr.R0 < 4.95 * 1.01
    assert tr.Bl_spread[1] - tr.Bl_spread[0] < 0.01 * tr.Bl  # degree of the polynomial irrelevant
    assert 150.0 < tr.fs < 175.0  # |V/I| peaks at 160 Hz in the file


def test_instrument_factor_is_the_artifact_step_and_one_without_it():
    omega = np.geomspace(60.0, 1.2e5, 40)
    ud = parse_model_spec("UD")
    p = {"zeta": 0.1, "omega0": 1000.0, "phi": 100.0, "R0": 5.0, "Lg": 1e-4, "alpha": 5e-4, "beta": 0.04}
    np.testing.assert_allclose(ts.instrument_factor(ud, ud.vector(p), omega), 1.0, rtol=1e-12)
    art = parse_model_spec("UD+measurement_artifact")
    g = ts.instrument_factor(art, art.vector({**p, "omegas": 1156.0, "delta_s": 0.1, "psi_s": 0.05}), omega)
    step = omega > 1156.0
    np.testing.assert_allclose(g[~step], 1.0, rtol=1e-12)
    np.testing.assert_allclose(g[step], 1.1 * np.exp(0.05j), rtol=1e-12)
