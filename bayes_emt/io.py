"""Reading and writing measurement files.

Formats met in practice (SPEC §6):

* ``.zma``: frequency [Hz], |Z| [Ω], phase [deg] by the format's convention; ``*`` header lines;
  tab- or space-separated; sometimes no header at all.
* CSV/TSV with a header line (LCR-meter and audio-analyser exports): magnitude/phase or
  real/imaginary, impedance or admittance, Hz or rad/s, degrees or radians. Units are taken from
  the header when it states them (``Frequency (Hz)``, ``Z_rad``, ``Re(Y)``, ...); otherwise the
  caller must say (``freq_unit``, ``phase_unit``, ``quantity``) — never guessed silently.
* Touchstone ``.s1p`` (S, Z or Y parameters; MA, DB or RI; Hz … GHz; reference resistance).
* The native CSV written by :func:`write_measurement` (``omega_rad_s,Y_real_S,Y_imag_S``).

Every problem raises :class:`~bayes_emt.errors.DataFormatError` with ``path:line: what is wrong``.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from ._atomic import atomic_path
from .data import Measurement
from .errors import DataFormatError

__all__ = ["read_measurement", "write_measurement"]

FreqUnit = Literal["hz", "rad/s"]
PhaseUnit = Literal["deg", "rad"]
Quantity = Literal["Z", "Y"]
MIN_POINTS = 3
_FREQ_SCALE = {"hz": 1.0, "khz": 1e3, "mhz": 1e6, "ghz": 1e9}


@dataclass
class _Layout:
    """What the columns hold: representation, quantity and units (None = not stated)."""

    freq_unit: str | None = None
    rep: str | None = None  # "magphase" or "reim"
    quantity: str | None = None
    phase_unit: str | None = None
    weights: bool = False


def _word(t: str, w: str) -> bool:
    return re.search(rf"(?<![a-z]){re.escape(w)}(?![a-z])", t) is not None


def _parse_header(cells: list[str], where: str) -> _Layout:
    t = [c.strip().lower() for c in cells]
    lay = _Layout()
    f = t[0]
    if not any(k in f for k in ("freq", "omega")) and not _word(f, "f") and not _word(f, "w"):
        raise DataFormatError(f"{where}: first column {cells[0]!r} is not a frequency column")
    if "rad/s" in f or "rad_s" in f or "omega" in f or _word(f, "w"):
        lay.freq_unit = "rad/s"
    elif _word(f, "hz"):
        lay.freq_unit = "hz"
    elif any(_word(f, u) for u in ("khz", "mhz", "ghz")):
        lay.freq_unit = next(u for u in ("khz", "mhz", "ghz") if _word(f, u))
    kinds = []
    for c in t[1:3]:
        if _word(c, "re") or _word(c, "real") or c.startswith("re("):
            kinds.append("re")
        elif _word(c, "im") or _word(c, "imag") or c.startswith("im("):
            kinds.append("im")
        elif any(k in c for k in ("phase", "arg", "deg", "°")) or _word(c, "rad") or _word(c, "ang"):
            kinds.append("phase")
        elif any(k in c for k in ("|", "mag", "abs", "ohm", "Ω", "imped", "admit")):
            kinds.append("mag")
        else:
            raise DataFormatError(f"{where}: cannot tell what column {c!r} holds "
                                  "(expected magnitude/phase or real/imaginary parts)")
    if kinds == ["mag", "phase"]:
        lay.rep = "magphase"
    elif kinds == ["re", "im"]:
        lay.rep = "reim"
    else:
        raise DataFormatError(f"{where}: columns {cells[1:3]} are neither magnitude+phase nor real+imaginary")
    q = set()
    for c in t[1:3]:
        if _word(c, "z") or "imped" in c or "ohm" in c or "Ω" in c:
            q.add("Z")
        if _word(c, "y") or "admit" in c or "siemens" in c or _word(c, "s") and not _word(c, "rad"):
            q.add("Y")
    if len(q) > 1:
        raise DataFormatError(f"{where}: header {cells[1:3]} mentions both impedance and admittance")
    lay.quantity = q.pop() if q else None
    if lay.rep == "magphase":
        p = t[2]
        if "deg" in p or "°" in p:
            lay.phase_unit = "deg"
        elif _word(p, "rad"):
            lay.phase_unit = "rad"
    if len(t) == 4:
        if "weight" not in t[3]:
            raise DataFormatError(f"{where}: unexpected fourth column {cells[3]!r} "
                                  "(only 'weight' is allowed)")
        lay.weights = True
    return lay


def _merge(lay: _Layout, *, freq_unit, phase_unit, quantity, path) -> _Layout:
    """Combine header units with the caller's; contradictions and gaps raise."""
    for name, given, opt in (("frequency unit", freq_unit, "freq-unit"),
                             ("phase unit", phase_unit, "phase-unit"), ("quantity", quantity, "quantity")):
        attr = {"frequency unit": "freq_unit", "phase unit": "phase_unit", "quantity": "quantity"}[name]
        have = getattr(lay, attr)
        if given is not None:
            given_n = given.lower() if attr != "quantity" else given.upper()
            if have is not None and have != given_n:
                raise DataFormatError(f"{path}: the header says the {name} is {have!r}, "
                                      f"but --{opt} {given} was given")
            setattr(lay, attr, given_n)
    missing = []
    if lay.freq_unit is None:
        missing.append("whether frequencies are in Hz or rad/s; pass --freq-unit hz|rad/s")
    if lay.quantity is None:
        missing.append("whether the data are impedance or admittance; pass --quantity Z|Y")
    if lay.rep == "magphase" and lay.phase_unit is None:
        missing.append("whether the phase is in degrees or radians; pass --phase-unit deg|rad")
    if missing:
        raise DataFormatError(f"{path}: the file does not say " + "; nor ".join(missing))
    return lay


