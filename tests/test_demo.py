"""The main job, ``bayes-emt demo --quick``, end to end on the bundled data: fits, evidence,
posterior, shunts, the diagnosis' recording, and the report, checked in a headless Chromium.
The chains are far too short to converge (a few hundred steps; NL(5) needs thousands): the demo must
say so, as a warning on top of the report, and still exit 0 because the chain completed (issue 24).
Convergence itself is the slow test
``test_posterior.py::test_paper_bench_nl5_converges_with_ess_1000``."""

import json
import warnings

import numpy as np
import pytest
from markupsafe import escape as html_escape

from bayes_emt.cli import main
from bayes_emt.errors import ConvergenceWarning
from bayes_emt.io.datasets import CONCEALED_BENCH_EFFECT, load_concealed_bench
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.report.browser import dump_dom, find_chromium, screenshot


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "run"
    import contextlib
    import io

    buf = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stdout(buf):
        warnings.simplefilter("ignore", ConvergenceWarning)
        # the diagnosis (minutes) is left to the slow test below
        rc = main(["demo", "--quick", "--out", str(out), "--max-steps", "120", "--seed", "3",
                   "--skip", "diagnose"])
    return rc, out, buf.getvalue()


def test_quick_demo_runs_the_chain_and_says_what_it_cut(demo):
    rc, out, text = demo
    # the exit-status table: a delivered result that is not to be trusted (an unconverged preferred
    # posterior) exits 1, and says why
    assert rc == 1 and "NOT CONVERGED" in text and "did not converge: exit code 1" in text
    expected = {"run.json", "fits.json", "comparison.json", "evidence.png", "posterior.nc", "posterior.json",
                "posterior_bode.png", "posterior_corner.png", "residuals.png", "shunts.json",
                "robust_shunt.json", "shunt_robust_gain.png", "report.html"}
    assert {p.name for p in out.iterdir()} >= expected
    fits = json.loads((out / "fits.json").read_text())
    assert list(fits) == ["I", "II", "NL"]
    # the bundled data are Table 5 NL(5) with 0.2 % noise: the NL fit is within 4 standard errors of
    # the truth, and the plain-inductance model is far worse than NL
    nl = fits["NL"]
    z = [abs(nl["parameters"][k] - v) / nl["stderr"][k] for k, v in PAPER_TABLES["NL"].items()]
    assert max(z) < 4, z
    assert nl["rms_rel_residual"] < 0.004 < 0.1 < fits["I"]["rms_rel_residual"]
    # evidence prefers the generating model by thousands of nats (measured ~16000 over II)
    cmp = json.loads((out / "comparison.json").read_text())
    assert cmp["best"] == "NL"
    post = json.loads((out / "posterior.json").read_text())
    assert post["model"] == "NL" and post["converged"] is False and post["n_steps"] == 120
    # issue 9: every fit carries its warnings; the adequate NL(5) fit none, model I (no eddy
    # currents) model_inadequate; the posterior's JSON carries the NL fit's, plus not_converged
    assert all(isinstance(f["warnings"], list) for f in fits.values())
    assert nl["warnings"] == [] and "model_inadequate" in [w["code"] for w in fits["I"]["warnings"]]
    assert [w["code"] for w in post["warnings"]] == ["not_converged"]
    assert "warning [model_inadequate]" in text  # one line per distinct warning (issue 22)
    # SPEC §5: the NL design attenuates by -24.7 dB (here from the fitted, not the printed, parameters)
    shunts = json.loads((out / "shunts.json").read_text())
    assert shunts["NL"]["evaluated_on_NL"]["attenuation_db"] == pytest.approx(-24.7, abs=0.1)
    run = json.loads((out / "run.json").read_text())
    assert any("III, UD and UL are left out" in c for c in run["cut"])
    assert any("did not converge" in w and "--quick" in w for w in run["warnings"])
    steps = {s["name"]: s for s in run["steps"]}
    assert steps["hankel"]["status"] == "skipped"
    assert steps["robust_shunt"]["status"] == "ran", steps["robust_shunt"]  # issue 12 is on main
    assert steps["diagnose"]["status"] == "skipped"
    rob = json.loads((out / "robust_shunt.json").read_text())
    assert rob["n_draws"] == 200 and {"nominal", "robust", "per_draw"} <= set(rob)
    import arviz as az

    dt = az.from_netcdf(out / "posterior.nc")
    assert np.all(np.isfinite(dt["posterior"]["R0"].values))
    for line in text.splitlines():  # outputs are listed with absolute paths (./run demo changes folder)
        if line.startswith("  ") and "kB)" in line:
            assert line.strip().startswith(str(out.resolve()))


