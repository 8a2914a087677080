"""Reading a run folder's saved outputs without trusting them: a missing file is "not run", an
unreadable one is a warning on top of the report, never a traceback."""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["RunFiles", "normalise_warning"]


@dataclass
class RunFiles:
    """The run folder ``root`` and the problems met while reading it (``problems``: one line each)."""

    root: Path
    problems: list[str] = field(default_factory=list)

    def path(self, name: str) -> Path:
        return self.root / name

    def exists(self, name: str) -> bool:
        return (self.root / name).is_file()

    def json(self, name: str):
        """The parsed JSON file ``name``, or ``None`` when absent or unreadable (then noted)."""
        p = self.root / name
        if not p.is_file():
            return None
        try:
            return json.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            self.problems.append(f"{p}: could not be read as JSON ({exc}); its section is left out")
            return None

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
