"""Shared text handling for the readers: decoding, splitting, numeric rows and their checks.

Every problem raises :class:`~bayes_emt.errors.DataFormatError` as ``path:line: what is wrong``
(``path: what is wrong`` when no single line is to blame).
"""

from __future__ import annotations

import math
import os
import re
import stat
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement

__all__ = ["MIN_POINTS", "read_text", "split_cells", "detect_delimiter", "numeric_rows", "check_rows",
           "check_scale", "finish", "MAX_FREQ_HZ", "Z_RANGE_OHM"]

MIN_POINTS = 3
MAX_FREQ_HZ = 1e12  # no electromechanical transducer is measured above 1 THz
# |Z| outside this range [ohm] is a scaling or unit error, not a transducer (and its square, in the
# fit, would under- or overflow)
Z_RANGE_OHM = (1e-9, 1e12)
_KIND = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
         (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
_DECIMAL_COMMA = re.compile(r"^[-+]?\d*,\d+(?:[eE][-+]?\d+)?$")
_BOMS = ((b"\xff\xfe\x00\x00", "utf-32-le"), (b"\x00\x00\xfe\xff", "utf-32-be"), (b"\xff\xfe", "utf-16-le"),
         (b"\xfe\xff", "utf-16-be"))


def _wide_encoding(raw: bytes) -> str | None:
    """UTF-16/32 by byte-order mark, or UTF-16 without one by its pattern (ASCII text in UTF-16
    has a NUL in every other byte); ``None`` otherwise."""
    for bom, enc in _BOMS:
        if raw.startswith(bom):
            return enc
    head = raw[:4096]
    n = len(head) // 2 * 2
    if n < 8:
        return None
    even, odd = head[0:n:2], head[1:n:2]
    if odd.count(0) > 0.9 * len(odd) and even.count(0) == 0:
        return "utf-16-le"
    if even.count(0) > 0.9 * len(even) and odd.count(0) == 0:
        return "utf-16-be"
    return None


def read_text(path: Path) -> str:
    """The file's text (UTF-8, Latin-1, or UTF-16/32 with or without a byte-order mark); raise for
    a missing, empty, folder or binary file."""
    try:
        mode = os.stat(path).st_mode  # stat never blocks, an open of a FIFO does (for good)
    except FileNotFoundError:
        raise DataFormatError(f"{path}: no such file") from None
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise DataFormatError(f"{path}: is a folder, not a measurement file")
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KIND if test(mode)), "not a regular file")
        raise DataFormatError(f"{path}: is {kind}, not a measurement file (only regular files are read)")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not raw.strip():
        raise DataFormatError(f"{path}: empty file")
    wide = _wide_encoding(raw)
    if wide is not None:
        try:
            text = raw[len(next((b for b, e in _BOMS if e == wide and raw.startswith(b)), b"")):].decode(wide)
        except UnicodeDecodeError as exc:
            raise DataFormatError(f"{path}: looks like {wide.upper()} text but does not decode "
                                  f"({exc.reason} at byte {exc.start})") from None
        if not text.strip():
            raise DataFormatError(f"{path}: empty file")
        return text
    nul = raw.find(b"\x00", 0, 65536)
    if nul >= 0:
        line = raw[:nul].count(b"\n") + 1
        raise DataFormatError(f"{path}:{line}: binary file (NUL bytes), "
                              "not a text measurement export")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        # Latin-1 exports (a '°' or 'Ω' in the header) decode; a binary file has control bytes
        text = raw.decode("latin-1")
        ctrl = sum(ch < " " and ch not in "\t\r\n\f" for ch in text[:65536])
        if ctrl > 8:
            line = raw[:exc.start].count(b"\n") + 1
            raise DataFormatError(f"{path}:{line}: binary file (undecodable bytes), "
                                  "not a text measurement export") from None
        return text


def detect_delimiter(line: str) -> str | None:
    """Tab, semicolon or comma (in that order), else ``None`` for runs of spaces."""
    for d in ("\t", ";", ","):
        if d in line:
            return d
    return None


def split_cells(line: str, delim: str | None) -> list[str]:
    """Cells of one line; a trailing delimiter adds no empty cell."""
    if delim is None:
        return line.split()
    cells = [c.strip() for c in line.split(delim)]
    if len(cells) > 1 and cells[-1] == "":
        cells.pop()
    return cells


def uses_decimal_comma(line: str, delim: str | None) -> bool:
    """True for ``10,5;3,2;45`` or tab/space-separated ``10,5 3,2``: commas are decimal marks
    (a ``.`` elsewhere on such a line is then a thousands separator, which
    :func:`numeric_rows` refuses)."""
    return delim != "," and any(_DECIMAL_COMMA.match(c) for c in split_cells(line, delim))


def is_numeric_line(line: str, delim: str | None, decimal_comma: bool = False) -> bool:
    """True when every cell of ``line`` parses as a float (``nan`` and ``inf`` included)."""
    cells = split_cells(line, delim)
    try:
        for c in cells:
            float(c.replace(",", ".") if decimal_comma else c)
    except ValueError:
        return False
    return bool(cells)


