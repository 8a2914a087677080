"""The package's layers (pyproject.toml, [tool.importlinter]) hold: a layer imports only the
layers below it, features sit side by side, and no package has an import cycle."""

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_import_contracts_are_kept():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    assert exe is not None, "import-linter is a test extra: pip install -e '.[test]'"
    run = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "broken" in run.stdout and "0 broken" in run.stdout


def _term_ids() -> set[str]:
    """The catalogue's term ids, less those that are also stage names (``"motional"``: a stage
    comparison is structure, not dispatch on a term; every model has exactly one motional term)."""
    import typing

    from bayes_emt.models import TERMS
    from bayes_emt.models.term import Stage

    return set(TERMS) - set(typing.get_args(Stage))


def _dispatch_on_model_names(path: Path) -> list[str]:
    """Places in ``path`` that branch on a model's or a term's name: ``model.name`` (any
    ``...model.name``), or a comparison with one of the paper's model names (``x == "NL"``,
    ``x in ("I", "II")``) or with a term id (``term.id == "bessel_eddy"``)."""
    import ast

    from bayes_emt.models import MODEL_NAMES

    names = set(MODEL_NAMES) | _term_ids()

    def is_name_literal(node):
        if isinstance(node, ast.Constant) and node.value in names:
            return True
        return isinstance(node, ast.Tuple | ast.List | ast.Set) and any(is_name_literal(e) for e in node.elts)

    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Attribute) and node.attr == "name":
            v = node.value
            if (isinstance(v, ast.Name) and v.id == "model") or (
                    isinstance(v, ast.Attribute) and v.attr == "model"):
                out.append(f"{path}:{node.lineno}: model.name")
        if isinstance(node, ast.Compare) and any(is_name_literal(c) for c in [node.left, *node.comparators]):
            out.append(f"{path}:{node.lineno}: comparison with a model name or term id")
    return out


def test_nothing_outside_models_dispatches_on_a_model_name():
    # behaviour belongs to the terms (issue 10): a new coil model or term touches models/ alone;
    # the likelihood's fast path (issue 14) asks the terms for their kernels, never their ids
    found = []
    for path in sorted((ROOT / "bayes_emt").rglob("*.py")):
        if "models" not in path.relative_to(ROOT / "bayes_emt").parts:
            found += _dispatch_on_model_names(path)
    assert not found, "\n".join(found)


def test_the_dispatch_check_finds_what_it_looks_for(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text('def f(model, fit):\n    if model.name == "NL":\n        pass\n'
                   '    return fit.model.name in ("I", "II")\n'
                   'def g(term):\n'
                   '    return term.id in ("bessel_eddy", "ring_ladder") or term.stage == "motional"\n')
    assert len(_dispatch_on_model_names(bad)) == 5
