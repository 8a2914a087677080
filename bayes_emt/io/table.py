"""Text tables: ``.zma``, CSV/TSV exports with a header line, and the native CSV.

Lines starting with ``*``, ``#`` or ``!`` are comments. The first other line is a header when it
is not all numbers; failing that, a comment line just before the data that reads as a header
(``* freq(Hz) |Z|(ohm) phase(deg)``) names the columns, with a notice. Units come from the header
(:mod:`.header`), from the caller's options when the header does not say, or, for a ``.zma``
file, from that format's convention (frequency Hz, |Z| Ω, phase degrees); the source of each is
recorded in ``meta["units_from"]``. Anything still unknown raises, naming the option to pass: a
file is never read under a guessed unit.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement
from ._rows import (
    check_rows,
    check_scale,
    detect_delimiter,
    finish,
    is_numeric_line,
    numeric_rows,
    split_cells,
    uses_decimal_comma,
)
from .header import Layout, freq_scale, parse_header
from .resolution import resolution_band

__all__ = ["read_table", "NATIVE_HEADER", "NATIVE_MARKER"]

NATIVE_HEADER = "omega_rad_s,Y_real_S,Y_imag_S"
NATIVE_MARKER = "bayes_emt measurement"
ZMA_CONVENTION = {"freq_unit": "hz", "quantity": "Z", "phase_unit": "deg"}
_NAMES = {"freq_unit": ("frequency unit", "freq-unit", "hz|rad/s"),
          "phase_unit": ("phase unit", "phase-unit", "deg|rad"),
          "quantity": ("quantity", "quantity", "Z|Y")}
_SAYS = {"freq_unit": "whether frequencies are in Hz or rad/s",
         "phase_unit": "whether the phase is in degrees or radians",
         "quantity": "whether the values are impedance Z or admittance Y"}
_THOUSANDS = re.compile(r"^\d{1,3}(?:\.\d{3})+$")
_PASSIVE_TOL = 1e-3  # Re Z below -0.1 % of |Z| (phase beyond +-90.06 deg) is not rounding
_LABEL = {"hz": "Hz", "khz": "kHz", "mhz": "MHz", "ghz": "GHz", "rad/s": "rad/s", "deg": "degrees",
          "rad": "radians", "Z": "impedance Z", "Y": "admittance Y"}


def _merge(lay: Layout, options: dict, *, where: str, is_zma: bool, notices: list[str]) -> Layout:
    """Combine what the header says with the caller's options (and the .zma convention)."""
    for attr, given in options.items():
        if given is None:
            continue
        have = getattr(lay, attr)
        if lay.units_from.get(attr) == "header" and have != given:
            name, opt, _ = _NAMES[attr]
            raise DataFormatError(f"{where} says the {name} is {_LABEL[have]}, but --{opt} {given} "
                                  "was given")
        if is_zma and given != ZMA_CONVENTION[attr] and attr not in lay.units_from:
            notices.append(f"--{_NAMES[attr][1]} {given} overrides the .zma convention "
                           f"({_LABEL[ZMA_CONVENTION[attr]]})")
        lay.state(attr, given, lay.units_from.get(attr, "option"))
    needed = ["freq_unit", "quantity"] + (["phase_unit"] if lay.rep == "magphase" else [])
    if is_zma:
        filled = [a for a in needed if getattr(lay, a) is None]
        for a in filled:
            lay.state(a, ZMA_CONVENTION[a], "zma convention")
        if filled:
            notices.append("read by the .zma convention: "
                           + ", ".join(f"{_NAMES[a][0]} {_LABEL[ZMA_CONVENTION[a]]}" for a in filled))
    missing = [a for a in needed if getattr(lay, a) is None]
    if missing:
        raise DataFormatError(f"{where} does not say " + "; nor ".join(
            f"{_SAYS[a]}; pass --{_NAMES[a][1]} {_NAMES[a][2]}" for a in missing))
    return lay


def _written_meta(comments: list[str]) -> dict:
    """The ``# meta: {...}`` (or ``* meta:``) line :func:`write_measurement` adds, if any."""
    for c in comments:
        if c[1:].lstrip().startswith("meta:"):
            try:
                m = json.loads(c[1:].lstrip()[len("meta:"):])
            except json.JSONDecodeError:
                return {}
            if isinstance(m, dict):
                m.pop("source", None)
                m.pop("notices", None)
                return {"written_meta": m}
    return {}


