"""Every command's ``--help`` ends with worked examples that the parser accepts, and offers
``--quiet`` / ``--verbose``; the two flags change what is printed, never the results."""

import shlex

import pytest

from bayes_emt.cli import build_parser, main
from bayes_emt.io import write_measurement
from bayes_emt.io.simulate import log_omega_grid, simulate
from bayes_emt.models import build_model
from bayes_emt.reference import PAPER_TABLES

NOT_YET: set[str] = set()  # every command carries examples and the two flags


def _commands():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return parser, {name: p for name, p in sub.choices.items() if name not in NOT_YET}


def _examples(p) -> list[str]:
    assert p.epilog and p.epilog.startswith("examples:"), f"{p.prog}: no examples in --help"
    lines = [ln.strip() for ln in p.epilog.splitlines()[1:]]
    return [ln.split("  (")[0] for ln in lines if ln.startswith("bayes-emt")]


@pytest.mark.parametrize("name", sorted(_commands()[1]))
def test_help_has_examples_the_parser_accepts_and_both_verbosity_flags(name, capsys):
    parser, commands = _commands()
    p = commands[name]
    examples = _examples(p)
    assert len(examples) >= 2
    for line in examples:
        argv = shlex.split(line)
        assert argv[:2] == ["bayes-emt", name]
        parser.parse_args(argv[1:])  # exits (SystemExit) on an example the parser rejects
    help_text = p.format_help()
    assert "--quiet" in help_text and "--verbose" in help_text and "examples:" in help_text
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0 and "examples:" in capsys.readouterr().out


@pytest.fixture
def recording(tmp_path):
    meas = simulate(build_model("I"), PAPER_TABLES["I"], log_omega_grid(10, 1e4, 150), noise=0.002, seed=3)
    return write_measurement(meas, tmp_path / "rec.zma")


def _run(argv, capsys):
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_fit_quiet_and_verbose(recording, tmp_path, capsys):
    argv = ["fit", str(recording), "--model", "I", "--json", str(tmp_path / "f.json")]
    rc, normal, _ = _run(argv, capsys)
    rc_q, quiet, _ = _run(argv + ["--quiet"], capsys)
    rc_v, verbose, err_v = _run(argv + ["--verbose"], capsys)
    assert rc == rc_q == rc_v == 0
    assert "model I on" in normal and "wrote" in normal and "initial estimate" not in normal
    assert "model I on" not in quiet and "wrote" not in quiet
    assert "initial estimate" in verbose and "finished in" in err_v
    # the results table is the same in all three
    table = [ln for ln in normal.splitlines() if ln.startswith(("zeta", "omega0", "R0", "rms"))]
    assert len(table) == 4
    for text in (quiet, verbose):
        assert [ln for ln in text.splitlines() if ln.startswith(("zeta", "omega0", "R0", "rms"))] == table
    assert main(argv + ["--quiet", "--verbose"]) == 2  # a usage error: one line, exit 2
    assert "not allowed with argument --quiet" in capsys.readouterr().err


def test_sample_verbose_prints_priors_and_the_stopping_checks(recording, tmp_path, capsys):
    rc, out, _ = _run(["sample", str(recording), "--model", "I", "--max-steps", "100", "--verbose",
                       "--out", str(tmp_path / "p.nc")], capsys)
    assert rc == 1  # a 100-step budget does not converge, and says so
    assert "prior zeta" in out and "prior sigma_rel" in out and "check at step 100" in out


def test_info_quiet_keeps_the_facts(recording, capsys):
    rc, out, _ = _run(["info", str(recording), "--quiet"], capsys)
    assert rc == 0 and "file " not in out and "points      150" in out and "Hz" in out
    rc, out, _ = _run(["info", str(recording), "--verbose"], capsys)
    assert rc == 0 and "meta " in out
