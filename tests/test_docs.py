"""The user-facing text: the README stays a doorstep, nothing a user reads cites internal documents
or issue numbers, and the documentation site's navigation names only pages that exist (the strict
build itself, ``./run docs``, runs in CI after the tests: it executes the notebooks)."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# a citation of the internal technical reference ("SPEC §7", "SPEC.md") or of an issue ("issue 13",
# "issue-13"); NU_SPEC, the Student-t degrees-of-freedom parameter's spec, is a Python name
CITATION = re.compile(r"(?<![A-Za-z_])SPEC(?![A-Za-z_])|(?i:\bissues? ?-?[0-9])")


def _user_facing_files():
    yield ROOT / "README.md"
    yield from (ROOT / "docs").rglob("*.md")
    yield from (ROOT / "notebooks").glob("*.py")
    for p in (ROOT / "bayes_emt").rglob("*"):
        if p.suffix in {".py", ".j2", ".csv"}:
            yield p


def test_nothing_user_facing_cites_internal_documents_or_issues():
    hits = [f"{p.relative_to(ROOT)}:{i}: {line.strip()[:100]}"
            for p in _user_facing_files()
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if CITATION.search(line.replace("NU_SPEC", ""))]
    assert not hits, "\n".join(hits)


def test_the_readme_is_a_doorstep():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200, len(lines)
    # the first lines are the two commands on a fresh machine
    block = lines[lines.index("```bash") + 1:lines.index("```")]
    assert [ln.split("#")[0].strip() for ln in block] == ["./run demo", "./run test"]
    assert lines.index("```bash") <= 2
    assert "./run docs" in "\n".join(lines)


def test_the_navigation_names_existing_pages():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8").split("\nnav:", 1)[1]
    pages = re.findall(r":\s*([\w/.-]+\.(?:md|ipynb))\s*$", nav, re.M)
    assert len(pages) >= 20, pages
    missing = [p for p in pages if not (ROOT / "docs" / p).exists()]
    assert not missing, missing
    # every tutorial is one of the notebooks the tests execute
    for nb in (ROOT / "docs" / "tutorials").glob("*.ipynb"):
        assert nb.resolve().parent == ROOT / "notebooks", nb


def test_the_real_data_tutorial_is_shown_unexecuted_without_the_recordings(tmp_path, monkeypatch):
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "scripts" / "docs_hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)

    class Plugin:
        def __init__(self):
            self.config = {"execute": True, "execute_ignore": []}

    class Config:
        def __init__(self):
            self.plugins = {"mkdocs-jupyter": Plugin()}

    monkeypatch.setenv("BAYES_EMT_REALDATA", str(tmp_path))  # an empty folder: no recordings
    cfg = hooks.on_config(Config())
    assert cfg.plugins["mkdocs-jupyter"].config["execute_ignore"] == [hooks.NEEDS_REALDATA]
    assert (ROOT / "docs" / hooks.NEEDS_REALDATA).exists()
    (tmp_path / hooks.PROBE).write_text("")  # the recordings are there: everything runs
    cfg = hooks.on_config(Config())
    assert cfg.plugins["mkdocs-jupyter"].config["execute_ignore"] == []