def numeric_rows(lines: list[tuple[int, str]], delim: str | None, ncols: int, path: Path, *,
                 decimal_comma: bool = False, what: str = "") -> np.ndarray:
    """Parse ``(line number, text)`` pairs into an ``(n, ncols)`` float array, checking each cell.

    ``what`` names the expected columns in the wrong-count message.
    """
    out = np.empty((len(lines), ncols))
    for r, (lineno, text) in enumerate(lines):
        cells = split_cells(text, delim)
        if len(cells) != ncols:
            raise DataFormatError(f"{path}:{lineno}: expected {ncols} columns, found {len(cells)}"
                                  + (f" ({what})" if what else ""))
        for c, cell in enumerate(cells):
            if decimal_comma and "." in cell:
                raise DataFormatError(f"{path}:{lineno}: {cell!r} has a '.' although this file's decimal "
                                      "mark is ',': is '.' a thousands separator? Export the numbers "
                                      "without thousands separators")
            try:
                v = float(cell.replace(",", ".") if decimal_comma else cell)
            except ValueError:
                raise DataFormatError(f"{path}:{lineno}: not a number: {cell!r}") from None
            if not math.isfinite(v):
                raise DataFormatError(f"{path}:{lineno}: non-finite value {cell!r}")
            out[r, c] = v
    return out


def check_rows(arr: np.ndarray, linenos: list[int], path: Path, *, magnitude_col: int | None,
               notices: list[str] | None = None) -> tuple[np.ndarray, list[int]]:
    """Point count, positive frequencies (column 0), positive magnitudes, and duplicate frequencies:
    a row repeated exactly is dropped with a notice (and a warning), a frequency given two
    different values is an error naming both lines. Returns the rows kept and their line numbers."""
    if arr.shape[0] < MIN_POINTS:
        raise DataFormatError(f"{path}: only {arr.shape[0]} data points (need at least {MIN_POINTS})")
    bad = np.flatnonzero(arr[:, 0] <= 0)
    if bad.size:
        raise DataFormatError(f"{path}:{linenos[bad[0]]}: non-positive frequency {arr[bad[0], 0]:g}")
    if magnitude_col is not None:
        bad = np.flatnonzero(arr[:, magnitude_col] <= 0)
        if bad.size:
            raise DataFormatError(f"{path}:{linenos[bad[0]]}: non-positive magnitude "
                                  f"{arr[bad[0], magnitude_col]:g}")
    seen: dict[float, int] = {}
    keep = []
    for i, f in enumerate(arr[:, 0]):
        if f in seen:
            j = seen[f]
            if np.array_equal(arr[i], arr[j]):
                msg = (f"{path}:{linenos[i]}: repeats line {linenos[j]} exactly (frequency {f:g}); "
                       "read once")
                warnings.warn(msg, UserWarning, stacklevel=4)
                if notices is not None:
                    notices.append(msg)
                continue
            raise DataFormatError(f"{path}:{linenos[i]}: duplicate frequency {f:g} "
                                  f"(also on line {linenos[j]}) with different values")
        seen[f] = i
        keep.append(i)
    if len(keep) < arr.shape[0]:
        arr, linenos = arr[keep], [linenos[i] for i in keep]
        if arr.shape[0] < MIN_POINTS:
            raise DataFormatError(f"{path}: only {arr.shape[0]} distinct data points (need at least "
                                  f"{MIN_POINTS})")
    return arr, linenos


def check_scale(freq_hz: np.ndarray, Z_abs: np.ndarray, linenos: list[int], path: Path) -> None:
    """Refuse a frequency above :data:`MAX_FREQ_HZ` or a finite |Z| outside :data:`Z_RANGE_OHM`
    (an absurd scale that overflows later), naming the line. Values may be inf (an overflow
    while converting): that is refused too."""
    with np.errstate(over="ignore", invalid="ignore"):
        bad = np.flatnonzero(~(freq_hz <= MAX_FREQ_HZ))
    if bad.size:
        i = bad[0]
        raise DataFormatError(f"{path}:{linenos[i]}: frequency {freq_hz[i]:.4g} Hz is beyond any "
                              f"transducer's band (at most {MAX_FREQ_HZ:g} Hz)"
                              "; check the frequency column's unit")
    lo, hi = Z_RANGE_OHM
    with np.errstate(over="ignore", invalid="ignore"):
        bad = np.flatnonzero(~((Z_abs >= lo) & (Z_abs <= hi)))
    if bad.size:
        i = bad[0]
        raise DataFormatError(f"{path}:{linenos[i]}: |Z| = {Z_abs[i]:.4g} ohm is outside {lo:g}..{hi:g} ohm, "
                              "no transducer's impedance: check the values' unit or scale")


def finish(omega: np.ndarray, Y: np.ndarray, linenos: list[int], path: Path, meta: dict,
           notices: list[str], weights: np.ndarray | None = None) -> Measurement:
    """The :class:`Measurement`, sorted by frequency with a warning (and a notice) when needed."""
    bad = np.flatnonzero(~np.isfinite(Y) | (Y == 0))
    if bad.size:
        raise DataFormatError(f"{path}:{linenos[bad[0]]}: value maps to an infinite or zero "
                              "impedance/admittance")
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        check_scale(omega / (2 * math.pi), 1.0 / np.abs(Y), linenos, path)
    down = np.flatnonzero(np.diff(omega) < 0)
    if down.size:
        msg = (f"{path}:{linenos[down[0] + 1]}: frequencies are not in increasing order; "
               "sorted them")
        warnings.warn(msg, UserWarning, stacklevel=4)
        notices.append(msg)
        order = np.argsort(omega, kind="stable")
        omega, Y = omega[order], Y[order]
        weights = None if weights is None else weights[order]
    return Measurement(omega, Y, weights=weights, meta={**meta, "notices": tuple(notices)})