def test_concealed_recording_hides_a_second_mode_that_the_paper_model_misses():
    """The bundled concealed-effect recording: its truth names the hidden mode, and an NL(5) fit
    (the model that generated the rest) leaves a local misfit at the mode, many noise widths
    (0.2 %) above the noise, while its overall rms residual stays near the noise: concealed."""
    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.models import build_model

    meas = load_concealed_bench()
    truth = meas.meta["written_meta"]["truth"]
    assert {k: truth[k] for k in CONCEALED_BENCH_EFFECT} == CONCEALED_BENCH_EFFECT
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_admittance(meas, build_model("NL"))
    r = np.abs(fit.model.admittance(meas.omega, fit.theta) - meas.Y) / np.abs(meas.Y)
    at = np.argmax(r)
    assert abs(meas.omega[at] / CONCEALED_BENCH_EFFECT["omega2"] - 1) < 0.05
    assert r[at] > 5 * 0.002 * np.sqrt(2)
    assert fit.rms_rel_residual < 0.005


def test_demo_report_states_the_missing_features_and_renders_in_chromium(demo, tmp_path):
    rc, out, _ = demo
    html = (out / "report.html").read_text()
    assert html.index('id="warnings"') < html.index('id="sec-data"')
    assert "the posterior did NOT converge" in html
    assert "What this run did not do" in html
    for sid in ("data", "fits", "evidence", "posterior", "shunt"):
        assert f'<section id="sec-{sid}" class="ran">' in html, sid
    run = json.loads((out / "run.json").read_text())
    for step in run["steps"]:
        if step["status"] == "unavailable":
            assert html_escape(step["detail"]) in html
    if find_chromium() is None:
        pytest.skip("no Chromium found (apt-get install chromium, or set BAYES_EMT_CHROMIUM)")
    from PIL import Image

    shot = screenshot(out / "report.html", tmp_path / "demo.png", width=1200, height=4000)
    img = np.asarray(Image.open(shot).convert("L"))
    ink = (img < 200).sum(axis=1) > 5  # rows with text or figure lines
    assert ink[:1000].mean() > 0.2 and ink.mean() > 0.2
    dom = dump_dom(out / "report.html")
    n_figs = html.count('<img src="data:image/png;base64,')
    assert n_figs >= 5 and dom.count('src="data:image/png;base64,') == n_figs


def test_a_failing_feature_step_is_recorded_and_the_rest_of_the_demo_goes_on(tmp_path, monkeypatch):
    """The robust shunt is a verb call (``be.robust_shunt``); when it fails (here: made to raise as a
    mis-merged build would), the step is recorded as failed with a one-line reason and a warning,
    never a traceback, and the report says so."""
    from types import SimpleNamespace

    from bayes_emt import api
    from bayes_emt.cli.commands import demo
    from bayes_emt.report import render_report

    def broken(*args, **kwargs):
        raise AttributeError("'Model' object has no attribute 'name'\nsecond line")

    monkeypatch.setattr(api, "robust_shunt", broken)
    d = demo._Demo(SimpleNamespace(quiet=True, verbose=False, out=str(tmp_path), seed=0))
    post = SimpleNamespace(model=SimpleNamespace(label="NL(5)"))
    demo._robust(d, post, None, demo.QUICK)
    (step,) = d.steps
    assert step["name"] == "robust_shunt" and step["status"] == "failed"
    assert step["detail"] == "AttributeError: 'Model' object has no attribute 'name'"
    assert d.warnings == ["robust_shunt failed: AttributeError: 'Model' object has no attribute 'name'"]
    (tmp_path / "run.json").write_text(json.dumps({"steps": d.steps, "warnings": d.warnings}))
    html = render_report(tmp_path)
    assert '<section id="sec-robust" class="not-run">' in html
    assert html_escape("robust_shunt failed: AttributeError: 'Model' object has no attribute 'name'") in html


