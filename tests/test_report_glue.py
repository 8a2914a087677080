"""Acceptance: ``report DIR`` on a folder written by the individual commands (fit, sample, ts,
diagnose, shunt; no demo), under names of the user's choosing, shows each result: outputs are
found by their recorded kind, figures never overwrite one another, and the page renders in a
headless Chromium (skipped only when none is installed)."""

from __future__ import annotations

import pytest

from bayes_emt.cli import main
from bayes_emt.io import write_measurement
from bayes_emt.io.simulate import log_omega_grid, simulate
from bayes_emt.models import build_model
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.report.browser import dump_dom, find_chromium

SECTIONS = ("ts", "fits", "posterior", "shunt", "diagnosis")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("glue")
    data = write_measurement(simulate(build_model("I"), PAPER_TABLES["I"], log_omega_grid(10, 1e4, 150),
                                      noise=0.002, seed=3), d / "bench.zma")
    out = d / "results"
    out.mkdir()
    q = "--quiet"
    assert main(["fit", str(data), "--model", "I", "--json", str(out / "my_fit.json"), q]) == 0
    # a short chain: delivered and flagged (exit 1), enough for the report to show it
    assert main(["sample", str(data), "--model", "I", "--max-steps", "150", "--out", str(out / "chain.nc"),
                 "--json", str(out / "chain_summary.json"), "--plot", str(out), q]) == 1
    assert main(["ts", str(data), "--model", "I", "--fast", "--spread-models", "none",
                 "--json", str(out / "driver_ts.json"), "--plot", str(out), q]) == 0
    assert main(["diagnose", str(data), "--model", "I", "--max-rounds", "1", "--workers", "1",
                 "--time-budget", "0", "--json", str(out / "diag.json"), "--plot", str(out), q]) == 0
    assert main(["shunt", "--params", str(out / "my_fit.json"), "--json", str(out / "rc.json"),
                 "--plot", str(out), q]) == 0
    assert main(["report", str(out), q]) == 0
    return out


def test_every_command_output_is_shown_by_its_kind(folder):
    html = (folder / "report.html").read_text()
    for sid in SECTIONS:
        assert f'<section id="sec-{sid}" class="ran">' in html, sid
    assert "Not run: no fits.json" not in html
    # the T/S section draws the fit with its band from the saved curve; diagnose's and sample's
    # figures keep their own names beside the report's (no residuals.png was written by diagnose)
    assert 'data-figure="ts-fit"><img src="data:image/png;base64,' in html
    names = {p.name for p in folder.iterdir()}
    assert {"ts_fit.png", "diagnosis_residuals.png", "diagnosis_bode.png", "posterior_I_bode.png"} <= names
    assert "residuals.png" not in names
    assert 'data-figure="bode"><img' in html and 'data-figure="shunt"><img' in html
    assert 'data-figure="diagnosis-residuals"><img' in html


def test_a_second_output_of_one_kind_is_named_not_hidden(folder, tmp_path):
    import shutil

    copy = tmp_path / "two"
    shutil.copytree(folder, copy)
    shutil.copy(copy / "driver_ts.json", copy / "driver_ts_again.json")
    assert main(["report", str(copy), "--quiet"]) == 0
    html = (copy / "report.html").read_text()
    assert ("2 thiele_small outputs (driver_ts.json, driver_ts_again.json); the report shows "
            "driver_ts.json") in html


@pytest.mark.skipif(find_chromium() is None, reason="no Chromium found (apt-get install chromium, or set "
                                                    "BAYES_EMT_CHROMIUM)")
def test_the_glued_report_renders_in_headless_chromium(folder):
    dom = dump_dom(folder / "report.html")
    for sid in SECTIONS:
        assert f'id="sec-{sid}" class="ran"' in dom, sid
    assert dom.count('src="data:image/png;base64,') >= 6


def test_a_sample_netcdf_alone_makes_the_posterior_section(folder, tmp_path):
    import shutil

    only = tmp_path / "nc_only"
    only.mkdir()
    shutil.copy(folder / "chain.nc", only / "my_chain.nc")
    assert main(["report", str(only), "--quiet"]) == 0
    html = (only / "report.html").read_text()
    assert '<section id="sec-posterior" class="ran">' in html
    assert "R0" in html and 'data-figure="bode"><img' in html
    assert "did NOT converge" in html  # the 150-step chain's flag reaches the top of the page
    assert {p.name for p in only.iterdir()} == {"my_chain.nc", "report.html", "posterior_bode.png",
                                               "posterior_corner.png"}
