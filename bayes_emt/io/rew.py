"""Room EQ Wizard (REW) text exports of an impedance measurement.

REW writes ``*`` comment lines (``* Measurement data measured by REW V5.20``, ``* Source: ...``,
``* Format: ...``, ``* Dated: ...``, ``* Frequency Step: ...``, ``* Start Frequency: ...``), an
optional ``* Freq(Hz) ... Phase(degrees)`` comment naming the columns, then three numeric columns:
frequency [Hz], magnitude, phase [deg], separated by commas, tabs, spaces or semicolons (its own
importer accepts all four). The magnitude column's label is not reliable (REW labels it for the
kind of measurement, and impedance exports often keep an SPL label), so the file is read as an
impedance when its comments say so (``impedance``, ``ohm``, ``Z(``) or the caller passes
``quantity="Z"``; a file whose comments name SPL and nothing else is refused as a sound-pressure
export, and one that says neither is refused with the option to pass.

Recognised by the comment ``measured by REW`` (or ``REW V``) in the first lines.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import DataFormatError
from ..measurement import Measurement
from ._bench import bench_measurement
from ._rows import detect_delimiter, numeric_rows, uses_decimal_comma

__all__ = ["looks_like_rew", "read_rew"]

_REW = re.compile(r"\bREW\b(?:\s+V\d|\s*$)|measured by REW|room eq wizard", re.IGNORECASE)
_IMPEDANCE = re.compile(r"impedance|\bohms?\b|Ω|\bZ\s*\(", re.IGNORECASE)
_SPL = re.compile(r"\bspl\b|sound\s*pressure|db\s*spl", re.IGNORECASE)


def looks_like_rew(text: str) -> bool:
    """A ``*`` comment naming REW among the first comment lines."""
    for line in text.splitlines()[:30]:
        s = line.strip()
        if not s:
            continue
        if not s.startswith("*"):
            return False
        if _REW.search(s):
            return True
    return False


def read_rew(path: Path, text: str, quantity: str | None = None) -> Measurement:
    """Read a REW export (see the module docstring); ``quantity`` ``"Z"`` says it is an impedance."""
    comments, body = [], []
    for i, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        (comments if s.startswith("*") else body).append((i, s))
    if quantity == "Y":
        raise DataFormatError(f"{path}: REW exports a magnitude in ohm or dB, not an admittance; drop "
                              "--quantity Y")
    says_z = [c for c in comments if _IMPEDANCE.search(c[1])]
    says_spl = [c for c in comments if _SPL.search(c[1])]
    notices: list[str] = []
    if quantity != "Z":
        if says_spl and not says_z:
            ln, c = says_spl[0]
            raise DataFormatError(f"{path}:{ln}: comment {c[:60]!r}: a sound-pressure (SPL) frequency "
                                  "response, not an impedance; if this REW export is an impedance "
                                  "measurement, pass --quantity Z")
        if not says_z:
            raise DataFormatError(f"{path}: a REW export that does not say whether its magnitude is an "
                                  "impedance [ohm] or a sound pressure [dB]; for an impedance measurement "
                                  "pass --quantity Z")
        notices.append(f"{path}:{says_z[0][0]}: read as impedance (ohm, degrees) as its comment says")
    if not body:
        raise DataFormatError(f"{path}: no data lines (only REW's comment block)")
    delim = detect_delimiter(body[0][1])
    comma = any(uses_decimal_comma(s, delim) for _, s in body)
    if comma:
        notices.append("decimal commas read as decimal points")
    arr = numeric_rows(body, delim, 3, path, decimal_comma=comma,
                       what="frequency [Hz], |Z| [ohm], phase [deg]")
    meta = {"header": None, "n_header_lines": body[0][0] - 1}
    return bench_measurement(path, arr, [i for i, _ in body], fmt="rew", notices=notices, meta=meta)
