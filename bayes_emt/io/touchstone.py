"""One-port Touchstone files (``.s1p``; version 1.x, and 2.0 with its keywords).

Option line ``# <Hz|kHz|MHz|GHz> <S|Z|Y> <MA|DB|RI> R <ohm>`` (any order, defaults GHz S MA R 50).
Angles are in degrees; DB is ``20 log10 |x|``. ``S11`` becomes the terminal impedance through
``Z = R (1 + S) / (1 - S)``; version 1.x stores Z and Y normalised to ``R``, version 2.0 does not.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement
from ._rows import check_rows, finish, numeric_rows
from .header import freq_scale

__all__ = ["read_touchstone", "looks_like_touchstone"]

_OPTION = re.compile(r"^#(\s+(hz|khz|mhz|ghz|s|y|z|g|h|ma|db|ri|r\s+\S+))*\s*$", re.IGNORECASE)
# [Matrix Format] is the same for a 1x1 matrix whatever its value; [Begin/End Information] hold notes
_ALLOWED_KEYWORDS = {"version", "number of ports", "number of frequencies", "reference",
                     "network data", "end", "matrix format", "begin information", "end information"}


def looks_like_touchstone(text: str) -> int | None:
    """Line number of a Touchstone option line or ``[Version]`` keyword opening ``text``, else None.

    Only comment (``!``) and blank lines may come before it, as the format requires.
    """
    for i, ln in enumerate(text.splitlines()[:200], start=1):
        s = ln.split("!")[0].strip()
        if not s:
            continue
        if _OPTION.match(s) or s.lower().startswith("[version]"):
            return i
        return None
    return None


def _parse_option_line(s: str, lineno: int, path: Path, opt: dict) -> None:
    toks = s[1:].lower().split()
    j = 0
    while j < len(toks):
        t = toks[j]
        if t in ("hz", "khz", "mhz", "ghz"):
            opt["unit"] = t
        elif t in ("s", "y", "z"):
            opt["param"] = t
        elif t in ("g", "h"):
            raise DataFormatError(f"{path}:{lineno}: {t.upper()}-parameters are two-port parameters "
                                  "(a one-port file holds S, Z or Y)")
        elif t in ("ma", "db", "ri"):
            opt["fmt"] = t
        elif t == "r":
            try:
                opt["r"] = float(toks[j + 1])
            except (IndexError, ValueError):
                raise DataFormatError(f"{path}:{lineno}: 'R' must be followed by the reference "
                                      "resistance in ohm") from None
            if not opt["r"] > 0 or not math.isfinite(opt["r"]):
                raise DataFormatError(f"{path}:{lineno}: reference resistance must be positive")
            j += 1
        else:
            raise DataFormatError(f"{path}:{lineno}: unknown Touchstone option {t!r} "
                                  "(expected Hz/kHz/MHz/GHz, S/Z/Y, MA/DB/RI, R <ohm>)")
        j += 1


def _keyword(s: str, lineno: int, path: Path, state: dict) -> None:
    m = re.match(r"^\[([^\]]+)\]\s*(.*)$", s)
    if not m:
        raise DataFormatError(f"{path}:{lineno}: malformed Touchstone keyword line {s!r}")
    key, arg = m.group(1).strip().lower(), m.group(2).strip()
    if key not in _ALLOWED_KEYWORDS:
        raise DataFormatError(f"{path}:{lineno}: Touchstone keyword [{m.group(1)}] is not supported "
                              "for a one-port measurement")
    if key == "version":
        state["version"] = arg
        if not arg.startswith("2"):
            raise DataFormatError(f"{path}:{lineno}: unsupported Touchstone version {arg!r}")
    elif key == "number of ports" and arg != "1":
        raise DataFormatError(f"{path}:{lineno}: [Number of Ports] {arg}: a transducer's terminals "
                              "are one port")
    elif key == "number of frequencies":
        state["n_freq"] = (lineno, arg)
    elif key == "reference":
        try:
            state["reference"] = float(arg.split()[0])
        except (IndexError, ValueError):
            raise DataFormatError(f"{path}:{lineno}: [Reference] needs one resistance in ohm") from None
    elif key == "end":
        state["ended"] = True


def read_touchstone(path: Path, text: str) -> Measurement:
    """Read a one-port Touchstone file; the terminal admittance is ``1/Z``."""
    opt = {"unit": "ghz", "param": "s", "fmt": "ma", "r": 50.0}
    state: dict = {"version": None, "ended": False}
    body, opt_line, notices = [], None, []
    for i, ln in enumerate(text.splitlines(), start=1):
        s = ln.split("!")[0].strip()
        if not s:
            continue
        if state["ended"]:
            raise DataFormatError(f"{path}:{i}: data after [End]")
        if s.startswith("#"):
            if opt_line is None:
                _parse_option_line(s, i, path, opt)
                opt_line = i
            else:
                notices.append(f"line {i}: second option line ignored (only the first counts)")
        elif s.startswith("["):
            _keyword(s, i, path, state)
        else:
            if opt_line is None:
                raise DataFormatError(f"{path}:{i}: data before the option line "
                                      "('# <unit> S|Z|Y MA|DB|RI R <ohm>')")
            body.append((i, s))
    if opt_line is None:
        raise DataFormatError(f"{path}: no Touchstone option line ('# Hz S MA R 50' or similar)")
    if not body:
        raise DataFormatError(f"{path}: no data lines")
    v2 = state["version"] is not None
    if v2 and "reference" in state:
        opt["r"] = state["reference"]
    arr = numeric_rows(body, None, 3, path, what="frequency and one complex value")
    linenos = [ln for ln, _ in body]
    if "n_freq" in state and state["n_freq"][1] != str(len(body)):
        raise DataFormatError(f"{path}:{state['n_freq'][0]}: [Number of Frequencies] says "
                              f"{state['n_freq'][1]} but there are {len(body)} data lines")
    arr, linenos = check_rows(arr, linenos, path, magnitude_col=None, notices=notices)
    a, b = arr[:, 1], arr[:, 2]
    if opt["fmt"] == "ma":
        bad = np.flatnonzero(a < 0)
        if bad.size:
            raise DataFormatError(f"{path}:{linenos[bad[0]]}: negative magnitude {a[bad[0]]:g}")
        x = a * np.exp(1j * np.deg2rad(b))
    elif opt["fmt"] == "db":
        with np.errstate(over="ignore"):
            x = 10 ** (a / 20) * np.exp(1j * np.deg2rad(b))
    else:
        x = a + 1j * b
    R = opt["r"]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if opt["param"] == "s":
            Z = R * (1 + x) / (1 - x)
        elif opt["param"] == "z":
            Z = x if v2 else R * x
        else:
            Z = 1 / x if v2 else R / x
    if opt["param"] == "s" and np.any(np.abs(x) > 1):
        i = int(np.argmax(np.abs(x)))
        msg = (f"{path}:{linenos[i]}: |S11| = {abs(x[i]):.4g} > 1 (negative resistance); "
               "check the calibration")
        warnings.warn(msg, UserWarning, stacklevel=3)
        notices.append(msg)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        Y = 1.0 / Z
    bad = np.flatnonzero(~np.isfinite(Z) | ~np.isfinite(Y) | (Y == 0))
    if bad.size:
        raise DataFormatError(f"{path}:{linenos[bad[0]]}: value maps to an infinite or zero impedance")
    meta = {"source": str(path), "format": "touchstone", "freq_unit": opt["unit"], "phase_unit": "deg"
            if opt["fmt"] != "ri" else None, "quantity": opt["param"].upper(),
            "representation": {"ma": "magphase", "db": "dbphase", "ri": "reim"}[opt["fmt"]],
            "touchstone_options": dict(opt), "touchstone_version": state["version"] or "1",
            "n_header_lines": body[0][0] - 1}
    with np.errstate(over="ignore"):
        omega = 2 * math.pi * freq_scale(opt["unit"]) * arr[:, 0]
    return finish(omega, Y, linenos, path, meta, notices)
