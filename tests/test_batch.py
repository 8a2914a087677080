"""Batch runs on Dask (issue 15): many recordings, broken files reported, resumable, summary table.

The recordings are simulated from the paper's Table 1 (model I) on 120 points with 0.2 % noise,
so every fit and every short sampler run takes about a second; the cluster is a real
``distributed.LocalCluster`` of 2 worker processes (shared by the tests of this module).
"""

import csv
import json
import pickle

import numpy as np
import pytest

from bayes_emt.batch import BatchSettings, FileOutcome, find_inputs, is_finished, process_file, run_batch
from bayes_emt.batch.jobs import ERROR_FILE, MARKER
from bayes_emt.cli import main
from bayes_emt.io import write_measurement
from bayes_emt.io.simulate import log_omega_grid, simulate
from bayes_emt.models import build_model
from bayes_emt.reference import PAPER_TABLES

BROKEN = {"broken_header.zma": "* an impedance file\n100 abc 3\n", "broken_empty.zma": ""}


def make_recordings(folder, n_good: int, *, broken: bool = True):
    """``n_good`` simulated recordings (resonance moved 1 % per file) plus the two broken files."""
    folder.mkdir(parents=True, exist_ok=True)
    model = build_model("I")
    for i in range(n_good):
        p = dict(PAPER_TABLES["I"], omega0=PAPER_TABLES["I"]["omega0"] * (1 + 0.01 * i))
        write_measurement(simulate(model, p, log_omega_grid(10, 1e4, 120), noise=0.002, seed=i),
                          folder / f"rec{i:02d}.zma")
    if broken:
        for name, text in BROKEN.items():
            (folder / name).write_text(text)
    return folder


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as c:
            yield c


def test_twenty_recordings_two_broken_give_eighteen_results_and_two_clear_errors(tmp_path, client):
    data = make_recordings(tmp_path / "data", 18)
    out = tmp_path / "out"
    settings = BatchSettings(jobs=("fit",), model="I")
    res = run_batch(data, out, settings, client=client)
    assert res.counts == {"done": 18, "error": 2, "pending": 0}
    errors = {o.name: o.error for o in res.errors}
    assert set(errors) == {"broken_header", "broken_empty"}
    for name, msg in errors.items():
        assert "\n" not in msg and f"{name}.zma" in msg  # one line, naming the file
    assert "empty file" in errors["broken_empty"]
    for o in res.outcomes:
        if o.status == "done":
            # each fit recovers its own resonance: omega0 = 50.8 (1 + 0.01 i) rad/s within 1 %
            i = int(o.name[3:])
            assert o.summary["omega0_rad_s"] == pytest.approx(50.8 * (1 + 0.01 * i), rel=0.01)
            assert (out / o.name / "fit.json").exists() and (out / o.name / MARKER).exists()
            assert json.loads((out / o.name / "fit.json").read_text())["model"] == "I"
    with open(out / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 20
    assert sorted(r["status"] for r in rows) == ["done"] * 18 + ["error"] * 2
    assert all(r["f0 [Hz]"] for r in rows if r["status"] == "done")
    html = (out / "summary.html").read_text()
    assert html.count("<tr class=\"done\">") == 18 and html.count("<tr class=\"error\">") == 2
    assert "18 done, 2 failed, 0 not finished" in html

    # a re-run skips the 18 finished files and tries only the two broken ones again
    again = run_batch(data, out, settings, client=client)
    assert sorted(again.ran) == ["broken_empty", "broken_header"]
    assert again.counts == res.counts


def test_sample_job_writes_a_readable_posterior_and_flags_the_short_run(tmp_path, client):
    from bayes_emt.api import read_posterior

    data = make_recordings(tmp_path / "data", 2, broken=False)
    out = tmp_path / "out"
    res = run_batch(data, out, BatchSettings(jobs=("fit", "sample"), model="I", max_steps=100), client=client)
    assert res.counts["done"] == 2
    for o in res.outcomes:
        post = read_posterior(out / o.name / "posterior.nc")
        assert post.n_steps == 100 and not post.converged
        assert o.summary["converged"] is False and o.summary["steps"] == 100
        # a run cut by its budget says so in its warnings, it is not a quiet number
        assert any("not converged" in w for w in o.warnings)
        assert np.isfinite(o.summary["ess_min"])


def test_marker_is_only_written_on_success_and_tied_to_input_bytes_and_settings(tmp_path):
    data = make_recordings(tmp_path / "data", 1)
    out = tmp_path / "out"
    inputs = {i.name: i for i in find_inputs(data)}
    settings = BatchSettings(jobs=("fit",), model="I")
    good = process_file(inputs["rec00"], out / "rec00", settings)
    assert good.status == "done" and is_finished(inputs["rec00"], out / "rec00", settings)
    # other settings or more jobs: not finished for them
    assert not is_finished(inputs["rec00"], out / "rec00", BatchSettings(jobs=("fit",), model="II"))
    assert not is_finished(inputs["rec00"], out / "rec00", BatchSettings(jobs=("fit", "sample"), model="I"))
    # changed input bytes: not finished
    path = inputs["rec00"].path
    path.write_text(path.read_text() + "\n")
    assert not is_finished(inputs["rec00"], out / "rec00", settings)
    bad = process_file(inputs["broken_header"], out / "broken_header", settings)
    assert bad.status == "error"
    assert not (out / "broken_header" / MARKER).exists()
    rec = json.loads((out / "broken_header" / ERROR_FILE).read_text())
    assert rec["error"] == bad.error and "Traceback" in rec["traceback"]


def test_the_diagnose_job_writes_the_issue_13_record(tmp_path):
    """A recording of exactly the model it is diagnosed with (model I, 0.2 % noise): the record has
    issue 13's keys, starts and ends at I, and finds no significant mismatch."""
    data = make_recordings(tmp_path / "data", 1, broken=False)
    inp = find_inputs(data)[0]
    o = process_file(inp, tmp_path / "out" / inp.name, BatchSettings(jobs=("fit", "diagnose"), model="I"))
    assert o.status == "done", o.error
    rec = json.loads((tmp_path / "out" / inp.name / "diagnosis.json").read_text())
    assert {"baseline_model", "final_model", "rms_rel_residual", "findings", "unexplained",
            "warnings"} <= set(rec)
    assert rec["baseline_model"] == rec["final_model"] == "I" and rec["findings"] == []


def test_what_crosses_to_the_workers_pickles(tmp_path):
    inp = find_inputs(make_recordings(tmp_path / "data", 1, broken=False))[0]
    s = BatchSettings(jobs=("fit", "sample"), model="NL+winding_capacitance", rings=3,
                      read_options=(("freq_unit", "hz"),))
    o = FileOutcome("a", "a.zma", "done", summary={"f0_hz": 8.1}, warnings=("w",), seconds=1.0)
    for obj in (inp, s, o):
        assert pickle.loads(pickle.dumps(obj)) == obj


def test_inputs_from_folder_and_glob_with_unique_stable_names(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for d in ("a", "b"):
        (tmp_path / d / "rec.zma").write_text("x")
    (tmp_path / "a" / "notes.md").write_text("not a measurement")
    assert [i.name for i in find_inputs(tmp_path / "a")] == ["rec"]
    names = [i.name for i in find_inputs(str(tmp_path / "*" / "rec.zma"))]
    assert len(set(names)) == 2 and all(n.startswith("rec-") for n in names)
    assert names == [i.name for i in find_inputs(str(tmp_path / "*" / "rec.zma"))]
    # files inside the output folder are never inputs
    assert [i.name for i in find_inputs(str(tmp_path / "*" / "*.zma"), out=tmp_path / "b")] == ["rec"]
    with pytest.raises(FileNotFoundError, match="matches no file"):
        find_inputs(str(tmp_path / "*.nothing"))
    with pytest.raises(FileNotFoundError, match="no measurement files"):
        find_inputs(tmp_path)


@pytest.mark.parametrize("argv, message", [
    (["--jobs", "fit,plot"], "--jobs: unknown job plot"),
    (["--max-steps", "0"], "--max-steps must be positive"),
    (["--model", "XX"], "--model XX"),
    (["--scheduler", "tcp://127.0.0.1:9", "--workers", "2"], "--workers applies to --scheduler local only"),
])
def test_cli_usage_errors_are_one_line_exit_2(tmp_path, capsys, argv, message):
    data = make_recordings(tmp_path / "data", 1, broken=False)
    rc = main(["batch", str(data), "--out", str(tmp_path / "out"), *argv])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_cli_missing_source_exit_2(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "nowhere"), "--out", str(tmp_path / "out")]) == 2
    assert "no such folder or file" in capsys.readouterr().err


