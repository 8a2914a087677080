"""Klippel LPM (Linear Parameter Measurement) text exports of the impedance magnitude.

Layout (Klippel's "export curve as text"): a quoted title line (``"Magnitude of electric impedance
Z(f)"``), a quoted line naming the column groups (``"Measured"``, ``"Fitted"``; a group spans a
frequency and a magnitude column), a quoted unit line (``"Frequency [Hz]" "[Ohm]" "Frequency [Hz]"
"[Ohm]"``), then tab-separated numbers. Magnitude only: there is no phase.

Recognised by the quoted title, a group line naming ``Measured`` and a unit line with ``[Hz]``.
The measured group is read (as a magnitude-only curve, :func:`._bench.bench_measurement`); the
fitted group is kept as the bench's own fit, ``meta["bench_fit"] = {"bench": "Klippel LPM",
"source": path, "values": {}, "curve": {"f_hz": [...], "abs_z_ohm": [...]}}``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement
from ._bench import bench_measurement

__all__ = ["looks_like_klippel", "read_klippel"]

_QUOTED = re.compile(r'"([^"]*)"')
_OHM_UNITS = {"ohm": 1.0, "ohms": 1.0, "Ω": 1.0, "kohm": 1e3, "mohm": 1e-3}


def _head(text: str, n: int = 6) -> list[tuple[int, str]]:
    out = []
    for i, line in enumerate(text.splitlines(), start=1):
        if line.strip():
            out.append((i, line.strip()))
        if len(out) == n:
            break
    return out


def _cells(line: str) -> list[str]:
    """Cells of a header line: quoted strings (a tab-separated empty cell counts as one)."""
    if "\t" in line:
        return [c.strip().strip('"').strip() for c in line.split("\t")]
    return [c.strip() for c in _QUOTED.findall(line)]


def looks_like_klippel(text: str) -> bool:
    """A quoted title line, then a quoted group line naming 'Measured' and a unit line naming [Hz]."""
    head = _head(text, 3)
    if len(head) < 3 or not all(ln.startswith('"') for _, ln in head):
        return False
    return any(c.lower() == "measured" for c in _cells(head[1][1])) and "[hz]" in head[2][1].lower()


def _unit(cell: str) -> str:
    m = re.search(r"\[([^\]]*)\]", cell)
    return m.group(1).strip() if m else ""


def read_klippel(path: Path, text: str) -> Measurement:
    """Read a Klippel LPM magnitude export (see the module docstring)."""
    head = _head(text, 3)
    (title_line, title), (group_line, groups_text), (unit_line, units_text) = head
    groups, units = _cells(groups_text), _cells(units_text)
    # a group's name stands over its frequency column; the next cell (often empty) is its magnitude
    starts = [(i, g) for i, g in enumerate(groups) if g]
    layout = {}
    for i, g in starts:
        units_here = [*units[i:i + 2], "", ""]
        f_unit, v_unit = _unit(units_here[0]), _unit(units_here[1])
        if f_unit.lower() != "hz":
            raise DataFormatError(f"{path}:{unit_line}: group {g!r} has frequency unit {f_unit or 'none'!r}; "
                                  "expected [Hz]")
        if v_unit.lower() not in {k.lower() for k in _OHM_UNITS}:
            raise DataFormatError(f"{path}:{unit_line}: group {g!r} has magnitude unit {v_unit or 'none'!r}; "
                                  "export the impedance magnitude in ohm")
        layout[g.lower()] = (i, _OHM_UNITS.get(v_unit, _OHM_UNITS.get(v_unit.lower(), 1.0)))
    if "measured" not in layout:
        raise DataFormatError(f"{path}:{group_line}: no 'Measured' column group (found "
                              f"{', '.join(repr(g) for _, g in starts)})")
    ncol = max(i for i, _ in layout.values()) + 2
    measured, fitted, linenos = [], [], []
    lines = text.splitlines()
    for lineno in range(unit_line + 1, len(lines) + 1):
        s = lines[lineno - 1].strip()
        if not s:
            continue
        cells = [c.strip() for c in lines[lineno - 1].split("\t")]
        if len(cells) < 2:
            cells = s.split()
        cells += [""] * (ncol - len(cells))

        def num(c: str, lineno=lineno) -> float:
            try:
                v = float(c.replace(",", ".")) if c else math.nan
            except ValueError:
                raise DataFormatError(f"{path}:{lineno}: not a number: {c!r}") from None
            return v

        i, scale = layout["measured"]
        f, z = num(cells[i]), num(cells[i + 1])
        if not (math.isnan(f) and math.isnan(z)):
            if math.isnan(f) or math.isnan(z) or not (math.isfinite(f) and math.isfinite(z)):
                raise DataFormatError(f"{path}:{lineno}: the 'Measured' frequency and magnitude must both "
                                      "be finite numbers")
            measured.append((f, z * scale))
            linenos.append(lineno)
        if "fitted" in layout:
            j, fscale = layout["fitted"]
            ff, fz = num(cells[j]), num(cells[j + 1])
            if math.isfinite(ff) and math.isfinite(fz):
                fitted.append((ff, fz * fscale))
    if not measured:
        raise DataFormatError(f"{path}: no data lines under the 'Measured' group (line {group_line})")
    arr = np.array(measured)
    curve = np.array(sorted(fitted)) if fitted else np.empty((0, 2))
    fit = {"bench": "Klippel LPM", "source": str(path), "values": {},
           "curve": {"f_hz": curve[:, 0].tolist(), "abs_z_ohm": curve[:, 1].tolist()}}
    notices = [f"{path}: a Klippel LPM export holds |Z| only (no phase): fitted on log|Z| alone"]
    meta = {"header": title, "n_header_lines": unit_line, "bench_fit": fit, "title_line": title_line}
    return bench_measurement(path, arr, linenos, fmt="klippel", notices=notices, meta=meta,
                             magnitude_only=True)