def _comment_header(comment: tuple[int, str], first_data: int, text: str,
                    path: Path) -> tuple[int | None, str | None]:
    """A comment line right before the data that reads as a header (``* Freq(Hz) Ohm Deg``)."""
    lineno, line = comment
    between = text.splitlines()[lineno:first_data - 1]
    if any(ln.strip() for ln in between):
        return None, None
    cand = line.lstrip("*#! \t")
    try:
        parse_header(split_cells(cand, detect_delimiter(cand)), f"{path}:{lineno}")
    except DataFormatError:
        return None, None  # an ordinary comment
    return lineno, cand


_SPL = re.compile(r"(?<![a-z])(spl|db\s*spl|dbspl|sound[\s_-]*pressure|db\s*\(?\s*20\s*µ?u?pa|"
                  r"pa/v|db/v|db\s*re\s*20)", re.IGNORECASE)


_PARAM_LINE = re.compile(r"^[*#!%\s]*[a-z][\w()]*\s*(?:=\s*|\s+)[-+]?\d", re.IGNORECASE)


def _refuse_sound_pressure(path: Path, comments: list[str], header: str | None, header_line) -> None:
    """An SPL / frequency-response export (``.frd``, or a header or comment naming SPL or sound
    pressure) is refused as such: it holds the acoustic output, not the electrical impedance."""
    where = None
    if path.suffix.lower() == ".frd":
        where = f"{path}: a .frd file"
    elif header is not None and _SPL.search(header):
        where = f"{path}:{header_line}: header {header!r}"
    else:
        # a parameter line ('* SPL= 0 1W/1m', '% dBSPL 88') of a bench's fit block names no column
        hit = next((c for c in comments if _SPL.search(c) and not _PARAM_LINE.match(c)), None)
        if hit is not None:
            where = f"{path}: comment {hit[:60]!r}"
    if where is not None:
        raise DataFormatError(f"{where}: a sound-pressure (SPL) frequency response, not an impedance; "
                              "export the impedance (|Z| and phase, or Z/Y parts) of the same measurement")