def _read_text(path: Path) -> str:
    if not path.exists():
        raise DataFormatError(f"{path}: no such file")
    if path.is_dir():
        raise DataFormatError(f"{path}: is a folder, not a measurement file")
    raw = path.read_bytes()
    if not raw.strip():
        raise DataFormatError(f"{path}: empty file")
    if b"\x00" in raw[:4096]:
        raise DataFormatError(f"{path}: binary file (not a text measurement export)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
        ctrl = sum(ch < " " and ch not in "\t\r\n" for ch in text[:4096])
        if ctrl > 8:
            raise DataFormatError(f"{path}: binary file (not a text measurement export)") from None
        return text


def _split(line: str, delim: str | None) -> list[str]:
    return [c.strip() for c in line.split(delim)] if delim else line.split()


def _numeric_rows(lines, delim, ncols, path):
    """Parse ``(lineno, text)`` lines into a float array, validating each cell."""
    rows = []
    for lineno, text in lines:
        cells = _split(text, delim)
        if delim and cells and cells[-1] == "":
            cells = cells[:-1]  # trailing delimiter
        if len(cells) != ncols:
            raise DataFormatError(f"{path}:{lineno}: expected {ncols} columns, found {len(cells)}")
        vals = []
        for c in cells:
            try:
                v = float(c)
            except ValueError:
                raise DataFormatError(f"{path}:{lineno}: not a number: {c!r}") from None
            if not math.isfinite(v):
                raise DataFormatError(f"{path}:{lineno}: non-finite value {c!r}")
            vals.append(v)
        rows.append(vals)
    return np.array(rows, dtype=float).reshape(-1, ncols)


def _check_rows(arr, linenos, path, *, magnitude_col: int | None):
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
    for i, f in enumerate(arr[:, 0]):
        if f in seen:
            raise DataFormatError(f"{path}:{linenos[i]}: duplicate frequency {f:g} "
                                  f"(also on line {linenos[seen[f]]})")
        seen[f] = i


def _detect_delim(line: str) -> str | None:
    for d in (",", ";", "\t"):
        if d in line:
            return d
    return None


def _read_table(path: Path, text: str, freq_unit, phase_unit, quantity) -> Measurement:
    lines = text.splitlines()
    is_zma = path.suffix.lower() == ".zma"
    comments, body = [], []
    for i, ln in enumerate(lines, start=1):
        s = ln.strip()
        if not s:
            continue
        if s[0] in "*#!":
            comments.append(s)
        else:
            body.append((i, s))
    if not body:
        raise DataFormatError(f"{path}: no data lines (only a header or comments)")
    header_line, header = None, None
    first = body[0][1]
    if re.search(r"[A-Za-z|(]", first) and not re.fullmatch(r"[-+0-9.eE,;\s\t]+", first):
        header_line, header = body.pop(0)
        if not body:
            raise DataFormatError(f"{path}: no data lines (only a header)")
    delim = _detect_delim(header if header is not None else body[0][1])
    if header is not None:
        cells = [c for c in _split(header, delim) if c != ""] if delim is None else _split(header, delim)
        if len(cells) not in (3, 4):
            raise DataFormatError(f"{path}:{header_line}: header has {len(cells)} columns; "
                                  "expected frequency and two value columns")
        lay = _parse_header(cells, f"{path}:{header_line}")
    elif is_zma:
        lay = _Layout("hz", "magphase", "Z", "deg")  # the .zma convention
    else:
        lay = _Layout(rep="magphase")
        if None in (freq_unit, phase_unit, quantity):
            raise DataFormatError(
                f"{path}: no header line, so the columns' meaning is unknown; add a header "
                "(e.g. 'Frequency (Hz),|Z| (ohm),Phase (deg)') or pass --freq-unit, --phase-unit "
                "and --quantity for a frequency, magnitude, phase file")
    lay = _merge(lay, freq_unit=freq_unit, phase_unit=phase_unit, quantity=quantity, path=path)
    ncols = 4 if lay.weights else 3
    arr = _numeric_rows(body, delim, ncols, path)
    linenos = [ln for ln, _ in body]
    _check_rows(arr, linenos, path, magnitude_col=1 if lay.rep == "magphase" else None)
    f = arr[:, 0] * _FREQ_SCALE.get(lay.freq_unit, 1.0)
    omega = f if lay.freq_unit == "rad/s" else 2 * math.pi * f
    if lay.rep == "magphase":
        ph = np.deg2rad(arr[:, 2]) if lay.phase_unit == "deg" else arr[:, 2]
        if lay.phase_unit == "deg" and np.max(np.abs(arr[:, 2])) <= math.pi and arr.shape[0] > 20 \
                and np.max(np.abs(arr[:, 2])) > 0:
            warnings.warn(f"{path}: phase declared in degrees but never exceeds pi; "
                          "check --phase-unit", UserWarning, stacklevel=3)
        val = arr[:, 1] * np.exp(1j * ph)
    else:
        val = arr[:, 1] + 1j * arr[:, 2]
        bad = np.flatnonzero(val == 0)
        if bad.size:
            raise DataFormatError(f"{path}:{linenos[bad[0]]}: zero impedance/admittance")
    Y = 1.0 / val if lay.quantity == "Z" else val
    meta = {"source": str(path), "format": "zma" if is_zma else "table",
            "freq_unit": lay.freq_unit, "phase_unit": lay.phase_unit, "quantity": lay.quantity,
            "header": header, "n_comment_lines": len(comments)}
    meta.update(_native_meta(comments))
    return Measurement(omega, Y, weights=arr[:, 3] if lay.weights else None, meta=meta)


def _native_meta(comments: list[str]) -> dict:
    for c in comments:
        if c.startswith("# meta:"):
            try:
                m = json.loads(c[len("# meta:"):])
            except json.JSONDecodeError:
                return {}
            m.pop("source", None)
            return {"written_meta": m}
    return {}


def _read_touchstone(path: Path, text: str) -> Measurement:
    opt = {"unit": "ghz", "param": "s", "fmt": "ma", "r": 50.0}
    body, seen_opt = [], False
    for i, ln in enumerate(text.splitlines(), start=1):
        s = ln.split("!")[0].strip()
        if not s:
            continue
        if s.startswith("#"):
            if seen_opt:
                continue  # Touchstone: only the first option line counts
            seen_opt = True
            toks = s[1:].lower().split()
            j = 0
            while j < len(toks):
                t = toks[j]
                if t in _FREQ_SCALE:
                    opt["unit"] = t
                elif t in ("s", "y", "z"):
                    opt["param"] = t
                elif t in ("g", "h"):
                    raise DataFormatError(f"{path}:{i}: {t.upper()}-parameters are not supported "
                                          "(use S, Z or Y)")
                elif t in ("ma", "db", "ri"):
                    opt["fmt"] = t
                elif t == "r" and j + 1 < len(toks):
                    try:
                        opt["r"] = float(toks[j + 1])
                    except ValueError:
                        raise DataFormatError(
                            f"{path}:{i}: bad reference resistance {toks[j + 1]!r}") from None
                    j += 1
                else:
                    raise DataFormatError(f"{path}:{i}: unknown Touchstone option {t!r}")
                j += 1
        elif s.startswith("["):
            raise DataFormatError(f"{path}:{i}: Touchstone 2.0 keywords are not supported")
        else:
            body.append((i, s))
    if not body:
        raise DataFormatError(f"{path}: no data lines")
    arr = _numeric_rows(body, None, 3, path)
    linenos = [ln for ln, _ in body]
    _check_rows(arr, linenos, path, magnitude_col=1 if opt["fmt"] == "ma" else None)
    f = arr[:, 0] * _FREQ_SCALE[opt["unit"]]
    a, b = arr[:, 1], arr[:, 2]
    if opt["fmt"] == "ma":
        x = a * np.exp(1j * np.deg2rad(b))
    elif opt["fmt"] == "db":
        x = 10 ** (a / 20) * np.exp(1j * np.deg2rad(b))
    else:
        x = a + 1j * b
    R = opt["r"]
    with np.errstate(divide="ignore", invalid="ignore"):
        if opt["param"] == "s":
            Z = R * (1 + x) / (1 - x)
        elif opt["param"] == "z":
            Z = R * x  # Touchstone 1.x stores normalised Z
        else:
            Z = R / x
    bad = np.flatnonzero(~np.isfinite(Z) | (Z == 0))
    if bad.size:
        raise DataFormatError(f"{path}:{linenos[bad[0]]}: value maps to an infinite or zero impedance")
    meta = {"source": str(path), "format": "touchstone", "freq_unit": "hz", "quantity": "Z",
            "touchstone_options": opt}
    return Measurement(2 * math.pi * f, 1.0 / Z, meta=meta)


def read_measurement(path: str | Path, *, freq_unit: FreqUnit | None = None,
                     phase_unit: PhaseUnit | None = None, quantity: Quantity | None = None) -> Measurement:
    """Read a measurement file into a :class:`~bayes_emt.data.Measurement` (admittance, rad/s).

    Parameters
    ----------
    path : ``.zma``, CSV/TSV with a header, native CSV, or Touchstone ``.s1p``.
    freq_unit, phase_unit, quantity : what the file holds, when its header does not say; a value
        that contradicts the header raises.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if re.fullmatch(r"\.s\d+p", suffix) and suffix != ".s1p":
        raise DataFormatError(f"{path}: a {suffix[2:-1]}-port Touchstone file; a transducer's "
                              "terminals are one port (.s1p)")
    text = _read_text(path)
    if suffix == ".s1p":
        if any(v is not None for v in (freq_unit, phase_unit, quantity)):
            raise DataFormatError(f"{path}: Touchstone files state their units; drop --freq-unit, "
                                  "--phase-unit and --quantity")
        return _read_touchstone(path, text)
    return _read_table(path, text, freq_unit, phase_unit, quantity)


def write_measurement(meas: Measurement, path: str | Path) -> Path:
    """Write ``meas`` atomically: native CSV (``.csv``) or ``.zma`` (Hz, Ω, deg)."""
    path = Path(path)
    suffix = path.suffix.lower()
    meta = json.dumps(dict(meas.meta), default=str, sort_keys=True)
    if suffix == ".zma":
        Z = meas.Z
        lines = ["* bayes_emt measurement: frequency (Hz), |Z| (ohm), phase (deg)", f"* meta: {meta}"]
        lines += [f"{f:.10g}\t{abs(z):.10g}\t{math.degrees(np.angle(z)):.10g}"
                  for f, z in zip(meas.f_hz, Z, strict=True)]
    elif suffix in (".csv", ".txt", ""):
        lines = ["# bayes_emt measurement: angular frequency (rad/s), admittance (S)", f"# meta: {meta}"]
        head = "omega_rad_s,Y_real_S,Y_imag_S" + (",weight" if meas.weights is not None else "")
        lines.append(head)
        w = meas.weights if meas.weights is not None else [None] * meas.n_points
        for om, y, wi in zip(meas.omega, meas.Y, w, strict=True):
            row = f"{float(om)!r},{float(y.real)!r},{float(y.imag)!r}"
            lines.append(row + (f",{float(wi)!r}" if wi is not None else ""))
    else:
        raise DataFormatError(f"{path}: cannot write {suffix!r}; use .csv or .zma")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
