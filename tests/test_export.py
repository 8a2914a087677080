"""Exports (bayes_emt.io.export, ``bayes-emt export``): ZMA/FRD of a fitted impedance re-read to
1e-6 relative; WinISD and Hornresp driver files parse back to the values written."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from bayes_emt.errors import DataFormatError
from bayes_emt.io import read_measurement
from bayes_emt.io.export import (
    hornresp_mmd,
    read_hornresp,
    read_wdr,
    write_frd,
    write_hornresp,
    write_wdr,
    write_zma,
)
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver


def _ud_curve():
    model = parse_model_spec("UD")
    theta = model.vector({"zeta": 0.12, "omega0": 2 * math.pi * 40, "phi": 50.0, "R0": 5.6, "Lg": 4e-4,
                          "alpha": 1.5e-4, "beta": 0.12})
    f = np.geomspace(10, 20000, 400)
    return f, model.impedance(2 * math.pi * f, theta)


def test_zma_rereads_within_1e_6(tmp_path):
    f, Z = _ud_curve()
    path = write_zma(tmp_path / "fit.zma", f, Z, comment="test")
    meas = read_measurement(path)
    assert np.max(np.abs(meas.f_hz - f) / f) < 1e-6
    assert np.max(np.abs(meas.Z - Z) / np.abs(Z)) < 1e-6


def test_frd_is_impedance_in_db(tmp_path):
    f, Z = _ud_curve()
    path = write_frd(tmp_path / "fit.frd", f, Z)
    rows = np.array([[float(x) for x in ln.split()] for ln in path.read_text().splitlines()
                     if not ln.startswith("*")])
    assert np.allclose(rows[:, 0], f, rtol=1e-9)
    back = 10 ** (rows[:, 1] / 20) * np.exp(1j * np.radians(rows[:, 2]))
    assert np.max(np.abs(back - Z) / np.abs(Z)) < 1e-6


def test_curve_writers_refuse_bad_input(tmp_path):
    with pytest.raises(ValueError, match="increasing"):
        write_zma(tmp_path / "x.zma", [10.0, 5.0], [1 + 0j, 2 + 0j])


def test_driver_files_parse_back(tmp_path):
    sim = simulate_driver("I+semi_inductance", seed=8, n_points=400)
    ts = thiele_small(sim.free, "I+semi_inductance", loaded=list(sim.loaded), sd=sim.sd, fast=True,
                      models_for_spread=[])
    wdr = read_wdr(write_wdr(tmp_path / "d.wdr", ts))
    pairs = (("Fs", "fs"), ("Qts", "Qts"), ("Vas", "Vas"), ("BL", "Bl"), ("Re", "Re"), ("Mms", "Mms"))
    for key, name in pairs:
        assert wdr[key] == pytest.approx(ts[name], rel=1e-9)
    assert wdr["Sd"] == pytest.approx(sim.sd, rel=1e-9)
    hr = read_hornresp(write_hornresp(tmp_path / "hr.txt", ts))
    assert hr["Sd"] == pytest.approx(sim.sd * 1e4, rel=1e-5)
    assert hr["Cms"] == pytest.approx(ts["Cms"], rel=1e-5)
    assert hr["Le"] == pytest.approx(ts["Le"] * 1e3, rel=1e-5)
    assert hr["Mmd"] == pytest.approx(hornresp_mmd(ts["Mms"], sim.sd) * 1e3, rel=1e-5)
    assert 0 < hr["Mmd"] < ts["Mms"] * 1e3
    (tmp_path / "bad.txt").write_text("Sd = 1\n")
    with pytest.raises(DataFormatError, match="missing"):
        read_hornresp(tmp_path / "bad.txt")


def test_cli_export_fit_and_ts(tmp_path):
    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.io import write_measurement
    from bayes_emt.io.paramfile import write_json

    sim = simulate_driver("I+semi_inductance", deltas=(), seed=9, n_points=300)
    data = write_measurement(sim.free, tmp_path / "free.zma")
    fit = fit_admittance(sim.free, parse_model_spec("I+semi_inductance"))
    write_json(tmp_path / "fit.json", fit.to_json_dict())
    out = tmp_path / "fitted.zma"
    cmd = [sys.executable, "-m", "bayes_emt.cli", "export", str(tmp_path / "fit.json"), "--data", str(data),
           "--zma", str(out), "--frd", str(tmp_path / "fitted.frd")]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    back = read_measurement(out)
    Z = fit.model.impedance(2 * math.pi * back.f_hz, fit.theta)
    assert np.max(np.abs(back.Z - Z) / np.abs(Z)) < 1e-6
    bad = subprocess.run(cmd[:5] + ["--wdr", str(tmp_path / "x.wdr")], capture_output=True, text=True,
                         timeout=120)
    assert bad.returncode != 0 and "not a T/S record" in bad.stderr and "Traceback" not in bad.stderr
    ts = thiele_small(sim.free, "I+semi_inductance", mms=sim.truth["Mms"], sd=sim.sd, fast=True,
                      models_for_spread=[])
    ts.save(tmp_path / "ts.json")
    p = subprocess.run([sys.executable, "-m", "bayes_emt.cli", "export", str(tmp_path / "ts.json"),
                        "--wdr", str(tmp_path / "d.wdr"), "--hornresp", str(tmp_path / "h.txt")],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert read_wdr(tmp_path / "d.wdr")["Fs"] == pytest.approx(json.loads((tmp_path / "ts.json").read_text())
                                                                ["parameters"]["fs"]["value"], rel=1e-9)
