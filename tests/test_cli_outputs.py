"""Outputs never destroy inputs, bad output paths and options fail at once in one line (issue 9).

Every output option of every command (``--json``, ``--out``, ``--checkpoint``, ``--plot``, simulate's
``--out``, the demo's folder) is checked before any work (:mod:`bayes_emt.cli.paths`): equal to an
input file, refused; parent missing, a file, or not writable: one line, exit 2. Option values the
parser can judge (seeds, counts, ``--nu`` without the Student-t likelihood) name the option.
"""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.cli import main
from bayes_emt.cli.paths import OutputPathError, check_outputs
from bayes_emt.io import write_measurement
from bayes_emt.reference import PAPER_TABLES

MALFORMED = Path(__file__).parent / "malformed"
NOISE_PRIOR = str(MALFORMED / "params" / "noise_prior_excludes_data.toml")
OMEGA = np.geomspace(10, 1e5, 150)


@pytest.fixture()
def data(tmp_path):
    path = tmp_path / "meas.csv"
    write_measurement(simulate(build_model("I"), PAPER_TABLES["I"], OMEGA, noise=0.002, seed=3), path)
    return path


@pytest.fixture()
def params(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"model": "I", "parameters": PAPER_TABLES["I"]}))
    return path


def _one_line_error(capsys, *needles):
    """The captured run printed exactly one error line (warnings may precede it), no traceback."""
    cap = capsys.readouterr()
    err = [ln for ln in cap.err.strip().splitlines() if not ln.startswith("bayes-emt: warning:")]
    assert len(err) == 1 and err[0].startswith("bayes-emt: error:") and "Traceback" not in cap.err, cap.err
    for n in needles:
        assert n in err[0], err[0]
    return cap


def _commands(data, params, target):
    """Every command with one output option set to ``target``."""
    d, p, t = str(data), str(params), str(target)
    return {
        "fit --json": ["fit", d, "--model", "I", "--json", t],
        "hankel --json": ["hankel", d, "--max-rings", "2", "--json", t],
        "sample --out": ["sample", d, "--model", "I", "--max-steps", "50", "--quiet", "--out", t],
        "sample --checkpoint": ["sample", d, "--model", "I", "--max-steps", "50", "--quiet",
                                "--checkpoint", t],
        "sample --json": ["sample", d, "--model", "I", "--max-steps", "50", "--quiet", "--json", t],
        "sample --plot": ["sample", d, "--model", "I", "--max-steps", "50", "--quiet", "--plot", t],
        "added-mass --json": ["added-mass", d, d, "--delta-m", "0.1", "--model", "I", "--json", t],
        "simulate --out": ["simulate", "--params", p, "--out", t, "--points", "50"],
        "shunt --json": ["shunt", "--params", p, "--json", t],
        "shunt --plot": ["shunt", "--params", p, "--plot", t],
        "demo --out": ["demo", "--data", d, "--quick", "--out", t],
    }


INPUT_OF = {"simulate --out": "params", "shunt --json": "params", "shunt --plot": "params"}


@pytest.mark.parametrize("which", sorted(_commands("d", "p", "t")))
def test_an_output_equal_to_an_input_is_refused_and_the_input_kept(which, data, params, capsys):
    target = params if INPUT_OF.get(which) == "params" else data
    before = target.read_bytes()
    argv = _commands(data, params, target)[which]
    assert main(argv) == 2
    _one_line_error(capsys, str(target), "input")
    assert target.read_bytes() == before
    assert sorted(p.name for p in target.parent.iterdir()) == ["meas.csv", "p.json"]  # nothing else written


def test_an_output_that_is_the_input_through_a_link_is_refused(data, capsys):
    link = data.parent / "link.csv"
    os.link(data, link)  # a hard link: another name for the same file
    before = data.read_bytes()
    assert main(["fit", str(data), "--model", "I", "--json", str(link)]) == 2
    _one_line_error(capsys, "is the input DATA")
    assert data.read_bytes() == before