def read_table(path: Path, text: str, options: dict, *, is_zma: bool) -> Measurement:
    """Read a ``.zma`` or delimited text table; ``options`` holds normalised ``freq_unit``,
    ``phase_unit`` and ``quantity`` (``None`` where not given)."""
    comments, body, last_comment = [], [], None
    for i, ln in enumerate(text.splitlines(), start=1):
        s = ln.strip()
        if not s:
            continue
        if s[0] in "*#!":
            comments.append(s)
            last_comment = (i, s)
        else:
            body.append((i, s))
    if not body:
        raise DataFormatError(f"{path}: no data lines (only a header or comments)")
    header_line, header, notices = None, None, []
    d0 = detect_delimiter(body[0][1])
    if not is_numeric_line(body[0][1], d0, uses_decimal_comma(body[0][1], d0)):
        header_line, header = body.pop(0)
        if not body:
            raise DataFormatError(f"{path}: no data lines (only a header)")
    elif last_comment is not None and last_comment[0] < body[0][0]:
        header_line, header = _comment_header(last_comment, body[0][0], text, path)
        if header is not None:
            notices.append(f"column names taken from comment line {header_line}")
    _refuse_sound_pressure(path, comments, header, header_line)
    delim = detect_delimiter(body[0][1])
    decimal_comma = any(uses_decimal_comma(ln, delim) for _, ln in body)
    if decimal_comma:
        notices.append("decimal commas read as decimal points")
    if header is not None:
        where = f"{path}:{header_line}: header {header!r}"
        lay = parse_header(split_cells(header, detect_delimiter(header)), f"{path}:{header_line}")
    else:
        where = f"{path}: no header line"
        lay = Layout(rep="magphase")
        given = [a for a, v in options.items() if v is not None]
        if not is_zma and len(given) < 3:
            hint = " (if it is a .zma export, Hz/ohm/deg, name it .zma)" if any(
                c.startswith("*") for c in comments) else ""
            raise DataFormatError(
                f"{where}, so nothing says what the columns hold; for frequency, magnitude, phase "
                "columns pass " + ", ".join(f"--{_NAMES[a][1]} {_NAMES[a][2]}" for a in _NAMES
                                              if a not in given)
                + f", or add a header such as 'Frequency (Hz),|Z| (ohm),Phase (deg)'{hint}")
    lay = _merge(lay, options, where=where, is_zma=is_zma, notices=notices)
    ncols = 4 if lay.weights else 3
    what = ("frequency, " + ("magnitude, phase" if lay.rep == "magphase" else "real, imaginary")
            + (", weight" if lay.weights else ""))
    arr = numeric_rows(body, delim, ncols, path, decimal_comma=decimal_comma, what=what)
    linenos = [ln for ln, _ in body]
    _check_thousands_separator(arr[:, 0], body, delim, path)
    arr, linenos = check_rows(arr, linenos, path, notices=notices,
                              magnitude_col=lay.cols[0] if lay.rep == "magphase" else None)
    to_hz = 1 / (2 * math.pi) if lay.freq_unit == "rad/s" else freq_scale(lay.freq_unit)
    repeated = _note_resolution_rows(arr, linenos, path, notices, to_hz)
    a, b = arr[:, lay.cols[0]] * (lay.scale * lay.signs[0]), arr[:, lay.cols[1]] * lay.signs[1]
    if min(lay.signs) < 0:
        notices.append("values of the column(s) named with a leading minus were negated")
    # absurd scales (1e300 Hz, |Z| = 1e-320) are refused by name, not by numpy's overflow warnings
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        if lay.freq_unit == "rad/s":
            omega = arr[:, 0].copy()
        else:
            omega = 2 * math.pi * freq_scale(lay.freq_unit) * arr[:, 0]
        if lay.rep == "magphase":
            val = a * np.exp(1j * _phase_radians(b, lay, linenos, path, notices))
        else:
            val = a + 1j * b * lay.scale
            bad = np.flatnonzero(val == 0)
            if bad.size:
                raise DataFormatError(f"{path}:{linenos[bad[0]]}: zero impedance/admittance (both parts 0)")
        check_scale(omega / (2 * math.pi), np.abs(val) if lay.quantity == "Z" else 1.0 / np.abs(val),
                    linenos, path)
    weights = None
    if lay.weights:
        weights = arr[:, 3]
        bad = np.flatnonzero(weights <= 0)
        if bad.size:
            raise DataFormatError(f"{path}:{linenos[bad[0]]}: non-positive weight {weights[bad[0]]:g}")
    native = header == NATIVE_HEADER or (header or "").startswith(NATIVE_HEADER + ",")
    fmt = "zma" if is_zma else "native" if native and any(NATIVE_MARKER in c for c in comments) else \
        {"\t": "tsv", None: "text"}.get(delim, "csv")
    meta = {"source": str(path), "format": fmt, "freq_unit": lay.freq_unit,
            "phase_unit": lay.phase_unit if lay.rep == "magphase" else None,
            "quantity": lay.quantity, "representation": lay.rep, "units_from": dict(lay.units_from),
            "header": header, "n_header_lines": body[0][0] - 1, **_written_meta(comments),
            **({"repeated_band_hz": repeated} if repeated else {})}
    if lay.scale != 1.0:
        notices.append(f"values scaled by {lay.scale:g} to {'ohm' if lay.quantity == 'Z' else 'S'} "
                       "as the header's unit says")
    Y = 1.0 / val if lay.quantity == "Z" else val
    _check_passive(Y, linenos, path, notices)
    return finish(omega, Y, linenos, path, meta, notices, weights)


def _note_resolution_rows(arr: np.ndarray, linenos: list[int], path: Path, notices: list[str],
                          to_hz: float) -> list[float] | None:
    """Name the low band whose rows repeat one another (:mod:`.resolution`) in one warning: in a
    plain table nothing says which analyser wrote it, so the rows are kept (the bench readers,
    which know, drop them) and the warning says how to leave them out. Returns the band [Hz]."""
    order = np.argsort(arr[:, 0], kind="stable")
    s = arr[order]
    k = resolution_band(s[:, 0], s[:, 1], s[:, 2])
    if not k:
        return None
    f_hz = s[:, 0] * to_hz
    msg = (f"{path}: rows {f_hz[0]:.4g}-{f_hz[k - 1]:.4g} Hz repeat the same values in runs, as a bench "
           "writes below its analyser's resolution (copies, not measurements); they are kept: pass "
           f"--omega-min {2 * math.pi * f_hz[k]:.4g} (rad/s, {f_hz[k]:.4g} Hz) to leave them out")
    notices.append(msg)
    warnings.warn(msg, UserWarning, stacklevel=4)
    return [float(f_hz[0]), float(f_hz[k - 1])]


