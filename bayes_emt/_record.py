"""What a result shows a person: a one-line ``repr``, a plain-text summary table with units, the
same table as HTML in a notebook, and strict JSON to save and read back.

Every frozen result record of the public verbs (:class:`~bayes_emt.estimation.results.FitResult`,
:class:`~bayes_emt.inference.posterior.Posterior`, :class:`~bayes_emt.evidence.records.Comparison`,
:class:`~bayes_emt.discovery.diagnose.Diagnosis`, the shunt designs) mixes in :class:`Record` and
provides three things: :meth:`Record.tables` (what :meth:`Record.summary` and
:meth:`Record._repr_html_` render), :meth:`Record.headline` (the one line of ``repr``) and
``to_json_dict`` (what :meth:`Record.save` writes, with a ``"kind"`` that :func:`read_record`
dispatches on to the class's ``from_json_dict``). The arrays stay attributes: printing a result
never dumps them (statsmodels' ``summary()``, lmfit's ``fit_report()``).
"""

from __future__ import annotations

import html
import json
import math
import textwrap
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

from ._atomic import atomic_write_text
from ._json import strict_json
from .errors import DataFormatError

__all__ = ["Table", "Record", "read_record", "record_from_dict", "fmt", "render_text", "render_html",
           "record_kinds", "register_kind"]

_KINDS: dict[str, type] = {}


def fmt(x, digits: int = 5) -> str:
    """A number for a table: ``digits`` significant digits, ``-`` for a missing or non-finite one."""
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return "-"
    return f"{v:.{digits}g}"


@dataclass(frozen=True)
class Table:
    """A titled table: ``columns`` (each naming its unit where it has one), ``rows`` of cells
    (numbers are formatted by :func:`fmt`), ``notes`` printed under it."""

    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple, ...]
    notes: tuple[str, ...] = ()


def _cells(row: Sequence) -> list[str]:
    return [c if isinstance(c, str) else fmt(c) for c in row]


#: width of a text summary [characters]; a last column that would pass it is wrapped
WIDTH = 110


def render_text(tables: Iterable[Table]) -> str:
    """Plain-text rendering, columns aligned (numbers right, text and units left), a long last
    column (a message) wrapped at :data:`WIDTH`."""
    out: list[str] = []
    for t in tables:
        out.append(t.title)
        if t.columns:
            rows = [_cells(r) for r in t.rows]
            widths = [max([len(c)] + [len(r[i]) for r in rows]) for i, c in enumerate(t.columns)]
            room = WIDTH - 2 - sum(w + 2 for w in widths[:-1])
            if widths[-1] > room >= 30:
                widths[-1] = room
            left = ["unit" in c.lower() for c in t.columns]
            out.append("  " + "  ".join(c.ljust(w) for c, w in zip(t.columns, widths, strict=True)).rstrip())
            out.append("  " + "  ".join("-" * w for w in widths))
            for r in rows:
                last = textwrap.wrap(r[-1], widths[-1]) or [""]
                cells = [(c.rjust(w) if _numeric(c) and not lf else c.ljust(w))
                         for c, w, lf in zip(r[:-1], widths[:-1], left[:-1], strict=True)]
                out.append("  " + "  ".join([*cells, last[0]]).rstrip())
                pad = "  " + "".join(" " * (w + 2) for w in widths[:-1])
                out += [pad + more for more in last[1:]]
        for n in t.notes:
            out += textwrap.wrap(n, WIDTH, initial_indent="  ", subsequent_indent="    ")
        out.append("")
    return "\n".join(out).rstrip() + "\n"


def _numeric(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def render_html(tables: Iterable[Table]) -> str:
    """The same tables as HTML (a notebook's rich display)."""
    e = html.escape
    parts = []
    for t in tables:
        parts.append(f"<p><b>{e(t.title)}</b></p>")
        if t.columns:
            head = "".join(f"<th>{e(c)}</th>" for c in t.columns)
            body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in _cells(r)) + "</tr>" for r in t.rows)
            parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        parts += [f"<p><small>{e(n)}</small></p>" for n in t.notes]
    return "<div>" + "".join(parts) + "</div>"


class Record:
    """Mixin for frozen result records (module docstring). Subclasses are dataclasses declared with
    ``repr=False`` (so that this one-line ``__repr__`` is kept), set :attr:`kind`, and implement
    :meth:`tables`, :meth:`headline`, ``to_json_dict`` and the class method ``from_json_dict``."""

    kind: ClassVar[str] = ""

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if cls.__dict__.get("kind"):
            register_kind(cls)

    def tables(self) -> list[Table]:  # pragma: no cover - every subclass overrides
        raise NotImplementedError

    def headline(self) -> str:  # pragma: no cover - every subclass overrides
        raise NotImplementedError

    def summary(self) -> str:
        """The result as plain-text tables with units (what ``print(result.summary())`` shows)."""
        return render_text(self.tables())

    def _repr_html_(self) -> str:
        return render_html(self.tables())

    def __repr__(self) -> str:
        return f"<{type(self).__name__}: {self.headline()}>"

    def to_json(self) -> str:
        """Strict JSON (no NaN: a value that could not be computed is ``null``) with ``"kind"``."""
        return json.dumps(strict_json({"kind": self.kind, **self.to_json_dict()}), indent=2, allow_nan=False)

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_json` to ``path`` atomically; :func:`read_record` reads it back."""
        atomic_write_text(path, self.to_json() + "\n")
        return Path(path)


def record_kinds() -> dict[str, type]:
    """The record classes by ``kind`` (those whose modules have been imported)."""
    return dict(_KINDS)


def register_kind(cls: type) -> type:
    """Register a record class that does not mix in :class:`Record` (its own summary and HTML) but
    writes a ``"kind"`` (``cls.kind``) and reads back with ``cls.from_json_dict``; returns ``cls``
    (usable as a class decorator)."""
    kind = getattr(cls, "kind", "")
    if not kind or not callable(getattr(cls, "from_json_dict", None)):
        raise TypeError(f"{cls.__name__}: a registered record needs a 'kind' and from_json_dict")
    _KINDS[kind] = cls
    return cls


def read_record(path: str | Path):
    """A result saved by :meth:`Record.save`, rebuilt by its class's ``from_json_dict``."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else exc
        raise DataFormatError(f"{path}: cannot read ({why})") from None
    except json.JSONDecodeError as exc:
        raise DataFormatError(f"{path}:{exc.lineno}: not JSON ({exc.msg})") from None
    return record_from_dict(rec, where=str(path))


def record_from_dict(rec, *, where: str = "record"):
    """The result a parsed record describes, by its ``kind`` (``where`` names it in errors)."""
    kind = rec.get("kind") if isinstance(rec, dict) else None
    if kind not in _KINDS:
        known = ", ".join(sorted(_KINDS)) or "none loaded"
        raise DataFormatError(f"{where}: not a saved bayes_emt result (its 'kind' is {kind!r}; "
                              f"known: {known})")
    try:
        return _KINDS[kind].from_json_dict(rec)
    except (KeyError, TypeError, ValueError) as exc:
        raise DataFormatError(f"{where}: a {kind} record that cannot be read back ({exc})") from None
