"""Dayton Audio Test System (DATS) impedance exports, both header styles.

The file is text (CRLF or LF): a header block whose lines start with ``*`` (newer versions) or
``%`` (older ones; sometimes ``% *``), holding DATS's own Thiele-Small fit of the curve, then the
column line ``Freq Impedance Phase`` (possibly itself behind the comment mark) and rows of
frequency [Hz], |Z| [ohm], phase [deg], tab- or space-separated.

Newer block: ``* f(s)= 25.07 Hz``, ``* R(e)= 4.2 Ohms``, ``* Q(ms)= 3.929``, ``* V(as)= 0 liters``,
``* L(e)= 2.855 mH``, ``* M(ms)= 0 grams``, ``* C(ms)= 0 mm/N``, ``* BL= 0``, ``* SPL= 0 1W/1m``,
``* Piston Diameter = 0 mm`` and the coil terms ``K(r)``, ``X(r)``, ``K(i)``, ``X(i)``. Older block:
``% Re 3.719 [Ohms]``, ``% Fs 84.38 [Hz]``, ``% D 130 [mm]``, ``% L10k 0.52 [mH]``, ... A value of 0
means DATS did not compute it (no piston diameter, no added-mass run) and is left out.

Recognised (no flag needed) by the column line ``Freq Impedance Phase`` after a ``*``/``%`` block
that names DATS or holds at least two of its parameter lines. The block is returned as the bench's
own fit, ``meta["bench_fit"] = {"bench": "DATS", "source": path, "values": {...}, "extra": {...}}``,
names and SI units as :data:`bayes_emt.thiele_small.relations.UNITS` (fs [Hz], Re [ohm], Le [H],
Bl [T m], Mms [kg], Cms [m/N], Vas [m^3], eta0 [1], SPL [dB]); the rest (piston diameter and the
area Sd, Z(max), L10k, the coil terms) under ``extra`` as ``{name: {"value", "unit"}}``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..errors import DataFormatError
from ..measurement import Measurement
from ._bench import bench_measurement
from ._rows import numeric_rows

__all__ = ["looks_like_dats", "read_dats"]

_COLUMNS = re.compile(r"^[*%\s]*freq\w*\s+impedance\w*\s+phase\w*\s*$", re.IGNORECASE)
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# newer style: 'f(s)= 25.07 Hz'; older: 'Fs 84.38 [Hz]'
_NEW = re.compile(rf"^(?P<key>[A-Za-z][A-Za-z ]*(?:\([A-Za-z0-9]+\))?)\s*=\s*(?P<val>{_NUM})\s*(?P<unit>.*)$")
_OLD = re.compile(rf"^(?P<key>[A-Za-z][A-Za-z0-9]*)\s+(?P<val>{_NUM})\s*"
                  r"(?:\[(?P<unit>[^\]]*)\])?\s*(?P<rest>.*)$")

# key (lower case, spaces dropped) -> (name, where: 'values'|'extra', {unit (lower): factor to SI}, SI unit)
_LENGTH_MM = {"mm": 1e-3}
_KEYS: dict[str, tuple[str, str, dict[str, float], str]] = {
    "f(s)": ("fs", "values", {"hz": 1.0}, "Hz"), "fs": ("fs", "values", {"hz": 1.0}, "Hz"),
    "r(e)": ("Re", "values", {"ohms": 1.0, "ohm": 1.0}, "ohm"),
    "re": ("Re", "values", {"ohms": 1.0, "ohm": 1.0}, "ohm"),
    "z(max)": ("Zmax", "extra", {"ohms": 1.0, "ohm": 1.0}, "ohm"),
    "zm": ("Zmax", "extra", {"ohms": 1.0, "ohm": 1.0}, "ohm"),
    "q(ms)": ("Qms", "values", {"": 1.0}, "1"), "qms": ("Qms", "values", {"": 1.0}, "1"),
    "q(es)": ("Qes", "values", {"": 1.0}, "1"), "qes": ("Qes", "values", {"": 1.0}, "1"),
    "q(ts)": ("Qts", "values", {"": 1.0}, "1"), "qts": ("Qts", "values", {"": 1.0}, "1"),
    "v(as)": ("Vas", "values", {"liters": 1e-3, "litres": 1e-3, "l": 1e-3}, "m^3"),
    "vas": ("Vas", "values", {"liters": 1e-3, "litres": 1e-3, "l": 1e-3}, "m^3"),
    "l(e)": ("Le", "values", {"mh": 1e-3}, "H"),
    "l10k": ("L10k", "extra", {"mh": 1e-3}, "H"),
    "n(0)": ("eta0", "values", {"%": 1e-2}, "1"), "n0": ("eta0", "values", {"%": 1e-2, "": 1e-2}, "1"),
    "spl": ("SPL", "values", {"1w/1m": 1.0, "db": 1.0}, "dB"),
    "dbspl": ("SPL", "values", {"1w/1m": 1.0, "db": 1.0, "": 1.0}, "dB"),
    "m(ms)": ("Mms", "values", {"grams": 1e-3, "g": 1e-3}, "kg"),
    "ms": ("Mms", "values", {"grams": 1e-3, "g": 1e-3}, "kg"),
    "c(ms)": ("Cms", "values", {"mm/n": 1e-3}, "m/N"), "cms": ("Cms", "values", {"mm/n": 1e-3}, "m/N"),
    "bl": ("Bl", "values", {"": 1.0, "n/a": 1.0, "tm": 1.0, "t m": 1.0}, "T m"),
    "pistondiameter": ("piston_diameter", "extra", _LENGTH_MM, "m"),
    "d": ("piston_diameter", "extra", _LENGTH_MM, "m"),
    "k(r)": ("K(r)", "extra", {"": 1.0}, "ohm (rad/s)^-X(r)"),
    "x(r)": ("X(r)", "extra", {"": 1.0}, "1"),
    "k(i)": ("K(i)", "extra", {"": 1.0}, "ohm (rad/s)^-X(i)"),
    "x(i)": ("X(i)", "extra", {"": 1.0}, "1"),
}
_NOTES = {"K(r)": "coil term: Re Z grows as K(r) omega^X(r) at high frequency (omega in rad/s; DATS's "
                  "convention for the real part is not documented)",
          "K(i)": "coil term: Im Z = K(i) omega^X(i) at high frequency (omega in rad/s)",
          "L10k": "inductance at 10 kHz, Im Z(10 kHz) / omega",
          "Zmax": "|Z| at the resonance"}


def _strip_mark(line: str) -> str:
    return line.lstrip().lstrip("%").lstrip().lstrip("*").strip()


def looks_like_dats(text: str) -> bool:
    """True for a DATS export: a ``*``/``%`` block naming DATS or holding two of its parameter lines,
    then the column line ``Freq Impedance Phase``."""
    hits = 0
    for line in text.splitlines()[:80]:
        s = line.strip()
        if not s:
            continue
        if _COLUMNS.match(s):
            return hits >= 2
        if s[0] not in "*%":
            return False
        if "dayton audio test system" in s.lower() or re.search(r"\bDATS\b", s):
            hits += 2
        elif _parse_param(_strip_mark(s)) is not None:
            hits += 1
    return False


def _parse_param(body: str):
    """``(key, value, unit)`` of one header parameter line, or ``None``."""
    m = _NEW.match(body)
    if m:
        key = m.group("key").lower().replace(" ", "")
        unit = re.sub(r"\(.*\)", "", m.group("unit")).strip().lower()
    else:
        m = _OLD.match(body)
        if not m:
            return None
        key = m.group("key").lower()
        unit = (m.group("unit") or "").strip().lower()
    if key not in _KEYS:
        return None
    return key, float(m.group("val")), unit


def _bench_fit(block: list[tuple[int, str]], path: Path, notices: list[str]) -> dict:
    values, extra = {}, {}
    for lineno, line in block:
        p = _parse_param(_strip_mark(line))
        if p is None:
            continue
        key, value, unit = p
        name, where, factors, si = _KEYS[key]
        if unit not in factors:
            notices.append(f"{path}:{lineno}: DATS parameter {key} in unknown unit {unit!r}: left out "
                           "of the bench's fit")
            continue
        if value == 0.0:  # DATS writes 0 for what it did not compute
            continue
        v = value * factors[unit]
        if where == "values":
            values[name] = v
        else:
            extra[name] = {"value": v, "unit": si}
            if name in _NOTES:
                extra[name]["note"] = _NOTES[name]
    d = extra.get("piston_diameter")
    if d is not None:
        extra["Sd"] = {"value": math.pi * d["value"] ** 2 / 4, "unit": "m^2",
                       "note": "piston area from the diameter, pi D^2 / 4"}
    return {"bench": "DATS", "source": str(path), "values": values, "extra": extra}


def read_dats(path: Path, text: str) -> Measurement:
    """Read a DATS impedance export (see the module docstring)."""
    lines = text.splitlines()
    block, col_line = [], None
    for i, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        if _COLUMNS.match(s):
            col_line = i
            break
        block.append((i, s))
    if col_line is None:  # looks_like_dats said otherwise
        raise DataFormatError(f"{path}: no 'Freq Impedance Phase' column line in this DATS export")
    body = []
    for i, line in enumerate(lines[col_line:], start=col_line + 1):
        s = line.strip()
        if s and s[0] not in "*%":
            body.append((i, s))
    if not body:
        raise DataFormatError(f"{path}: no data lines after the column line {col_line}")
    notices: list[str] = []
    arr = numeric_rows(body, None, 3, path, what="frequency [Hz], |Z| [ohm], phase [deg]")
    fit = _bench_fit(block, path, notices)
    style = "%" if block and block[0][1].startswith("%") else "*"
    meta = {"header": lines[col_line - 1].strip(), "n_header_lines": body[0][0] - 1, "bench_fit": fit,
            "header_style": style}
    return bench_measurement(path, arr, [i for i, _ in body], fmt="dats", notices=notices, meta=meta)

