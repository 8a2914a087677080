"""The diagnosis in the driver's terms (issue 34, acceptance 2): at most 20 lines by default, box terms
(fb in Hz) from the final fit, a ring ladder as its coil's Le and loss, no statistics unless asked."""

import json
import math
import sys
from pathlib import Path

import pytest

from bayes_emt.cli import main
from bayes_emt.discovery.diagnose import Diagnosis
from bayes_emt.discovery.summary import MAX_LINES, box_line, coil_line, summary_lines, ts_values
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io import write_measurement
from bayes_emt.models import parse_model_spec

sys.path.insert(0, str(Path(__file__).parent))
from vented_box import VENTED_CASES, simulate_vented_box  # noqa: E402

STORED = Path(__file__).resolve().parents[1] / "scripts" / "results" / "discovery_realdata"


@pytest.fixture(scope="module")
def vented():
    """Vented-box case 1 (fb 42 Hz, Qb 10) fitted with UD + a port from the truth: a diagnosis record
    whose final fit has the port, without the search."""
    driver, fb, _alpha, qb = VENTED_CASES[1]
    meas = simulate_vented_box(1, noise=0.003, seed=1).thin(60)
    start = fit_admittance(meas, parse_model_spec("UD"))
    init = {**driver, "Lb": driver["phi"] ** 2 / driver["omega0"] ** 2 / 1.5, "omegab": 2 * math.pi * fb,
            "zetab": 1 / (2 * qb)}
    final = fit_admittance(meas, parse_model_spec("UD+enclosure_port"), initial=init, warm=True)
    return meas, Diagnosis("vented box case 1", start, final, (), ()), fb, qb


def test_a_vented_box_prints_fb_in_hz_from_the_final_fit(vented):
    _meas, d, fb, qb = vented
    line = box_line(d.final_fit)
    got = float(line.split("fb ")[1].split(" Hz")[0])
    assert got == pytest.approx(d.final_fit.parameters["omegab"] / (2 * math.pi), rel=1e-3)
    assert got == pytest.approx(fb, rel=0.02)  # the simulated tuning, 0.3 % noise
    assert f"Qb {1 / (2 * d.final_fit.parameters['zetab']):.3g}" in line
    assert "the driver's resonance in the box" in line and "impedance peaks at" in line
    lines = summary_lines(d)
    assert len(lines) <= MAX_LINES and any(x.startswith("vented box (final fit): fb ") for x in lines)
    assert not any("nats" in x or "chi2" in x for x in lines)  # statistics are --verbose's


def test_a_sealed_setup_prints_the_in_box_resonance(vented):
    _meas, d, _fb, _qb = vented
    sealed = Diagnosis("sealed", d.baseline_fit, d.baseline_fit, (), ())
    line = box_line(sealed.final_fit, "sealed")
    fc = ts_values(sealed.final_fit)["fs"]
    assert line.startswith(f"sealed box (final fit): the driver's in-box resonance fc {fc:.4g} Hz, Qtc ")
    assert box_line(sealed.final_fit) == ""  # free air or unknown: no box terms


def test_a_ring_ladder_reads_as_its_coil_inductance_and_loss():
    model = parse_model_spec("NL(2)")
    v = {"zeta": 0.1, "omega0": 280.0, "phi": 50.0, "R0": 6.0, "Pg": 5e-9, "P1": 8e-9, "P2": 8e-9,
         "R1": 2e-5, "R2": 3e-4}
    from bayes_emt.estimation.results import FitResult

    fit = FitResult(model, model.vector({k: v[k] for k in model.names}), None, 0.0, 0.0, 10)
    line = coil_line(fit)
    assert line.startswith("coil (final fit) at 100, 1000, 10000 Hz: Le ") and "mH" in line and "ohm" in line
    assert "Pg" not in line and "P1" not in line  # the raw ladder stays in the JSON
    # a recording up to 1 kHz: no value at 10 kHz (no extrapolation)
    assert coil_line(fit, (10.0, 1000.0)).startswith("coil (final fit) at 100, 1000 Hz: Le ")
    assert coil_line(FitResult(parse_model_spec("I"), parse_model_spec("I").vector(
        {"zeta": 0.1, "omega0": 280.0, "phi": 50.0, "R0": 6.0, "L0": 5e-4}), None, 0.0, 0.0, 10)) == ""


@pytest.mark.parametrize("name", ["dayton_LS10-44.zma", "dayton_LS10-44_freeair_run2.txt",
                                  "dayton_LS10-44_added100g_run2.txt", "koan_mid_sealed.zma",
                                  "koan_tweeter.zma", "seas_E0018_freeair.zma", "joint_pair.json"])
def test_the_stored_real_diagnoses_read_in_at_most_20_lines(name):
    # the stored diagnoses of the real recordings (scripts/discovery_realdata.py), with the joint
    # check of the LS10-44 pair: the header line and the summary within 20
    rec = json.loads((STORED / (name if name.endswith(".json") else name + ".json")).read_text())
    d = Diagnosis.from_json_dict(rec.get("diagnosis", rec))
    lines = summary_lines(d, max_lines=MAX_LINES - 1)
    assert 2 <= len(lines) <= MAX_LINES - 1
    assert lines[0].startswith(f"start {d.baseline_model} ") and d.final_model in lines[0]
    assert lines[1].startswith("Thiele-Small values of the final fit: fs ")
    assert len([x for x in lines if x.startswith("finding ")]) == len(d.findings)


@pytest.mark.slow
def test_diagnose_prints_fb_of_the_final_fit_in_at_most_20_lines(tmp_path, capsys):
    meas = simulate_vented_box(1, noise=0.003, seed=1).thin(100)
    data = write_measurement(meas, tmp_path / "vented.csv")
    out = tmp_path / "d.json"
    main(["diagnose", str(data), "--setup", "vented", "--workers", "1", "--time-budget", "0",
          "--json", str(out)])
    text = capsys.readouterr().out.splitlines()
    rec = json.loads(out.read_text())
    body = [x for x in text if not x.startswith("wrote ")]
    assert len(body) <= MAX_LINES
    assert "enclosure_port" in rec["final_model"]
    fb = rec["final_fit"]["parameters"]["omegab"] / (2 * math.pi)
    assert any(x.startswith(f"vented box (final fit): fb {fb:.4g} Hz") for x in body)