def test_the_demo_calls_verbs_not_other_commands():
    # issue 21: the demo is a thin layer over the public verbs; it runs no other command's argparse
    import ast
    from pathlib import Path

    from bayes_emt.cli.commands import demo

    tree = ast.parse(Path(demo.__file__).read_text())
    froms = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    # from the commands package only the shared helpers (_common) and the demo's own time budget
    # (_demo_budget, used by no other command); nothing from another command
    assert {n.module for n in froms if n.level == 1} == {"_common", "_demo_budget"}
    assert "argparse" not in {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    names = {a.name for n in froms for a in n.names}
    assert "api" in names


@pytest.mark.slow
def test_quick_demo_report_shows_the_diagnosis_finding_on_the_concealed_recording(tmp_path):
    """Acceptance 1 of issue 15: the demo's report shows a diagnosis finding on the bundled
    concealed-effect recording (a second mode at omega2 = 2500 rad/s). Measured (discovery branch
    merged into ux, scratch run): second_resonance named, band 2019-3015 rad/s, omega2 = 2500 rad/s,
    log Z up by 231 nats; the diagnosis alone took 156 s of CPU."""
    import importlib.util

    if importlib.util.find_spec("bayes_emt.cli.commands.diagnose") is None:
        pytest.skip("bayes-emt diagnose (issue 13) is not in this build")
    out = tmp_path / "run"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        main(["demo", "--quick", "--out", str(out), "--max-steps", "120", "--quiet"])
    diag = json.loads((out / "diagnosis.json").read_text())
    w2 = CONCEALED_BENCH_EFFECT["omega2"]
    hits = [f for f in diag["findings"] if f["band_rad_s"][0] <= w2 <= f["band_rad_s"][1]]
    assert hits and hits[0]["physics"] == "second_resonance", diag["findings"]
    html = (out / "report.html").read_text()
    assert '<section id="sec-diagnosis" class="ran">' in html
    assert html_escape(hits[0]["explanation"][:40]) in html


@pytest.mark.parametrize("concealed", [False, True])
def test_demo_with_data_diagnoses_that_recording_unless_another_is_named(tmp_path, monkeypatch, concealed):
    """``demo --data FILE`` diagnoses FILE (the user's own recording), not the bundled
    concealed-effect recording; ``--concealed OTHER`` diagnoses OTHER. The chain's steps are stubbed:
    only which recording reaches the diagnosis is tested."""
    from bayes_emt.api import read
    from bayes_emt.cli.commands import demo as demo_cmd
    from bayes_emt.io import write_measurement
    from bayes_emt.io.simulate import simulate
    from bayes_emt.models import parse_model_spec

    def rec(name, r0):
        m = simulate(parse_model_spec("UD"), {**PAPER_TABLES["UD"], "R0": r0}, np.geomspace(1e2, 1e5, 60))
        return write_measurement(m, tmp_path / name)

    data, other = rec("mine.csv", 7.0), rec("other.csv", 9.0)
    seen = {}
    monkeypatch.setattr(demo_cmd, "_fits", lambda d, meas, cfg, truth: {})
    monkeypatch.setattr(demo_cmd, "_hankel", lambda d, meas, cfg: None)
    monkeypatch.setattr(demo_cmd, "_evidence", lambda d, meas, fits, cfg: ("UD", None))
    monkeypatch.setattr(demo_cmd, "_posterior", lambda d, cmp, preferred, fits: None)
    monkeypatch.setattr(demo_cmd, "_shunts", lambda d, fits, preferred: None)
    monkeypatch.setattr(demo_cmd, "_diagnose", lambda d, meas, model: seen.setdefault("meas", meas))
    monkeypatch.setattr(demo_cmd, "build_report", lambda *a, **k: None, raising=False)
    args = ["demo", "--data", str(data), "--out", str(tmp_path / "run"), "--skip", "robust_shunt",
            "--quiet"] + (["--concealed", str(other)] if concealed else [])
    try:
        main(args)
    except Exception:  # noqa: BLE001 - the stubbed chain may not write a report; the diagnosis ran before
        pass
    assert "meas" in seen, "the diagnosis step was not reached"
    want = other if concealed else data
    assert str(seen["meas"].source).endswith(want.name)
    np.testing.assert_allclose(seen["meas"].Y, read(want).Y, rtol=1e-12)  # its values, not a namesake's


def test_demo_diagnosis_prints_the_final_model_and_what_the_final_comparison_kept(tmp_path, monkeypatch,
                                                                                    capsys):
    """The diagnosis step says which model it ends at and the final comparison's line: on
    koan_tweeter.zma a quick demo starts from NL(5), finds nothing, and the final comparison keeps UD
    (NL(5)'s evidence fails); the demo printed only "no significant mismatch found". The search is
    stubbed with such a diagnosis."""
    from types import SimpleNamespace

    from bayes_emt import api as be
    from bayes_emt.cli.commands import demo as demo_cmd
    from bayes_emt.discovery.diagnose import Diagnosis
    from bayes_emt.estimation.fitting import fit_admittance
    from bayes_emt.io.simulate import simulate
    from bayes_emt.models import parse_model_spec

    ud = parse_model_spec("UD")
    meas = simulate(ud, PAPER_TABLES["UD"], np.geomspace(1e1, 1e5, 120), noise=0.002, seed=0)
    start, final = fit_admittance(meas, parse_model_spec("III")), fit_admittance(meas, ud)
    line = ("final comparison: UD (log Z 1630.4) is kept over III (log Z 1568.5), by one evidence on the "
            "same data")
    diag = Diagnosis(meas.source, start, final, (), (), warnings=(line,))
    monkeypatch.setattr(be, "fit", lambda m, model: start)
    monkeypatch.setattr(be, "diagnose", lambda *a, **k: diag)
    args = SimpleNamespace(quiet=False, seed=0, quick=True, out=str(tmp_path))
    demo_cmd._diagnose(demo_cmd._Demo(args), meas, "III")
    out = capsys.readouterr().out
    assert "no significant mismatch found" in out
    assert "  " + line in out
    assert "final model: UD (the search started from III)" in out
