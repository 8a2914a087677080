"""Exports for loudspeaker tools: a fitted impedance as ZMA or FRD, T/S parameters as driver files.

Curve files (text, one point per line, frequency ascending, ``*`` comment lines first):

* ``.zma``: frequency [Hz], |Z| [Ω], phase [deg] — the impedance format of LspCAD, LEAP,
  VituixCAD, XSim, ARTA/LIMP exports (the File formats page describes the variants met in practice; the
  package's own reader reads it back, :func:`bayes_emt.io.read_measurement`).
* ``.frd``: frequency [Hz], magnitude [dB], phase [deg] — the frequency-response layout the same
  tools use (a public discussion of its conventions: "Sound, Vibration and a Little Noise | .FRD
  file format", referred to in the Hornresp thread on diyaudio.com). Written here is the
  *impedance* in that layout, ``20 log10(|Z| / 1 Ω)`` dB: FRD has no unit field, so the header
  says so; it is not an acoustic response.

Numbers are written with 12 significant digits, so re-reading reproduces the curve to 1e-11
relative (tests/test_export.py checks 1e-6).

Driver parameter files (from a :class:`~bayes_emt.thiele_small.ThieleSmall` record):

* ``.wdr`` (WinISD): INI-style ``Key=value`` lines under a ``[Driver]`` section in SI units
  (Fs [Hz], Qms, Qes, Qts, Re [Ω], Le [H], Vas [m³], Sd [m²], Mms [kg], Cms [m/N], Rms [kg/s],
  BL [T m]), the layout public WinISD driver-library tools read (``Key=value`` per line, SI, e.g.
  Sd in m² and Vas in m³). Not verified against WinISD itself here.
* ``.txt`` (Hornresp driver record): ``Sd = ... Bl = ... Cms = ... Rms = ... Mmd = ... Le = ...
  Re = ...`` in Hornresp's input units (Sd [cm²], Bl [T m], Cms [m/N], Rms [N s/m], Mmd [g],
  Le [mH], Re [Ω]), as the Hornresp input fields and the diyaudio "Hornresp" thread
  (https://www.diyaudio.com/community/threads/hornresp.119854/, the import-file spreadsheet
  discussion) give them. Hornresp takes the moving mass *without* air load (Mmd):
  ``Mmd = Mms − 0.575 Sd^1.5`` kg (the air-load approximation quoted in that thread for
  Hornresp's own conversion, Sd in m²). Not verified against Hornresp itself here.

Both parameter files are parsed back by :func:`read_wdr` and :func:`read_hornresp`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_text
from ..errors import DataFormatError

__all__ = ["write_zma", "write_frd", "write_wdr", "read_wdr", "write_hornresp", "read_hornresp",
           "hornresp_mmd"]

_WDR_KEYS = {"Fs": "fs", "Qms": "Qms", "Qes": "Qes", "Qts": "Qts", "Re": "Re", "Le": "Le", "Vas": "Vas",
             "Mms": "Mms", "Cms": "Cms", "Rms": "Rms", "BL": "Bl"}


def _curve_lines(f_hz, Z, header: list[str], db: bool) -> str:
    f_hz = np.asarray(f_hz, float)
    Z = np.asarray(Z, complex)
    if f_hz.ndim != 1 or f_hz.shape != Z.shape or f_hz.size == 0:
        raise ValueError("frequencies and impedances must be 1-D arrays of the same, non-zero length")
    if not (np.all(np.isfinite(f_hz)) and np.all(f_hz > 0) and np.all(np.diff(f_hz) > 0)):
        raise ValueError("frequencies must be finite, positive and increasing [Hz]")
    if not np.all(np.isfinite(Z)) or np.any(Z == 0):
        raise ValueError("impedances must be finite and non-zero")
    mag = 20 * np.log10(np.abs(Z)) if db else np.abs(Z)
    ph = np.degrees(np.angle(Z))
    rows = [f"{f:.12g}\t{m:.12g}\t{p:.12g}" for f, m, p in zip(f_hz, mag, ph, strict=True)]
    return "\n".join([f"* {h}" for h in header] + rows) + "\n"


def write_zma(path: str | Path, f_hz, Z, *, comment: str = "") -> Path:
    """Write impedance ``Z`` [Ω] at ``f_hz`` [Hz] as ``.zma`` (atomically)."""
    head = ([comment] if comment else []) + ["freq(Hz)\t|Z|(ohm)\tphase(deg)"]
    atomic_write_text(path, _curve_lines(f_hz, Z, head, db=False))
    return Path(path)


def write_frd(path: str | Path, f_hz, Z, *, comment: str = "") -> Path:
    """Write impedance ``Z`` [Ω] in the FRD layout: Hz, 20 log10(|Z|/1 Ω) dB, phase deg."""
    head = ([comment] if comment else []) + ["impedance in FRD layout: magnitude is 20*log10(|Z|/1 ohm) dB",
                                             "freq(Hz)\tmag(dB re 1 ohm)\tphase(deg)"]
    atomic_write_text(path, _curve_lines(f_hz, Z, head, db=True))
    return Path(path)


def _values(ts) -> dict[str, float]:
    """``{name: value}`` [SI] from a ThieleSmall (or its JSON dict)."""
    params = ts.parameters if hasattr(ts, "parameters") else ts["parameters"]
    return {k: float(v["value"]) for k, v in params.items()}


def write_wdr(path: str | Path, ts, *, name: str = "bayes_emt", sd: float | None = None) -> Path:
    """WinISD-style driver file (module docstring) of a T/S record; ``sd`` [m²] if not in it."""
    v = _values(ts)
    sd = sd if sd is not None else (ts.inputs if hasattr(ts, "inputs") else ts.get("inputs", {})).get("sd_m2")
    lines = ["[Driver]", f"Brand={name}", f"Model={name}"]
    for key, src in _WDR_KEYS.items():
        if src in v:
            lines.append(f"{key}={v[src]:.10g}")
    if sd is not None:
        lines.append(f"Sd={float(sd):.10g}")
    lines.append("Comment=written by bayes_emt; SI units (Hz, ohm, H, m^3, m^2, kg, m/N, kg/s, T m)")
    atomic_write_text(path, "\n".join(lines) + "\n")
    return Path(path)


def read_wdr(path: str | Path) -> dict[str, float]:
    """The numeric ``Key=value`` entries of a ``.wdr`` file (keys as written, SI)."""
    out = {}
    for i, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
        line = line.strip()
        if not line or line.startswith(("[", ";", "#")) or "=" not in line:
            continue
        key, _, val = line.partition("=")
        try:
            out[key.strip()] = float(val)
        except ValueError:
            if key.strip() not in ("Brand", "Model", "Comment"):
                raise DataFormatError(f"{path}:{i}: {key.strip()} is not a number: {val.strip()!r}") from None
    return out


def hornresp_mmd(mms: float, sd: float) -> float:
    """Moving mass without air load [kg]: ``Mms − 0.575 Sd^1.5`` (Sd [m²]; module docstring)."""
    return mms - 0.575 * sd**1.5


def write_hornresp(path: str | Path, ts, *, sd: float | None = None) -> Path:
    """Hornresp driver record (module docstring); needs Bl, Cms, Rms, Mms, Re, Le and Sd."""
    v = _values(ts)
    sd = sd if sd is not None else (ts.inputs if hasattr(ts, "inputs") else ts.get("inputs", {})).get("sd_m2")
    missing = [k for k in ("Bl", "Cms", "Rms", "Mms", "Re", "Le") if k not in v] + ([] if sd else ["Sd"])
    if missing:
        raise ValueError(f"a Hornresp driver record needs {missing}: measure with added masses (or give a "
                         "known Mms or Bl) and give Sd")
    rec = {"Sd": sd * 1e4, "Bl": v["Bl"], "Cms": v["Cms"], "Rms": v["Rms"],
           "Mmd": hornresp_mmd(v["Mms"], sd) * 1e3, "Le": v["Le"] * 1e3, "Re": v["Re"]}
    lines = ["|Traditional Driver Parameter Values (bayes_emt; Sd cm2, Bl Tm, Cms m/N, Rms Ns/m, Mmd g, "
             "Le mH, Re ohm):"]
    lines += [f"{k} = {val:.6g}" for k, val in rec.items()]
    atomic_write_text(path, "\n".join(lines) + "\n")
    return Path(path)


_HR = re.compile(r"^\s*(Sd|Bl|Cms|Rms|Mmd|Le|Re)\s*=\s*([-+0-9.eE]+)\s*$")


def read_hornresp(path: str | Path) -> dict[str, float]:
    """``{Sd [cm²], Bl, Cms, Rms, Mmd [g], Le [mH], Re}`` from a Hornresp driver record."""
    out = {}
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        m = _HR.match(line)
        if m:
            out[m.group(1)] = float(m.group(2))
    missing = [k for k in ("Sd", "Bl", "Cms", "Rms", "Mmd", "Le", "Re") if k not in out]
    if missing:
        raise DataFormatError(f"{path}: not a Hornresp driver record, missing {missing}")
    return out


def check_finite(values: Mapping[str, float], where: str) -> None:
    bad = [k for k, v in values.items() if not math.isfinite(v)]
    if bad:
        raise DataFormatError(f"{where}: non-finite values for {bad}")


def grid_hz(text: str) -> np.ndarray:
    """``"FMIN:FMAX:N"`` → N log-spaced frequencies [Hz] from FMIN to FMAX (``--grid``)."""
    try:
        lo, hi, n = text.split(":")
        lo, hi, n = float(lo), float(hi), int(n)
    except ValueError:
        raise ValueError(f"--grid {text}: expected FMIN:FMAX:N, e.g. 10:20000:500") from None
    if not (0 < lo < hi and math.isfinite(hi) and n >= 2):
        raise ValueError(f"--grid {text}: need 0 < FMIN < FMAX and N >= 2")
    return np.geomspace(lo, hi, n)


def fitted_impedance(model, theta, f_hz) -> np.ndarray:
    """The model's terminal impedance [Ω] at ``f_hz`` [Hz] (what ``export --zma/--frd`` writes)."""
    return model.impedance(2 * math.pi * np.asarray(f_hz, float), theta)
