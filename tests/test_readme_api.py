"""The README's Python API block runs as written on the bundled data (issue 21, acceptance 1)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_api_block() -> str:
    text = README.read_text()
    m = re.search(r"## The Python API[^\n]*\n```python\n(.*?)```", text, re.S)
    assert m, "README.md has no '## The Python API' section with a python block"
    return m.group(1)


def test_the_readme_block_is_at_most_seven_lines_of_verbs():
    lines = [ln for ln in readme_api_block().splitlines() if ln.strip()]
    assert len(lines) <= 7, lines
    assert lines[0] == "import bayes_emt as be"
    # every other line calls one public verb, nothing from a submodule
    for ln in lines[1:]:
        assert re.match(r"^\w+ = be\.\w+\(", ln), ln
        assert "bayes_emt." not in ln


@pytest.mark.slow
def test_the_readme_block_runs_on_the_bundled_data(tmp_path, monkeypatch):
    # about 4 min on a quiet 2-core machine: an NL(5) posterior, two models' evidence, 1000 draws
    # through the shunt design, a diagnosis
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(readme_api_block(), str(README), "exec"), ns)  # noqa: S102 - the README's own code
    fit, post, cmp, shunt, diag = (ns[k] for k in ("fit", "post", "cmp", "shunt", "diag"))
    # the bundled data were simulated from NL(5) (data/README.md)
    assert fit.model.label == "NL(5)" and fit.rms_rel_residual < 0.005
    assert post.converged
    assert cmp.best == "NL(5)" and cmp.log_evidence["NL(5)"] - cmp.log_evidence["UD"] > 5
    assert diag.findings == () and diag.final_model == "NL(5)"
    assert 0 <= shunt.p_unstable["robust"] <= 0.01
    for r in (fit, post, cmp, shunt, diag):
        assert "\n" not in repr(r) and len(repr(r)) < 200
        assert r.summary().strip() and r._repr_html_().startswith("<")
