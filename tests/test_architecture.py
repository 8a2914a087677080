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


def _dispatch_on_model_names(path: Path) -> list[str]:
    """Places in ``path`` that branch on a model's name: ``model.name`` (any ``...model.name``),
    or a comparison with one of the paper's model names (``x == "NL"``, ``x in ("I", "II")``)."""
    import ast

    from bayes_emt.models import MODEL_NAMES

    def is_name_literal(node):
        if isinstance(node, ast.Constant) and node.value in MODEL_NAMES:
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
            out.append(f"{path}:{node.lineno}: comparison with a model name")
    return out


def test_nothing_outside_models_dispatches_on_a_model_name():
    # behaviour belongs to the terms (issue 10): a new coil model or term touches models/ alone
    found = []
    for path in sorted((ROOT / "bayes_emt").rglob("*.py")):
        if "models" not in path.relative_to(ROOT / "bayes_emt").parts:
            found += _dispatch_on_model_names(path)
    assert not found, "\n".join(found)


def test_the_dispatch_check_finds_what_it_looks_for(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text('def f(model, fit):\n    if model.name == "NL":\n        pass\n'
                   '    return fit.model.name in ("I", "II")\n')
    assert len(_dispatch_on_model_names(bad)) == 4
