"""The T/S set in batch's summary (issue 22: "the same T/S section in ... batch's summary"): fs,
Re, Qms, Qes, Qts per recording in summary.csv / .html / .json, from the fit (and from the
posterior when sampled), without a Dask cluster (process_file and write_summary directly).

Truth: the paper's Table 1 model I (bayes_emt.reference.PAPER_TABLES), whose free-air T/S set is
fs = ω0/2π, Re = R0, Qms = 1/(2ζ) (SPEC §8), simulated on 120 points with 0.2 % noise."""

from __future__ import annotations

import csv
import json
import math

import pytest

from bayes_emt.batch import BatchSettings, find_inputs, process_file
from bayes_emt.batch.summary import write_summary
from bayes_emt.io import write_measurement
from bayes_emt.io.simulate import log_omega_grid, simulate
from bayes_emt.models import build_model
from bayes_emt.reference import PAPER_TABLES


def _recording(folder, seed=0):
    folder.mkdir(parents=True, exist_ok=True)
    write_measurement(simulate(build_model("I"), PAPER_TABLES["I"], log_omega_grid(10, 1e4, 120), noise=0.002,
                               seed=seed), folder / "rec.zma")
    return folder


def test_fit_job_summary_has_the_ts_set_with_units_and_intervals(tmp_path):
    data = _recording(tmp_path / "data")
    out = tmp_path / "out"
    inp = find_inputs(data)[0]
    settings = BatchSettings(jobs=("fit",), model="I")
    o = process_file(inp, out / inp.name, settings)
    assert o.status == "done", o.error
    p = PAPER_TABLES["I"]
    s = o.summary
    # 0.2 % noise on 120 points: the fit recovers fs and Re to 0.5 %, Qms to 5 %
    assert s["fs_hz"] == pytest.approx(p["omega0"] / (2 * math.pi), rel=0.005)
    assert s["Re_ohm"] == pytest.approx(p["R0"], rel=0.005)
    assert s["Qms"] == pytest.approx(1 / (2 * p["zeta"]), rel=0.05)
    # medians of draws: Qts = Qms Qes/(Qms + Qes) holds per draw, for the medians to 1 %
    assert s["Qts"] == pytest.approx(s["Qms"] * s["Qes"] / (s["Qms"] + s["Qes"]), rel=0.01)
    assert s["ts_from"] == "fit"
    for name in ("fs", "Re", "Qms", "Qes", "Qts"):
        lo, hi = s["ts"][name]["ci90"]
        assert lo <= s["ts"][name]["value"] <= hi
    assert s["ts"]["fs"]["unit"] == "Hz" and s["ts"]["Re"]["unit"] == "ohm"

    write_summary([inp], out, jobs=settings.jobs, model=settings.model)
    with open(out / "summary.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    for header in ("fs [Hz]", "Re [ohm]", "Qms [1]", "Qes [1]", "Qts [1]", "T/S from"):
        assert row[header], header
    assert float(row["fs [Hz]"]) == pytest.approx(s["fs_hz"], rel=1e-3)
    html = (out / "summary.html").read_text()
    assert "fs [Hz]" in html and "Qts [1]" in html
    rec = json.loads((out / "summary.json").read_text())  # strict JSON (no NaN): json.loads accepts
    assert rec["columns"]["fs_hz"] == "fs [Hz]"
    row = rec["rows"][0]
    lo, hi = row["ts"]["Qts"]["ci90"]
    assert row["status"] == "done" and lo <= row["Qts"] <= hi


def test_sample_job_summary_takes_the_posterior_ts(tmp_path):
    data = _recording(tmp_path / "data", seed=1)
    inp = find_inputs(data)[0]
    o = process_file(inp, tmp_path / "out" / inp.name, BatchSettings(jobs=("fit", "sample"), model="I",
                                                                      max_steps=300))
    assert o.status == "done", o.error
    assert o.summary["ts_from"] == "posterior"
    # the posterior median of fs sits within 0.5 % of the truth whatever the short run's mixing
    assert o.summary["fs_hz"] == pytest.approx(PAPER_TABLES["I"]["omega0"] / (2 * math.pi), rel=0.005)


def test_from_fit_without_covariance_gives_points_and_says_so(tmp_path):
    import dataclasses

    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.thiele_small import from_fit, read_thiele_small

    meas = simulate(build_model("I"), PAPER_TABLES["I"], log_omega_grid(10, 1e4, 120), noise=0.002, seed=2)
    fit = fit_admittance(meas, build_model("I"))
    bare = from_fit(dataclasses.replace(fit, cov_z=None))
    assert bare.parameters["fs"]["ci90"] is None and bare.warnings[0]["code"] == "no_covariance"
    assert bare["fs"] == pytest.approx(PAPER_TABLES["I"]["omega0"] / (2 * math.pi), rel=0.005)
    assert "no intervals" in bare.summary()
    back = read_thiele_small(bare.save(tmp_path / "ts.json"))
    assert back.parameters == bare.parameters
    # seeded: the same fit gives the same intervals
    assert from_fit(fit, seed=3).parameters == from_fit(fit, seed=3).parameters