def test_a_running_scheduler_is_reached_by_its_address(tmp_path, client):
    # the --scheduler ADDRESS path: connect to an existing cluster (here the fixture's) by address
    data = make_recordings(tmp_path / "data", 2, broken=False)
    res = run_batch(data, tmp_path / "out", BatchSettings(jobs=("fit",), model="I"),
                    scheduler=client.scheduler.address)
    assert res.counts == {"done": 2, "error": 0, "pending": 0}


def test_an_unreachable_scheduler_is_a_one_line_usage_error(tmp_path, capsys):
    data = make_recordings(tmp_path / "data", 1, broken=False)
    rc = main(["batch", str(data), "--out", str(tmp_path / "out"), "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert rc == 2 and "--scheduler tcp://127.0.0.1:9: cannot connect" in err
    assert len(err.strip().splitlines()) == 1, err


def test_an_unfinished_file_continues_its_sampler_chain(tmp_path):
    # what a kill in the middle of a file leaves: the checkpoint, no marker. The next run resumes
    # the stored chain (its first steps kept bit for bit on this machine), it does not restart.
    import emcee

    inp = find_inputs(make_recordings(tmp_path / "data", 1, broken=False))[0]
    folder = tmp_path / "out" / inp.name
    first = process_file(inp, folder, BatchSettings(jobs=("fit", "sample"), model="I", max_steps=100))
    assert first.status == "done"

    def chain():
        ckpt = str(folder / "posterior.h5")
        return emcee.backends.HDFBackend(ckpt, name="mcmc", read_only=True).get_chain()

    chain100 = chain()
    (folder / MARKER).unlink()
    longer = BatchSettings(jobs=("fit", "sample"), model="I", max_steps=200)
    assert not is_finished(inp, folder, longer)
    again = process_file(inp, folder, longer)
    assert again.status == "done" and again.summary["steps"] == 200
    chain200 = chain()
    assert chain200.shape[0] == 200
    np.testing.assert_array_equal(chain200[:100], chain100)