@pytest.mark.parametrize("which", sorted(_commands("d", "p", "t")))
@pytest.mark.parametrize("defect", ["parent missing", "parent is a file", "not writable"])
def test_a_bad_output_path_fails_before_any_work_in_one_line(which, defect, data, params, capsys,
                                                             monkeypatch):
    if defect == "parent missing":
        target, needle = data.parent / "no_such_folder" / "x" / "out.json", "does not exist"
        if which.endswith(("--plot", "demo --out")):
            # folders are created with their parents: only an ancestor that is no folder is fatal
            target, needle = data / "sub" / "dir", "is a file"
    elif defect == "parent is a file":
        target, needle = data / "out.json", "is a file"
    else:
        # a folder of its own that may not be written: root may write wherever a permission bit
        # forbids it, so the probe the check relies on (creating a file there) is made to fail
        locked = data.parent / "locked"
        locked.mkdir()
        target, needle = locked / "out.json", "cannot write in"
        if which.endswith(("--plot", "demo --out")):
            target, needle = locked / "plots", "cannot create this folder"
        import bayes_emt.cli.paths as paths

        real = paths.tempfile.mkstemp

        def mkstemp(*args, dir=None, **kwargs):
            if dir is not None and Path(dir).resolve() == locked.resolve():
                raise PermissionError(13, "Permission denied")
            return real(*args, dir=dir, **kwargs)

        monkeypatch.setattr(paths.tempfile, "mkstemp", mkstemp)
    argv = _commands(data, params, target)[which]
    assert main(argv) == 2
    cap = _one_line_error(capsys, str(target), needle)
    assert cap.out == ""  # no work was done: nothing was fitted, sampled or printed
    assert not target.exists()
    assert {p.name for p in data.parent.iterdir()} <= {"meas.csv", "p.json", "locked"}


@pytest.mark.skipif(not Path("/sys").is_dir(), reason="needs /sys (Linux)")
def test_a_folder_nobody_may_write_is_refused_without_tricks(data, capsys):
    # /sys refuses new files even to root: the real probe, no monkeypatching
    assert main(["fit", str(data), "--model", "I", "--json", "/sys/out.json"]) == 2
    _one_line_error(capsys, "/sys/out.json", "cannot write in folder /sys")


def test_two_outputs_naming_one_file_and_an_output_folder_that_is_a_file(tmp_path, data, capsys):
    nc = str(tmp_path / "r.nc")
    assert main(["sample", str(data), "--model", "I", "--quiet", "--out", nc, "--checkpoint", nc]) == 2
    _one_line_error(capsys, "name the same file")
    assert main(["sample", str(data), "--model", "I", "--quiet", "--out", nc, "--json", str(tmp_path)]) == 2
    _one_line_error(capsys, "is a folder; give a file name")
    with pytest.raises(OutputPathError, match="--plot .*: is a file, not a folder"):
        check_outputs(folders=[("--plot", data, ["a.png"])])


