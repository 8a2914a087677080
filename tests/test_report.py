"""The HTML report: rendered from a run folder's saved outputs (JSON in the schemas of issues 11, 12
and 13, PNG figures), every section present when its output exists and a plain "not run" when not,
warnings on top, bad files reported instead of raised, and the page checked in a real headless
Chromium (screenshot pixels and the DOM after rendering)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.report import build_report, render_report
from bayes_emt.report.browser import BrowserError, dump_dom, find_chromium, screenshot

# one solid colour per figure, so that the screenshot shows which figures the browser drew
COLOURS = {"residuals.png": (255, 0, 255), "evidence.png": (0, 200, 200), "posterior_bode.png": (250, 120, 0),
           "shunt_robust_gain.png": (0, 0, 255), "diagnosis_residuals.png": (0, 160, 0)}
FIG_W, FIG_H = 320, 140


def _png(path, rgb):
    from PIL import Image

    Image.new("RGB", (FIG_W, FIG_H), rgb).save(path)


def _write(folder, name, rec):
    (folder / name).write_text(json.dumps(rec))


@pytest.fixture
def run_dir(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    _write(d, "run.json", {
        "title": "synthetic run", "cut": ["nothing was cut"], "total_seconds": 12.0,
        "data": [{"source": "bench.csv", "role": "main chain", "n_points": 2000, "omega_min": 10.0,
                  "omega_max": 1e5, "f_min_hz": 1.5915, "f_max_hz": 15915.0, "simulated_from": "NL",
                  "noise_rel": 0.002}],
        "warnings": ["a demo-level warning"], "diagnosed": "concealed.csv",
        "steps": [{"name": "fit", "status": "ran", "detail": "", "seconds": 1.0}]})
    _write(d, "fits.json", {
        "I": {"model": "I", "parameters": {"zeta": 0.00755, "omega0": 50.78, "phi": 1.64, "R0": 2.905,
                                           "L0": 3.366e-3},
              "stderr": {"zeta": 1.9e-3, "omega0": 0.08, "phi": 0.12, "R0": 0.02, "L0": 2.4e-5},
              "units": {"zeta": "1", "omega0": "rad/s", "phi": "N/A/kg^.5", "R0": "ohm", "L0": "H"},
              "rms_rel_residual": 0.3015, "success": True, "warnings": [{"code": "misfit",
                                                                         "message": "model I misfits"}]},
        "II": {"model": "II", "parameters": {"zeta": 0.0078, "omega0": 50.78, "phi": 1.661, "R0": 2.85,
                                             "L0": 3.39e-3, "Rmu": 214.7},
               "stderr": {}, "units": {"Rmu": "ohm"}, "rms_rel_residual": 0.2277, "success": True}})
    _write(d, "comparison.json", {
        "models": [{"name": "I", "n_params": 7, "log_evidence": 11049.75, "log_evidence_err": 0.54,
                    "by_method": {"bridge": {"log_evidence": 11049.75, "err": 0.54}}, "elpd_loo": 10159.0,
                    "elpd_loo_se": 74.3, "evidence_seconds": 26.0},
                   {"name": "II", "n_params": 8, "log_evidence": 12169.17, "log_evidence_err": 0.44,
                    "by_method": {"bridge": {"log_evidence": 12169.17, "err": 0.44}}, "elpd_loo": None,
                    "elpd_loo_se": None, "evidence_seconds": 25.0}],
        "best": "II", "best_verdict": "very strong against the runner-up I (ln B = 1119.42 nats)",
        "bayes_factor_details": {"I/II": {"log_bayes_factor": -1119.42, "err": 0.7, "verdict": "very strong",
                                          "favours": "II"}},
        "scale": "Kass & Raftery (1995)", "warnings": ["evidence warning"]})
    _write(d, "posterior.json", {
        "model": "II", "rings": None, "converged": False, "message": "not converged within 300 steps",
        "n_steps": 300, "tau_max": 26.0, "n_walkers": 32, "n_draws_kept": 1000, "seed": 0, "wall_time_s": 9.0,
        "parameters": {"R0": {"median": 2.85, "q05": 2.84, "q95": 2.86, "ess": 600, "tau": 20,
                              "unit": "ohm"}},
        "derived": {}})
    _write(d, "shunts.json", {"II": {"Rs": -2.7328, "Cs": 0.1374, "attenuation_db": -28.34,
                                     "evaluated_on_I": {"attenuation_db": -20.0, "stable": False,
                                                        "stability_margin": -0.168}}})
    # issue 12's schema
    _write(d, "robust_shunt.json", {
        "nominal": {"Rs": -2.3957, "Cs": 0.08122,
                    "attenuation_db": {"median": -24.6, "q05": -24.9, "q95": -23.1},
                    "p_unstable": 0.004, "p_unstable_ci": [0.001, 0.01],
                    "stability_margin_ohm": 0.0094, "r0_uncertainty_ohm": 0.0231},
        "robust": {"Rs": -2.3801, "Cs": 0.0831,
                   "attenuation_db": {"median": -24.4, "q05": -24.7, "q95": -23.9},
                   "p_unstable": 0.0, "p_unstable_ci": [0.0, 0.0007],
                   "stability_margin_ohm": 0.0251, "r0_uncertainty_ohm": 0.0231,
                   "qts_damped": {"median": 0.762, "q05": 0.755, "q95": 0.770},
                   "damped_resonance_hz": {"median": 37.23, "q05": 37.09, "q95": 37.36},
                   "resonance_peak_reduction_db": {"median": 13.75, "q05": 13.57, "q95": 13.93},
                   "p_unstable_bound": {"epsilon": 0.001, "confidence": 0.95, "draws_needed": 2995,
                                        "shown": False, "per_model": {"NL(5)": {
                                            "n_checked": 1480, "n_unstable": 0, "upper_bound": 0.00202}}}},
        "driver": {"qts": {"median": 0.501, "q05": 0.496, "q95": 0.506},
                   "resonance_hz": {"median": 44.96, "q05": 44.54, "q95": 45.31},
                   "qms": {"median": 4.83, "q05": 4.72, "q95": 4.95},
                   "fs_hz": {"median": 34.02, "q05": 33.9, "q95": 34.1}},
        "per_draw": {"Rs": {"median": -2.39, "q05": -2.40, "q95": -2.38},
                     "Cs": {"median": 0.081, "q05": 0.080, "q95": 0.083},
                     "attenuation_db": {"median": -24.7, "q05": -24.9, "q95": -24.5}},
        "n_draws": 1000, "models": [{"label": "NL(5)", "weight": 1.0}],
        "why": {"text": "the robust Rs moved away from the stability boundary"}, "warnings": []})
    # issue 13's schema
    _write(d, "diagnosis.json", {
        "baseline_model": "NL", "final_model": "NL+second_resonance",
        "rms_rel_residual": {"baseline": 0.00305, "final": 0.00282},
        "findings": [{"physics": "second_resonance", "band_rad_s": [2300.0, 2700.0],
                      "band_hz": [366.1, 429.7],
                      "delta_log_evidence": 85.0, "chi2_band_before": 1520.0, "chi2_band_after": 98.0,
                      "identifiable": True,
                      # the layout the discovery branch writes: added terms and moved parameters
                      "parameters": {"added": {"omega2": {"value": 2500.0, "stderr": 2.3, "unit": "rad/s"},
                                               "zeta2": {"value": 0.0161, "stderr": 0.0014, "unit": "1"}},
                                     "moved": {"R0": {"before": 2.5593, "after": 2.5595,
                                                      "relative_change": 7.8e-05}},
                                     "L_extra": 1.5e-3},
                      "explanation": "a second mode at 398 Hz explains the swing around 400 Hz"}],
        "unexplained": [{"band_rad_s": [60000.0, 90000.0], "description": "a smooth phase trend"}],
        "warnings": [{"code": "w1", "message": "a diagnosis warning"}]})
    for name, rgb in COLOURS.items():
        _png(d / name, rgb)
    return d


def test_every_section_renders_from_its_saved_output_with_units_and_warnings_on_top(run_dir):
    html = render_report(run_dir)
    for sid in ("data", "fits", "evidence", "posterior", "shunt", "robust", "diagnosis"):
        assert f'<section id="sec-{sid}" class="ran">' in html, sid
    # warnings come before every section, from every output that carries them
    first = html.index('id="sec-data"')
    warn = html.index('id="warnings"')
    assert warn < first
    for msg in ("a demo-level warning", "model I misfits", "evidence warning", "a diagnosis warning",
                "the posterior did NOT converge"):
        assert warn < html.index(msg) < first, msg
    # numbers carry units; frequencies say Hz and rad/s
    assert "R0 [Ω]" in html and "omega0 [rad/s]" in html and "zeta [1]" in html
    assert "366.1–429.7 Hz (2300–2700 rad/s)" in html
    assert "6e+04–9e+04 rad/s" in html  # the unexplained band, given in rad/s only, shown in both units
    assert "9549–1.432e+04 Hz" in html
    assert "85.0 nats" in html and "2500 rad/s ± 2.3 rad/s" in html and "0.0161 ± 0.0014" in html
    assert "2.5593 Ω → 2.5595 Ω (+0.0078 %)" in html  # R0's unit from fits.json
    assert "<th>L_extra</th>" in html
    assert "a second mode at 398 Hz explains the swing around 400 Hz" in html
    assert "-1119.42 ± 0.70" in html and "very strong" in html
    assert "<b class=\"bad\">unstable</b>" in html  # the II design evaluated on I
    # the robust shunts' stability margins beside R0's uncertainty; the nominal's is below it
    assert "stability margin [Ω]" in html
    assert re.search(r'<td class="warn" title="the margin is below R0\'s uncertainty">0.0094</td>'
                     r"<td>0.0231</td>", html)
    assert re.search(r"<td>0.0251</td><td>0.0231</td>", html)
    # what the shunt does to the driver (Q, resonance [Hz], peak reduction [dB], 90 % intervals) and
    # whether P(unstable) <= epsilon was shown
    assert "<th>resonance [Hz]</th><th>Q</th><th>peak reduction [dB]</th>" in html
    assert "Qts 0.501 (0.496 – 0.506)" in html and "Qms 4.83 (4.72 – 4.95)" in html
    assert "Qts&#39; 0.762 (0.755 – 0.77)" in html and "13.75 (13.57 – 13.93)" in html
    assert "P(unstable) ≤ 0.001 is not shown" in html and "needs 2995 such draws" in html
    # every figure embedded, none linked
    assert len(re.findall(r'<img src="data:image/png;base64,', html)) == len(COLOURS)
    assert not re.search(r'<img src="(?!data:)', html)


def test_absent_outputs_say_plainly_that_the_step_was_not_run(tmp_path):
    d = tmp_path / "empty"
    d.mkdir()
    html = render_report(d)
    for sid in ("fits", "evidence", "posterior", "robust", "diagnosis"):
        assert f'<section id="sec-{sid}" class="not-run">' in html, sid
    assert "Not run: no robust_shunt.json in this folder" in html
    assert "Not run: no diagnosis.json in this folder" in html
    assert "No warnings" in html
    # the demo's own reason wins over the generic one
    (d / "run.json").write_text(json.dumps({"steps": [{"name": "diagnose", "status": "unavailable",
                                                        "detail": "issue 13 is not in this build"}]}))
    assert "Not run: issue 13 is not in this build." in render_report(d)


def test_an_unreadable_output_is_a_warning_not_a_traceback(run_dir):
    (run_dir / "diagnosis.json").write_text("{not json")
    (run_dir / "evidence.png").write_text("not an image")
    html = render_report(run_dir)
    assert "diagnosis.json: could not be read as JSON" in html
    assert "evidence.png: not a PNG or SVG image" in html
    assert '<section id="sec-diagnosis" class="not-run">' in html


def test_report_command_writes_the_page_and_rejects_bad_arguments(run_dir, tmp_path, capsys):
    assert main(["report", str(run_dir)]) == 0
    assert (run_dir / "report.html").read_text().startswith("<!DOCTYPE html>")
    assert main(["report", str(tmp_path / "nowhere")]) == 2
    assert "no such run folder" in capsys.readouterr().err
    assert main(["report", str(run_dir), "--out", str(run_dir / "fits.json")]) == 2
    assert "must be an .html file" in capsys.readouterr().err
    assert json.loads((run_dir / "fits.json").read_text())["I"]["model"] == "I"  # input untouched


def _rows_with(img: np.ndarray, rgb, tol: int = 6, min_run: int = FIG_W // 2) -> np.ndarray:
    """Screenshot rows holding a horizontal run of at least ``min_run`` pixels of colour ``rgb``."""
    hit = np.all(np.abs(img[:, :, :3].astype(int) - np.array(rgb)) <= tol, axis=2)
    return np.flatnonzero(hit.sum(axis=1) >= min_run)


needs_chromium = pytest.mark.skipif(find_chromium() is None,
                                    reason="no Chromium found (apt-get install chromium, or set "
                                           "BAYES_EMT_CHROMIUM); .ci/run installs it")


@needs_chromium
def test_the_report_renders_in_headless_chromium(run_dir, tmp_path):
    from PIL import Image

    page = build_report(run_dir)
    shot = screenshot(page, tmp_path / "shot.png", width=1200, height=7000)
    img = np.asarray(Image.open(shot).convert("RGB"))
    assert img.shape[:2] == (7000, 1200)
    # every embedded figure was decoded and drawn at its own size (FIG_H rows of its colour), in the
    # order of the page: fits' residuals, evidence chart, Bode bands, robust gain, diagnosis residuals
    tops = []
    for name, rgb in COLOURS.items():
        rows = _rows_with(img, rgb)
        assert abs(rows.size - FIG_H) <= 2, (name, rows.size)
        assert np.all(np.diff(rows) == 1), name  # one contiguous block
        tops.append(rows[0])
    assert tops == sorted(tops)
    # the warnings box (background #fff4e5) is drawn above the first figure
    warn_rows = _rows_with(img, (0xFF, 0xF4, 0xE5), tol=2, min_run=600)
    assert warn_rows.size > 50 and warn_rows[-1] < tops[0]
    # the DOM after rendering: every section, the finding's verdict, the images' data URIs
    dom = dump_dom(page)
    assert dom.count('class="ran"') >= 7
    assert "a second mode at 398 Hz explains the swing around 400 Hz" in dom
    assert dom.count('src="data:image/png;base64,') == len(COLOURS)


def test_browser_errors_are_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv("BAYES_EMT_CHROMIUM", str(tmp_path / "no-such-browser"))
    assert find_chromium() is None
    with pytest.raises(BrowserError, match="no Chromium found"):
        screenshot(tmp_path / "x.html", tmp_path / "x.png")