def _check_thousands_separator(freq: np.ndarray, body: list[tuple[int, str]], delim, path: Path) -> None:
    """Refuse a frequency that falls below its predecessor and is written like ``1.000``: a '.'
    thousands separator read as a decimal point (1.000 Hz after 500 Hz, meaning 1000 Hz).

    Only when reading every such '.' as a separator makes the whole sweep rise: a sweep written
    from high to low frequency, or with rows out of order, is valid data (sorted, with a notice,
    by ``finish``)."""
    cells = [split_cells(text, delim)[0] for _, text in body]
    alt = np.array([float(c.replace(".", "")) if _THOUSANDS.match(c) else f
                    for c, f in zip(cells, freq, strict=True)])
    if not np.all(np.diff(alt) > 0):
        return
    for i in np.flatnonzero(np.diff(freq) < 0) + 1:
        cell = cells[i]
        if _THOUSANDS.match(cell):
            raise DataFormatError(
                f"{path}:{body[i][0]}: frequency {cell!r} reads as {freq[i]:g}, below the {freq[i - 1]:g} of "
                f"line {body[i - 1][0]}: is '.' a thousands separator ({cell} = {cell.replace('.', '')})? "
                "Export the numbers without thousands separators")


def _check_passive(Y: np.ndarray, linenos: list[int], path: Path, notices: list[str]) -> None:
    """Re Z (equivalently Re Y) below zero is impossible for a passive transducer: refuse a file
    where most points are so (a phase offset or sign convention, not the device), warn otherwise
    (a calibration error at a few points), naming the first line."""
    with np.errstate(divide="ignore", invalid="ignore"):
        Z = 1.0 / Y
    bad = np.flatnonzero(Z.real < -_PASSIVE_TOL * np.abs(Z))
    if not bad.size:
        return
    i = bad[0]
    what = (f"{path}:{linenos[i]}: Re Z = {Z[i].real:.4g} ohm < 0 (|Z| = {abs(Z[i]):.4g} ohm, phase "
            f"{math.degrees(np.angle(Z[i])):.4g} deg) at {bad.size} of {Y.size} points; a passive transducer "
            "has Re Z >= 0 (phase within +-90 deg)")
    if bad.size > Y.size / 2:
        raise DataFormatError(what + ": check the phase column's sign, unit and reference")
    msg = what + ": check the instrument's calibration there, or leave those points out (--omega-min/max)"
    warnings.warn(msg, UserWarning, stacklevel=4)
    notices.append(msg)


def _phase_radians(ph: np.ndarray, lay: Layout, linenos: list[int], path: Path,
                   notices: list[str]) -> np.ndarray:
    """Phase column in radians, refusing values that cannot be in the declared unit."""
    source = "the header says" if lay.units_from.get("phase_unit") == "header" else \
        "--phase-unit says" if lay.units_from.get("phase_unit") == "option" else "the .zma convention says"
    peak = int(np.argmax(np.abs(ph)))
    if lay.phase_unit == "rad":
        if abs(ph[peak]) > 2 * math.pi + 1e-9:
            raise DataFormatError(f"{path}:{linenos[peak]}: phase {ph[peak]:g} is beyond 2π, so it "
                                  f"is not in radians as {source}; is it in degrees?")
        return ph
    # a passive device's phase lies within +-90 deg (+-pi/2 rad): a degree column that never leaves
    # +-pi is suspect when long; a short one is judged against +-pi/2 (5 % slack for noise)
    limit = math.pi if ph.size > 20 else 1.05 * math.pi / 2
    if 0 < abs(ph[peak]) <= limit:
        bound = "π" if ph.size > 20 else "π/2 (+5 %), a passive device's range in radians,"
        msg = (f"{path}:{linenos[peak]}: the phase is in degrees as {source}, but its largest magnitude, "
               f"{ph[peak]:g}, does not exceed {bound} over {ph.size} points: check that it is not in "
               "radians")
        warnings.warn(msg, UserWarning, stacklevel=4)
        notices.append(msg)
    return np.deg2rad(ph)
