"""Thiele–Small parameters (bayes_emt.thiele_small): the relations, the creep convention, the
three methods on simulated drivers of known T/S, JSON, the CLI, the ohmmeter option.

Reference relations: R. H. Small, JAES 20(5), 1972 (Qes, Vas, eta0); the added-volume formula
Vas = Vb((fc Qec)/(fs Qes) - 1) (Small, JAES 20(10), 1972). Tolerances are stated per test."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.errors import DataFormatError
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small import read_thiele_small, thiele_small
from bayes_emt.thiele_small.relations import free_air, mechanical_resonance, with_mass, with_sd
from bayes_emt.thiele_small.simulate import simulate_driver

REALDATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"


def _theta(model, **v):
    return np.array([[v[n] for n in model.names]])


def test_relations_plain_driver_match_small_by_hand():
    """Plain mass-spring-damper: fs = ω0/2π, Qms = 1/(2ζ), Qes = ω0 Re Mms / Bl², Vas = ρc²Sd²Cms,
    SPL(1 W) = 112.1 + 10 log10 η0 at ρ = 1.18, c = 343 (to 0.05 dB: 112.07 exactly)."""
    model = parse_model_spec("I")
    m, fs, bl, re, qms = 0.02, 40.0, 8.0, 6.0, 4.0
    w = 2 * math.pi * fs
    th = _theta(model, zeta=1 / (2 * qms), omega0=w, phi=bl / math.sqrt(m), R0=re, L0=1e-3)
    ts = with_sd(with_mass(free_air(model, th), model, th, m), 0.02, 1.18, 343.0)
    qes = w * m * re / bl**2
    assert ts["fs"][0] == pytest.approx(fs, rel=1e-12)
    assert ts["Qms"][0] == pytest.approx(qms, rel=1e-12)
    assert ts["Qes"][0] == pytest.approx(qes, rel=1e-12)
    assert ts["Qts"][0] == pytest.approx(qms * qes / (qms + qes), rel=1e-12)
    assert ts["Le"][0] == pytest.approx(1e-3, rel=1e-12)
    cms = 1 / (w * w * m)
    assert ts["Cms"][0] == pytest.approx(cms, rel=1e-12)
    assert ts["Rms"][0] == pytest.approx(w * m / qms, rel=1e-12)
    vas = 1.18 * 343.0**2 * 0.02**2 * cms
    assert ts["Vas"][0] == pytest.approx(vas, rel=1e-12)
    eta0 = 4 * math.pi**2 / 343.0**3 * fs**3 * vas / qes
    spl_1w = ts["SPL"][0] - 10 * math.log10(2.83**2 / re)
    assert spl_1w == pytest.approx(112.1 + 10 * math.log10(eta0), abs=0.05)
    assert ts["EBP"][0] == pytest.approx(fs / qes, rel=1e-12)


def test_creep_fs_is_zero_reactance_and_qms_total_loss():
    """Under LOG creep the reported fs makes the mechanical reactance vanish (1e-9 relative) and
    Qms = ωs Mms / Re Zm(jωs); with λ → 0 both tend to the plain ω0/2π and 1/(2ζ)."""
    model = parse_model_spec("I+suspension_creep")
    m, w0, zeta, lam = 0.015, 2 * math.pi * 42, 1 / 6, 0.08
    th = _theta(model, zeta=zeta, omega0=w0, phi=7 / math.sqrt(m), R0=5.7, L0=2e-4, lambda_creep=lam)
    ws, qms, qv = mechanical_resonance(model, th)
    kappa = 1 / (1 + lam * np.log(w0 / (1j * ws[0])))
    zm = 2 * zeta * w0 + 1j * ws[0] + w0**2 * kappa / (1j * ws[0])  # Zm / Mms
    assert abs(zm.imag) < 1e-9 * ws[0]
    assert qms[0] == pytest.approx(ws[0] / zm.real, rel=1e-9)
    assert qms[0] < qv[0]  # the creep's loss lowers Qms
    th0 = th.copy()
    th0[0, -1] = 1e-9
    ws0, q0, _ = mechanical_resonance(model, th0)
    assert ws0[0] == pytest.approx(w0, rel=1e-6) and q0[0] == pytest.approx(1 / (2 * zeta), rel=1e-6)


@pytest.mark.parametrize("spec", ["I+semi_inductance", "I+semi_inductance+suspension_creep"])
def test_added_mass_fast_recovers_known_driver(spec):
    """Two added masses, 0.5 % noise, 600 points: every true value inside the reported 90 %
    interval widened by 2 (a single seed: the coverage study is scripts/ts_coverage.py)."""
    sim = simulate_driver(spec, seed=3, n_points=600)
    r = thiele_small(sim.free, spec, loaded=list(sim.loaded), sd=sim.sd, fast=True, seed=1,
                     models_for_spread=[])
    assert r.method == "added_mass"
    for name, p in r.parameters.items():
        lo, hi = p["ci90"]
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        assert abs(sim.truth[name] - mid) <= 2 * half + 1e-12 * abs(mid), (name, sim.truth[name], p)
    assert any(w["code"] == "fast_intervals" for w in r.warnings)


def test_added_volume_fast_recovers_vas():
    sim = simulate_driver("I+semi_inductance", deltas=(), box_volume=0.010, seed=2, n_points=600)
    r = thiele_small(sim.free, "I+semi_inductance", box=sim.box, sd=sim.sd, fast=True, models_for_spread=[])
    assert r.method == "added_volume"
    lo, hi = r.parameters["Vas"]["ci90"]
    assert lo < r.parameters["Vas"]["value"] < hi
    assert abs(sim.truth["Vas"] - r["Vas"]) <= 2 * (hi - lo), (sim.truth["Vas"], r.parameters["Vas"])
    assert r["Mms"] == pytest.approx(sim.truth["Mms"], rel=0.05)


def test_free_air_with_known_mass_json_roundtrip(tmp_path):
    sim = simulate_driver("I+semi_inductance", deltas=(), seed=4, n_points=500)
    r = thiele_small(sim.free, "I+semi_inductance", mms=sim.truth["Mms"], sd=sim.sd, fast=True,
                     models_for_spread=["II", "UD"])
    assert set(r.parameters) >= {"fs", "Re", "Le", "Qms", "Qes", "Qts", "Bl", "Vas", "SPL", "EBP"}
    assert r["Bl"] == pytest.approx(sim.truth["Bl"], rel=0.01)
    path = r.save(tmp_path / "ts.json")
    rec = json.loads(path.read_text())
    assert rec["method"] == "free_air" and rec["parameters"]["fs"]["unit"] == "Hz"
    assert set(rec["parameters"]["Vas"]) == {"value", "ci90", "unit", "model_spread", "model_only"}
    back = read_thiele_small(path)
    assert back.parameters == r.parameters and back.method == r.method
    import bayes_emt as be

    assert json.loads(path.read_text())["kind"] == "thiele_small"
    assert be.load(path).parameters == r.parameters  # by its kind
    text = r.summary()
    for unit in ("Hz", "Ω", "mH", "g", "mm/N", "L", "dB"):
        assert unit in text
    assert "ThieleSmall(free_air" in repr(r) and "<table>" in r._repr_html_()


def test_bad_inputs_raise_one_line_errors(tmp_path):
    sim = simulate_driver("I", deltas=(), seed=0, n_points=300)
    with pytest.raises(ValueError, match="not both"):
        thiele_small(sim.free, "I", mms=0.01, bl=5.0)
    with pytest.raises(ValueError, match="positive"):
        thiele_small(sim.free, "I", sd=-1.0)
    with pytest.raises(ValueError, match="re must be"):
        thiele_small(sim.free, "I", re=(5.0, 0.0))
    bad = tmp_path / "x.json"
    bad.write_text("{}")
    with pytest.raises(DataFormatError, match="not a T/S record"):
        read_thiele_small(bad)


def test_re_prior_mode_combines_meter_and_data_as_gaussians():
    """The penalised R0 is the precision-weighted mean of the fit's R0 (its standard error σ_d)
    and the reading (its sd) — to 10 % of the shift (the fit is not exactly linear) — whether
    the data pin R0 (sd 5 σ_d: R0 barely moves) or not (sd σ_d/5: R0 goes to the meter)."""
    sim = simulate_driver("I+semi_inductance", deltas=(), seed=5, n_points=400)
    model = parse_model_spec("I+semi_inductance")
    free = fit_admittance(sim.free, model)
    r0, sd_d = free.parameters["R0"], free.stderr["R0"]
    meter = r0 + 3 * sd_d
    for sd in (5 * sd_d, sd_d / 5):
        pen = fit_admittance(sim.free, model, re=(meter, sd, "prior"))
        w = (1 / sd_d**2) / (1 / sd_d**2 + 1 / sd**2)
        expect = w * r0 + (1 - w) * meter
        got = pen.parameters["R0"]
        assert abs(got - expect) <= 0.1 * abs(expect - r0), (sd, got, expect)
        assert pen.info["re"]["value"] == meter
    assert abs(pen.parameters["R0"] - meter) <= sd  # the tight reading wins: within its sd


def test_cli_ts_fast_writes_json(tmp_path):
    sim = simulate_driver("I+semi_inductance", seed=6, n_points=400)
    from bayes_emt.io import write_measurement

    files = [write_measurement(m, tmp_path / f"{n}.zma") for n, m in
             (("free", sim.free), ("l1", sim.loaded[0][0]), ("l2", sim.loaded[1][0]))]
    out = tmp_path / "ts.json"
    cmd = [sys.executable, "-m", "bayes_emt.cli", "ts", str(files[0]), "--model", "I+semi_inductance",
           "--loaded", str(files[1]), "--delta-m", "0.010", "--loaded", str(files[2]), "--delta-m", "0.020",
           "--sd", str(sim.sd), "--fast", "--spread-models", "none", "--json", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "Mms" in p.stdout and "mm/N" in p.stdout
    rec = json.loads(out.read_text())
    assert rec["method"] == "added_mass" and len(rec["inputs"]["loaded"]) == 2
    bad = subprocess.run(cmd[:-2] + ["--delta-m", "0.03"], capture_output=True, text=True, timeout=120)
    assert bad.returncode != 0 and "pairs" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.skipif(not (REALDATA / "dayton_LS10-44_freeair_run2.txt").exists(), reason="realdata absent")
def test_ls10_44_pair_gives_the_full_set_fast():
    opts = {"freq_unit": "hz", "phase_unit": "rad"}
    r = thiele_small(REALDATA / "dayton_LS10-44_freeair_run2.txt", "UD",
                     loaded=[(REALDATA / "dayton_LS10-44_added100g_run2.txt", 0.100)], sd=0.0363,
                     fast=True, f_range_hz=(10.0, 1000.0), read_options=opts, models_for_spread=[])
    assert {"fs", "Re", "Qts", "Bl", "Mms", "Cms", "Vas", "SPL"} <= set(r.parameters)
    assert 38.0 < r["fs"] < 46.0  # the impedance peak of the free-air file is at about 42 Hz


def test_from_posterior_free_air_set():
    """The T/S set of a (short) posterior: the free-air names, intervals ordered, unconverged said."""
    from bayes_emt.inference.sampling import sample_posterior
    from bayes_emt.thiele_small import from_posterior

    sim = simulate_driver("I", deltas=(), seed=10, n_points=200)
    with pytest.warns(Warning):  # 200 steps do not meet the stopping rule: said, not hidden
        post = sample_posterior(sim.free, parse_model_spec("I"), seed=0, max_steps=200, progress=False)
    ts = from_posterior(post)
    assert set(ts.parameters) == {"fs", "Re", "Le", "Qms", "Qes", "Qts", "EBP"}
    for p in ts.parameters.values():
        assert p["ci90"][0] <= p["value"] <= p["ci90"][1]
    assert abs(ts["fs"] - sim.truth["fs"]) < 0.05 * sim.truth["fs"]
    assert post.converged or any(w["code"] == "not_converged" for w in ts.warnings)


def test_report_puts_ts_first_and_groups_warnings(tmp_path):
    """The report's first section is the T/S table (from ts.json); the same warning about several
    models is one entry listing them; the terminal formatter gives one line per distinct warning."""
    from bayes_emt.cli.commands._common import warning_lines
    from bayes_emt.report.render import render_report

    sim = simulate_driver("I+semi_inductance", deltas=(), seed=11, n_points=300)
    ts = thiele_small(sim.free, "I+semi_inductance", mms=sim.truth["Mms"], sd=sim.sd, fast=True,
                      models_for_spread=[])
    ts.save(tmp_path / "ts.json")
    msg = ("UD cannot describe these data: the residuals are up to 289 times the noise level; largest in "
           "10–40.38 Hz (62.83–253.7 rad/s); try: enclosure_port or second_resonance")
    fits = {m: {"model": "I", "parameters": {"zeta": 0.1, "omega0": 250.0, "phi": 50.0, "R0": 5.0,
                                            "L0": 1e-3},
                "rms_rel_residual": 0.01, "warnings": [{"code": "model_inadequate", "message": msg}]}
            for m in ("I", "II")}
    (tmp_path / "fits.json").write_text(json.dumps(fits))
    html = render_report(tmp_path)
    assert html.index("Thiele–Small parameters") < html.index('id="sec-data"')
    assert html.count("<code>model_inadequate</code>") == 1
    lines = warning_lines([{**w, "model": m} for m, r in fits.items() for w in r["warnings"]])
    assert lines == ["warning [model_inadequate] 10-40.4 Hz: residuals up to 289x the noise; try "
                     "enclosure_port, second_resonance (I, II)"]
