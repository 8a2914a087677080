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


# ---- a physics term is one file (issue 21): params/ and discovery/ name no term ----------------
#: term names a file may still hold (none): the test fails when an entry is no longer needed, so
#: that it is removed with the last use
_PENDING: set[tuple[str, str]] = set()


def _indexed_names(name: str) -> set[str]:
    """``P{j}`` → ``P``, ``P1`` .. ``P9`` (what code naming a ring parameter would write)."""
    if "{j}" not in name:
        return {name}
    return {name.replace("{j}", "")} | {name.replace("{j}", str(j)) for j in range(1, 10)}


def _registered_names() -> tuple[set[str], set[str], set[str]]:
    """From the registry: every term id with the eddy-current escalation's physics id; every
    augmentation's parameter names; every term's parameter names (ring names expanded)."""
    from bayes_emt.models import EDDY_PHYSICS, TERMS

    ids = set(TERMS) | {EDDY_PHYSICS}
    aug = {n for c in TERMS.values() if c.augmentation for p in c.parameters for n in _indexed_names(p.name)}
    every = {n for c in TERMS.values() for p in c.parameters for n in _indexed_names(p.name)}
    return ids, aug, every


def _string_literals(path: Path):
    """``(line, text)`` of every string literal of ``path`` that is not a docstring (f-strings'
    literal parts included)."""
    import ast

    tree = ast.parse(path.read_text(), str(path))
    docs = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                docs.add(id(first.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            yield node.lineno, node.value


def _names_in(package: str, names: set[str]) -> list[str]:
    found = []
    for path in sorted((ROOT / "bayes_emt" / package).rglob("*.py")):
        rel = str(path.relative_to(ROOT / "bayes_emt"))
        found += [(rel, text, line) for line, text in _string_literals(path) if text in names]
    return found


def test_params_and_discovery_name_no_physics_term():
    # a term is one file in models/: its priors, band class and signature live with it, so params/
    # holds no term id nor any term's parameter name (the noise parameters are its own), and
    # discovery/ no term id, no escalation id and no augmentation's parameter name (it reads the
    # band classes from the registry). The plant's and the coil models' parameters (R0, omega0,
    # zeta, phi: the resonance and DC resistance every model has) discovery may read by name.
    ids, aug, every = _registered_names()
    found = _names_in("params", ids | every) + _names_in("discovery", ids | aug)
    left = [f"{rel}:{line}: {text!r}" for rel, text, line in found if (rel, text) not in _PENDING]
    assert not left, "term names outside models/:\n" + "\n".join(left)
    stale = _PENDING - {(rel, text) for rel, text, _ in found}
    assert not stale, f"no longer needed, remove from _PENDING: {sorted(stale)}"


def test_every_augmentation_has_a_band_class_and_is_proposed():
    # leave the band class out and discovery never proposes the term: every registered augmentation
    # declares a valid one, and candidate_physics proposes every augmentation for a band that spans
    # everything (omega_r unknown) on a model without any
    from bayes_emt.discovery import candidate_physics
    from bayes_emt.discovery.locate import Band
    from bayes_emt.models import AUGMENTATIONS, BANDS, EDDY_PHYSICS, TERMS, parse_model_spec

    bad = {i: c.band for i, c in TERMS.items() if c.augmentation and c.band not in BANDS}
    assert not bad, f"augmentations without a valid band class {BANDS}: {bad}"
    assert len(AUGMENTATIONS) >= 9
    everywhere = Band(1.0, 1e6, 0, 100, ("real", "imag"), 10.0, 5.0, 1e3)
    proposed = candidate_physics(everywhere, parse_model_spec("I"), None, structure=True)
    assert set(proposed) == set(AUGMENTATIONS) | {EDDY_PHYSICS}
    # a structure beyond one driver only when the data show its signature
    structural = {i for i in AUGMENTATIONS if TERMS[i].structural}
    assert set(candidate_physics(everywhere, parse_model_spec("I"), None)) == set(proposed) - structural


def test_the_term_name_check_finds_what_it_looks_for(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text('"""Docstrings may say winding_capacitance."""\n'
                   'COIL = ("eddy_current", "winding_capacitance")\n'
                   'def f(p):\n    """Cp is documented here."""\n    return p["Cp"], f"{p}lr2"\n')
    ids, aug, _ = _registered_names()
    hits = [(line, text) for line, text in _string_literals(bad) if text in ids | aug]
    assert hits == [(2, "eddy_current"), (2, "winding_capacitance"), (5, "Cp"), (5, "lr2")]


def test_command_modules_hold_no_numerical_logic():
    # issue 21: the command line is a thin skin over the verbs (parse, call, print, write); a module
    # of cli/ that needs numpy or scipy is computing something a user could not script
    import ast

    import bayes_emt

    root = Path(bayes_emt.__file__).parent / "cli"
    offenders = []
    for f in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{f.relative_to(root)}: {n}" for n in names
                          if n.split(".")[0] in ("numpy", "scipy")]
    assert offenders == []
