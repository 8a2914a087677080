"""The diagnosis searches a dense sweep on at most ``per_decade`` points per decade (issue 23, speed):
the thinning rule (:meth:`Measurement.thin`) and what the diagnosis records of it."""

import json
import math

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.discovery import diagnose
from bayes_emt.discovery.diagnose import SEARCH_PER_DECADE
from bayes_emt.io.simulate import simulate
from bayes_emt.measurement import Measurement
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES


def _meas(omega):
    return Measurement(np.asarray(omega, float), 1.0 / (3.0 + 1j * 1e-3 * np.asarray(omega, float)),
                       meta={"source": "t"})


def test_a_dense_log_sweep_keeps_the_cap_and_its_ends():
    omega = np.geomspace(1e1, 1e5, 4001)  # 1000 per decade over 4 decades
    m = _meas(omega).thin(200)
    lw = np.log10(m.omega)
    assert m.omega[0] == omega[0] and m.omega[-1] == omega[-1]
    # every kept step is at least 1/200 decade (the last one may be shorter: the end is always kept)
    assert np.all(np.diff(lw)[:-1] >= 1 / 200 - 1e-12)
    # and at most one original step more than that (nothing is skipped beyond the rule)
    assert np.all(np.diff(lw)[:-1] <= 1 / 200 + 1 / 1000 + 1e-12)
    assert 4 * 200 - 5 <= m.n_points <= 4 * 200 + 2
    assert m.meta["thinned_from"] == 4001
    np.testing.assert_array_equal(m.Y, _meas(omega).Y[np.isin(omega, m.omega)])


def test_a_sparse_sweep_is_left_as_it_is_and_a_linear_one_keeps_its_low_end():
    sparse = _meas(np.geomspace(1e1, 1e5, 300))
    assert sparse.thin(200) is sparse and sparse.thin(None) is sparse and sparse.thin(0) is sparse
    lin = _meas(2 * math.pi * np.arange(10.0, 1000.5, 0.5))  # the LS10-44 run2 grid: 0.5 Hz steps
    m = lin.thin(200)
    f = m.f_hz
    # below ~43 Hz a 0.5 Hz step is more than 1/200 decade: every point stays
    assert np.array_equal(f[f < 40], lin.f_hz[lin.f_hz < 40])
    assert m.n_points < lin.n_points / 4
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="per_decade"):
            lin.thin(bad)


def test_the_diagnosis_of_a_dense_sweep_runs_on_the_thinned_points_and_says_so():
    model = parse_model_spec("UD")
    meas = simulate(model, PAPER_TABLES["UD"], np.geomspace(1e1, 1e5, 2000), noise=0.003, seed=11)
    # the given start alone (starts=()): the thinning, not the other starts' searches, is tested here
    d = diagnose(meas, model, max_rounds=1, workers=1, starts=())
    sp = d.search_points
    assert sp["n_points"] == 2000 and sp["per_decade"] == SEARCH_PER_DECADE
    assert sp["used"] == d.baseline_fit.n_points == d.final_fit.n_points < 2000
    rec = json.loads(d.to_json())
    assert rec["search_points"] == sp and type(d).from_json_dict(rec).search_points == sp
    assert any("searched on" in n for t in d.tables() for n in t.notes)
    full = diagnose(meas, model, max_rounds=1, workers=1, per_decade=None, starts=())
    assert full.search_points["used"] == 2000 == full.final_fit.n_points


def test_a_fit_of_the_whole_recording_is_polished_on_the_search_points():
    from bayes_emt.estimation.fitting import fit_admittance

    model = parse_model_spec("UD")
    meas = simulate(model, PAPER_TABLES["UD"], np.geomspace(1e1, 1e5, 2000), noise=0.003, seed=12)
    fit = fit_admittance(meas, model)
    d = diagnose(meas, fit=fit, max_rounds=1, workers=1, starts=())
    assert d.baseline_fit.n_points == d.search_points["used"] < 2000
    # the same physics on fewer points: the values agree within a few of the full fit's standard errors
    se = np.sqrt(np.diag(fit.cov_z))
    dz = np.abs(d.baseline_fit.z - fit.z)
    assert np.all(dz <= 5 * se * math.sqrt(2000 / d.search_points["used"]))


def test_the_command_line_takes_per_decade(tmp_path, capsys):
    model = parse_model_spec("UD")
    meas = simulate(model, PAPER_TABLES["UD"], np.geomspace(1e1, 1e5, 2000), noise=0.003, seed=13)
    from bayes_emt.io import write_measurement

    data = tmp_path / "dense.csv"
    write_measurement(meas, data)
    out = tmp_path / "d.json"
    # no wall-clock budget: the answer (and the exit status) must not depend on the machine's load
    assert main(["diagnose", str(data), "--model", "UD", "--max-rounds", "1", "--workers", "1",
                 "--per-decade", "100", "--time-budget", "0", "--json", str(out), "--quiet"]) == 0
    rec = json.loads(out.read_text())
    assert rec["search_points"]["per_decade"] == 100 and rec["search_points"]["used"] < 500
    assert main(["diagnose", str(data), "--per-decade", "-3"]) == 2
    assert "--per-decade" in capsys.readouterr().err