@pytest.mark.parametrize("argv, needle", [
    (["sample", "{data}", "--model", "I", "--seed", "-1"], "argument --seed: must be a non-negative integer, "
                                                            "got '-1'"),
    (["simulate", "--params", "{params}", "--out", "{tmp}/s.csv", "--seed", "-1"], "argument --seed"),
    (["demo", "--seed", "-3", "--quick", "--out", "{tmp}/demo"], "argument --seed"),
    (["simulate", "--params", "{params}", "--out", "{tmp}/s.csv", "--points", "2"],
     "argument --points: must be an integer >= 3 (the readers, and so fit, refuse fewer), got '2'"),
    (["sample", "{data}", "--model", "I", "--nu", "3"], "--nu 3.0 applies to --likelihood student only"),
    (["sample", "{data}", "--model", "I", "--max-steps", "0"], "argument --max-steps"),
    (["fit", "{data}", "--model", "NL", "--rings", "0"], "argument --rings"),
    (["fit", "{data}", "--model", "I", "--omega-min", "-5"], "argument --omega-min"),
    (["hankel", "{data}", "--max-rings", "1"], "argument --max-rings"),
    (["shunt", "--params", "{params}", "--implement", "--fs", "0"], "argument --fs"),
    (["added-mass", "{data}", "{data}", "--model", "I", "--delta-m", "nan"], "argument --delta-m"),
    (["fit", "{data}"], "the following arguments are required: --model"),
    (["sample", "{data}", "--model", "I", "--priors", NOISE_PRIOR, "--out", "{tmp}/r.nc", "--quiet"],
     "the noise priors exclude the data"),
    (["simulate", "--params", str(MALFORMED / "params" / "null_parameter.json"), "--out", "{tmp}/s.csv"],
     "null_parameter.json: parameter 'L0' is null; give a number [H]"),
    (["shunt", "--params", str(MALFORMED / "params" / "text_parameter.json")],
     "text_parameter.json: parameter 'omega0' is \"50.8 rad/s\"; give a number [rad/s]"),
])
def test_option_errors_name_the_option_in_one_line(argv, needle, data, params, tmp_path, capsys):
    argv = [a.format(data=data, params=params, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    _one_line_error(capsys, needle)
    assert not any(p.suffix in (".h5", ".nc") for p in tmp_path.iterdir())  # no run was started


def test_the_corpus_of_parameter_files_is_complete():
    names = {p.name for p in (MALFORMED / "params").iterdir()}
    assert names == {"null_parameter.json", "text_parameter.json", "noise_prior_excludes_data.toml"}


def test_nu_with_the_student_likelihood_is_accepted(data, tmp_path, capsys):
    rc = main(["sample", str(data), "--model", "I", "--likelihood", "student", "--nu", "3", "--max-steps",
               "20", "--quiet", "--out", str(tmp_path / "r.nc"), "--json", str(tmp_path / "r.json")])
    assert rc == 1  # 20 steps cannot converge: flagged, not refused
    rec = json.loads((tmp_path / "r.json").read_text())
    assert rec["likelihood"] == "student" and rec["converged"] is False
    assert "not_converged" in [w["code"] for w in rec["warnings"]]


def test_fit_json_and_stdout_carry_the_fits_warnings(tmp_path, capsys):
    # model I on the bundled NL(5) data cannot follow the eddy-current rise: model_inadequate
    from bayes_emt.io.datasets import paper_bench_path

    out = tmp_path / "fit.json"
    assert main(["fit", str(paper_bench_path()), "--model", "I", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    rec = json.loads(out.read_text())
    codes = [w["code"] for w in rec["warnings"]]
    assert "model_inadequate" in codes and all(set(w) == {"code", "message"} for w in rec["warnings"])
    # one terminal line per warning (issue 22): code, band in Hz, short hint; the full text in the JSON
    lines = [ln for ln in text.splitlines() if ln.startswith("warning [")]
    assert len(lines) == 1 and lines[0].startswith("warning [model_inadequate]") and " Hz: " in lines[0]
    assert "rad/s" in rec["warnings"][0]["message"]


def test_sample_json_carries_the_fits_warnings(tmp_path, capsys):
    # the walkers start from the least-squares fit: its warnings travel with the posterior
    from bayes_emt.io.datasets import paper_bench_path

    js = tmp_path / "s.json"
    rc = main(["sample", str(paper_bench_path()), "--model", "I", "--max-steps", "20", "--quiet",
               "--out", str(tmp_path / "r.nc"), "--json", str(js)])
    assert rc == 1
    codes = [w["code"] for w in json.loads(js.read_text())["warnings"]]
    assert codes[0] == "model_inadequate" and codes[-1] == "not_converged"
    assert "WARNING [model_inadequate]" in capsys.readouterr().out
