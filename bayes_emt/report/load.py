"""Reading a run folder's saved outputs without trusting them: a missing file is "not run", an
unreadable one is a warning on top of the report, never a traceback.

Outputs are found by their recorded kind, whatever their file names: a section asks for the
demo's name (``fits.json``, ``ts.json``, ...; :mod:`.layout`) and, when that file is absent, gets
what the folder's other JSON files of the matching kind hold (:data:`KIND_OF`): ``fit --json``
outputs (kind ``fit``) make the fits table, ``shunt --json`` outputs (``shunt_design``) the shunt
table, and ``ts --json``, ``diagnose --json``, ``compare --json``, ``sample --json`` and
``shunt --posterior --json`` outputs their sections. A posterior netCDF file (``sample --out``) is
found by its suffix and read by :func:`~bayes_emt.api.read_posterior`."""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from . import layout as L

__all__ = ["RunFiles", "normalise_warning", "KIND_OF", "kind_of"]

#: the demo's file name → the recorded kind of a command's output that stands for it
KIND_OF = {L.FITS: "fit", L.SHUNTS: "shunt_design", L.TS: "thiele_small", L.DIAGNOSIS: "diagnosis",
           L.ROBUST: "robust_shunt", L.COMPARISON: "comparison", L.POSTERIOR_JSON: "posterior_summary"}
#: demo files that map a model to its record (several outputs of the kind are gathered)
_KEYED = (L.FITS, L.SHUNTS)


def kind_of(rec) -> str | None:
    """The kind a saved JSON record declares (``"kind"``), or recognised from its fields for
    outputs written before they carried one (a ``sample --json`` summary, a robust shunt)."""
    if not isinstance(rec, dict):
        return None
    if isinstance(rec.get("kind"), str):
        return rec["kind"]
    if {"converged", "n_steps", "tau_max", "parameters"} <= set(rec):
        return "posterior_summary"
    if {"nominal", "robust", "draws"} <= set(rec):
        return "robust_shunt"
    return None


@dataclass
class RunFiles:
    """The run folder ``root`` and the problems met while reading it (``problems``: one line each)."""

    root: Path
    problems: list[str] = field(default_factory=list)
    _index: dict | None = field(default=None, repr=False)
    #: results computed from the folder's files once per report (e.g. a posterior's summary)
    cache: dict = field(default_factory=dict, repr=False)

    def index(self) -> dict[str, list[tuple[str, dict]]]:
        """``kind → [(file name, record), ...]`` of the folder's JSON files (sorted by name)."""
        if self._index is None:
            self._index = {}
            names = sorted(p.name for p in self.root.glob("*.json")) if self.root.is_dir() else []
            for name in names:
                if name == L.RUN or name in KIND_OF:
                    continue
                rec = self._read(self.root / name)
                k = kind_of(rec)
                if k is not None:
                    self._index.setdefault(k, []).append((name, rec))
        return self._index

    def files_of(self, demo_name: str) -> list[str]:
        """The file names that stand for ``demo_name``: itself when present, else the outputs of its kind."""
        if self.exists(demo_name):
            return [demo_name]
        return [n for n, _ in self.index().get(KIND_OF.get(demo_name, ""), [])]

    def _read(self, p: Path):
        try:
            return json.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            self.problems.append(f"{p}: could not be read as JSON ({exc}); its section is left out")
            return None

    def _by_kind(self, name: str):
        found = self.index().get(KIND_OF.get(name, ""), [])
        if not found:
            return None
        if name in _KEYED:
            out = {}
            for fname, rec in found:
                label = str(rec.get("model") or fname)
                out[label if label not in out else f"{label} ({fname})"] = rec
            return out
        msg = (f"{self.root}: {len(found)} {KIND_OF[name]} outputs ({', '.join(n for n, _ in found)}); the "
               f"report shows {found[0][0]}")
        if len(found) > 1 and msg not in self.problems:
            self.problems.append(msg)
        return found[0][1]

    def glob_image(self, *patterns: str) -> str | None:
        """The first PNG matching one of ``patterns`` in the folder or one level below, as a data URI."""
        for pat in patterns:
            hits = sorted(self.root.glob(pat)) + sorted(self.root.glob(f"*/{pat}"))
            if hits:
                return self.image(hits[0])
        return None

    def path(self, name: str) -> Path:
        return self.root / name

    def exists(self, name: str) -> bool:
        return (self.root / name).is_file()

    def json(self, name: str):
        """The parsed JSON file ``name``, or ``None`` when absent or unreadable (then noted); for a
        demo name whose file is absent, the folder's outputs of its kind (module docstring)."""
        p = self.root / name
        if not p.is_file():
            return self._by_kind(name) if name in KIND_OF else None
        return self._read(p)

    def image(self, name: str | Path) -> str | None:
        """A ``data:`` URI of the PNG or SVG ``name`` (relative to the folder), or ``None``."""
        p = Path(name) if Path(name).is_absolute() else self.root / name
        if not p.is_file():
            return None
        try:
            raw = p.read_bytes()
        except OSError as exc:
            self.problems.append(f"{p}: could not be read ({exc}); the figure is left out")
            return None
        if p.suffix.lower() == ".svg":
            mime = "image/svg+xml"
        elif raw[:8] == b"\x89PNG\r\n\x1a\n":
            mime = "image/png"
        else:
            self.problems.append(f"{p}: not a PNG or SVG image; the figure is left out")
            return None
        return f"data:{mime};base64," + base64.b64encode(raw).decode("ascii")


def normalise_warning(w, source: str) -> dict:
    """A warning as ``{"source", "code", "message"}`` from a string or a ``{code, message}`` record."""
    if isinstance(w, dict):
        return {"source": source, "code": str(w.get("code") or ""), "message": str(w.get("message", w))}
    return {"source": source, "code": "", "message": str(w)}


def finite(x) -> bool:
    """Whether ``x`` is a finite real number (JSON ``null`` and strings are not)."""
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
