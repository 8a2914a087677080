"""``bayes-emt demo --time-budget``: a step cut by the budget is named (one line, the report's
warnings, its list of what the run did not do) and the report is still written; the emcee chain
stops at its deadline with a valid, shorter chain; the samplers print progress lines when the
output is not a terminal."""

import contextlib
import io
import json
import time
import warnings

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.cli import main
from bayes_emt.cli.commands._demo_budget import SHARES, Budget, budget_seconds
from bayes_emt.errors import ConvergenceWarning
from bayes_emt.inference import sampling
from bayes_emt.inference.sampling import sample_posterior
from bayes_emt.reference import PAPER_TABLES


def test_the_shares_cover_the_budget_and_deadlines_follow_the_order():
    assert sum(f for _, f in SHARES) == pytest.approx(1.0, abs=1e-12)
    b = Budget(300.0, start=1000.0)
    ends = [b.deadline(name) for name, _ in SHARES]
    assert ends == sorted(ends) and ends[-1] == pytest.approx(1300.0)
    assert b.share("evidence") == pytest.approx(300.0 * dict(SHARES)["evidence"])
    none = Budget(0)
    assert none.total is None and none.deadline("fit") is None and not none.over("diagnose")


@pytest.mark.parametrize("bad", ["-1", "abc", "inf", "nan"])
def test_a_bad_time_budget_is_refused_in_one_line(bad):
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match="--time-budget"):
        budget_seconds(bad)


def test_emcee_stops_at_its_deadline_with_a_valid_chain_and_says_so(monkeypatch):
    model = build_model("I")
    meas = simulate(model, PAPER_TABLES["I"], np.geomspace(10, 1e5, 150), noise=0.002, seed=3)
    monkeypatch.setattr(sampling, "PROGRESS_EVERY_S", 0.0)
    lines = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        # a deadline already past: the chain stops at the first block boundary allowed
        post = sample_posterior(meas, model, seed=1, progress=lines.append, deadline=time.monotonic())
    assert post.n_steps == sampling.MIN_STEPS_BEFORE_DEADLINE
    assert not post.converged and "stopped by the time budget at step 100" in post.message
    assert np.all(np.isfinite(post.draws))
    # a progress line per step here (the interval is 0 s), naming the step and the total
    assert any(line.startswith("emcee ") and "step 100/" in line for line in lines), lines[-3:]


def test_a_step_cut_by_the_budget_is_named_and_the_report_is_still_written(tmp_path, monkeypatch):
    from bayes_emt.cli.commands import demo

    out = tmp_path / "run"
    buf = io.StringIO()
    # the robust shunt's worker process gets 0.5 s (it cannot even load the posterior in that time)
    monkeypatch.setattr(demo, "MIN_STEP_S", 0.5)
    with warnings.catch_warnings(), contextlib.redirect_stdout(buf):
        warnings.simplefilter("ignore")
        # a budget of 1 ms: every share is over at once; the first model is still fitted and the
        # chain still makes its minimum of steps
        rc = main(["demo", "--quick", "--out", str(out), "--seed", "2", "--time-budget", "0.001",
                   "--skip", "diagnose"])
    text = buf.getvalue()
    assert rc == 1  # the preferred posterior did not converge: said, with exit status 1
    assert (out / "report.html").exists()
    run = json.loads((out / "run.json").read_text())
    assert run["time_budget_s"] == pytest.approx(0.001)
    assert list(json.loads((out / "fits.json").read_text())) == ["I"]
    for step in ("fit", "evidence", "robust_shunt"):
        said = f"[{step}] {step}: cut by the time budget"
        assert any(ln.startswith(said) for ln in text.splitlines()), (step, text)
        assert any(w.startswith(f"{step}: cut by the time budget") for w in run["warnings"])
        assert any(c.startswith(f"{step}: cut by the time budget") for c in run["cut"])
    assert "II, NL not fitted" in text
    assert not (out / "robust_shunt.json").exists()  # the worker was ended before it wrote anything
    steps = {s["name"]: s for s in run["steps"]}
    assert steps["robust_shunt"]["status"] == "skipped" and "time budget" in steps["robust_shunt"]["detail"]
    post = json.loads((out / "posterior.json").read_text())
    assert post["converged"] is False and "stopped by the time budget" in post["message"]
    html = (out / "report.html").read_text()
    assert "cut by the time budget" in html


def test_the_heartbeat_names_the_step_still_running_when_nothing_was_printed():
    from bayes_emt.cli.commands._demo_budget import Heartbeat

    lines, t0 = [], time.monotonic()
    with Heartbeat(lambda: t0, lambda: ("evidence", t0), lines.append, every=0.2):
        time.sleep(1.2)
    assert lines and all(ln.startswith("  ... evidence: still running (") for ln in lines), lines
    n = len(lines)
    time.sleep(0.6)
    assert len(lines) == n  # the thread ended with the context
    with Heartbeat(lambda: t0, lambda: ("x", t0), lines.append, every=0.0, on=False):
        time.sleep(0.6)
    assert len(lines) == n


def test_demo_help_states_the_budget_and_its_shares(capsys):
    with pytest.raises(SystemExit) as e:
        main(["demo", "--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--time-budget SECONDS" in text and "evidence 37 %" in text and "Default 300 s with --data" in text


def test_past_its_deadline_a_models_evidence_skips_nested_sampling_and_loo_and_says_so():
    from bayes_emt.evidence.compare import LOO_CUT_NOTE, NESTED_CUT_NOTE, CompareSettings, model_evidence

    model = build_model("I")
    meas = simulate(model, PAPER_TABLES["I"], np.geomspace(10, 1e5, 150), noise=0.002, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = model_evidence(meas, model, settings=CompareSettings(seed=1, loo=True), deadline=time.monotonic())
    assert "nested" not in m.by_method and m.elpd_loo is None
    assert any(w.startswith(NESTED_CUT_NOTE) for w in m.warnings)
    assert any(w.startswith(LOO_CUT_NOTE) for w in m.warnings)
    # the bridge estimate on the shortened chain is still there, and flagged as not converged
    assert np.isfinite(m.by_method["bridge"]["log_evidence"]) and not m.converged
