"""``bayes-emt simulate``: parameter file in, measurement file out (SPEC §5 tables as truth)."""

import json

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.cli import main
from bayes_emt.io import read_measurement
from bayes_emt.reference import PAPER_TABLES


def _params(tmp_path, name, rings=None, table=None):
    model = build_model(name, rings=rings)
    path = tmp_path / f"{name}.json"
    # the shape paramfile.read_param_file reads and `bayes-emt fit --json` writes
    path.write_text(json.dumps({"model": model.spec, "rings": model.rings, "n_turns": model.n_turns,
                                "parameters": dict(PAPER_TABLES[table or name])}))
    return path


def test_simulate_writes_what_it_says(tmp_path, capsys):
    params, out = _params(tmp_path, "UD"), tmp_path / "ud.csv"
    assert main(["simulate", "--params", str(params), "--out", str(out), "--noise", "0.002",
                 "--seed", "7", "--omega-min", "20", "--omega-max", "2e4", "--points", "300"]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out}" in text and "300 log-spaced points" in text and "20..2e+04 rad/s" in text
    assert "3.183..3183 Hz" in text and "noise 0.2 %" in text and "seed 7" in text
    meas = read_measurement(out)
    assert meas.n_points == 300
    assert meas.omega[0] == pytest.approx(20) and meas.omega[-1] == pytest.approx(2e4)
    truth = meas.meta["written_meta"]["truth"]
    assert truth == pytest.approx(PAPER_TABLES["UD"])
    # the same seed gives the same data as the library function
    again = simulate(build_model("UD"), PAPER_TABLES["UD"], meas.omega, noise=0.002, seed=7)
    np.testing.assert_array_equal(again.Y, meas.Y)


def test_simulate_noise_free_zma_matches_the_model(tmp_path, capsys):
    params, out = _params(tmp_path, "II"), tmp_path / "ii.zma"
    assert main(["simulate", "--params", str(params), "--out", str(out), "--noise", "0",
                 "--points", "50"]) == 0
    assert "no noise" in capsys.readouterr().out
    meas = read_measurement(out)
    model = build_model("II")
    exact = model.admittance(meas.omega, model.vector(PAPER_TABLES["II"]))
    np.testing.assert_allclose(meas.Y, exact, rtol=1e-8)  # .zma keeps 10 significant digits


def test_simulate_rings_for_ul(tmp_path, capsys):
    params = _params(tmp_path, "UL", table="UD")  # UL takes the UD parameters (SPEC §2)
    out = tmp_path / "ul.csv"
    assert main(["simulate", "--params", str(params), "--out", str(out), "--rings", "20", "--points", "40",
                 "--noise", "0"]) == 0
    assert "model UL(20)" in capsys.readouterr().out
    meas = read_measurement(out)
    assert meas.meta["written_meta"]["rings"] == 20
    model = build_model("UL", rings=20)
    np.testing.assert_array_equal(meas.Y, model.admittance(meas.omega, model.vector(PAPER_TABLES["UD"])))


@pytest.mark.parametrize("args, message", [
    (["--model", "I"], "holds model NL, but --model I was given"),
    (["--rings", "3"], "holds NL(5) parameters (P1..P5), so --rings 3 does not fit them"),
    (["--noise", "-1"], "noise must be a non-negative number"),
    (["--omega-min", "100", "--omega-max", "10"], "need 0 < omega_min < omega_max"),
])
def test_simulate_user_errors_exit_2(tmp_path, capsys, args, message):
    params = _params(tmp_path, "NL", rings=5)
    rc = main(["simulate", "--params", str(params), "--out", str(tmp_path / "x.csv"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("bayes-emt: error:") and message in err[0]
    assert not (tmp_path / "x.csv").exists()


def test_simulate_bad_parameter_file_and_output(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["simulate", "--params", str(bad), "--out", str(tmp_path / "x.csv")]) == 2
    assert "bad.json: line 1: invalid JSON" in capsys.readouterr().err
    params = _params(tmp_path, "I")
    assert main(["simulate", "--params", str(params), "--out", str(tmp_path / "x.xlsx")]) == 2
    assert "cannot write '.xlsx'" in capsys.readouterr().err
    assert main(["simulate", "--params", str(tmp_path / "none.json"), "--out", str(tmp_path / "x.csv")]) == 2
    assert "none.json: no such file" in capsys.readouterr().err
