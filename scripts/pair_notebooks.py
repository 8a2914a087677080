"""Write ``notebooks/*.ipynb`` from their percent-format twins ``notebooks/*.py`` (outputs empty).

The ``.py`` file is the source (plain text, reviewable diffs, runnable as a script); the
``.ipynb`` is generated from it, with no outputs, for Jupyter users. Cells start at lines
``# %%`` (code) or ``# %% [markdown]`` (markdown: the ``# `` comment prefix is removed).
This is the subset of jupytext's percent format the notebooks use, without the dependency.

    python scripts/pair_notebooks.py           # rewrite every .ipynb
    python scripts/pair_notebooks.py --check   # exit 1 when an .ipynb is out of date
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import nbformat

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


def cells_from_percent(text: str) -> list:
    """The notebook cells of a percent-format script."""
    cells, kind, lines = [], None, []

    def flush():
        body = "\n".join(lines).strip("\n")
        if kind == "markdown":
            body = "\n".join(ln[2:] if ln.startswith("# ") else ln.lstrip("#") for ln in body.splitlines())
            cells.append(nbformat.v4.new_markdown_cell(body))
        elif kind == "code" and body:
            cells.append(nbformat.v4.new_code_cell(body))

    for line in text.splitlines():
        if line.startswith("# %%"):
            flush()
            kind, lines = ("markdown" if "[markdown]" in line else "code"), []
        elif kind is not None:
            lines.append(line)
    flush()
    return cells


def notebook_from_percent(path: Path):
    nb = nbformat.v4.new_notebook()
    nb.cells = cells_from_percent(path.read_text(encoding="utf-8"))
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"{path.stem[:40]}-{i}"
    nb.metadata = {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
                   "language_info": {"name": "python"}, "jupytext": {"formats": "ipynb,py:percent"}}
    return nb


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="only report out-of-date notebooks")
    args = ap.parse_args(argv)
    stale = []
    for src in sorted(NOTEBOOKS.glob("*.py")):
        target = src.with_suffix(".ipynb")
        text = nbformat.writes(notebook_from_percent(src)) + "\n"
        if not target.exists() or target.read_text(encoding="utf-8") != text:
            stale.append(target)
            if not args.check:
                target.write_text(text, encoding="utf-8")
                print(f"wrote {target}")
    if args.check and stale:
        print("out of date (run python scripts/pair_notebooks.py): " + ", ".join(map(str, stale)))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
