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

* ``.txt`` (VituixCAD driver database, ``VituixCAD_Drivers.txt`` of its Enclosure tool): one
  tab-separated header row, ``Manufacturer, Model, Type, Status, Size [in], Re [ohm], fs [Hz], Qms,
  Qes, Qts, Rms [Ns/m], Mms [g], Cms [mm/N], Vas [l], Sd [cm2], BL [Tm], Pmax [W], Xmax [mm], Beta,
  Z1k [ohm], Z10k [ohm], Le [mH], Leb [mH], Ke [sH], Rss [ohm], USPL [dB], BL²/Re, Revision,
  Updated`` (the header as the open-source luchp/audioshape ``vituixcad.py`` writes it, which states
  it was checked against the program), then one row per driver; cells the record does not give are
  left empty, as the community database leaves them. The coil terms: VituixCAD's ``Ke`` [sH, i.e.
  Ω·s^½] is the coefficient of a semi-inductor ``Ke·√(jω)`` (Vanderkooy 1989, JAES 37(3): the
  skin-effect limit of eddy currents in the pole). Leach's ``K·(jω)^n`` (Leach 2002, JAES 50(6);
  the model's ``semi_inductance`` term) is that element exactly when ``n = ½``, so ``Ke = K``; for
  another ``n`` this writer sets ``Ke`` so that ``|Ke·√(jω)| = |K·(jω)^n|`` at 1 kHz,
  ``Ke = K·(2π·1000)^(n−½)``, exact there and only approximate elsewhere (the row's ``Revision``
  cell says so with the value of ``n``). ``Leb`` and ``Rss`` (a further inductance and the
  resistance across the semi-inductor in VituixCAD's circuit) have no counterpart in ``K·(jω)^n``
  and are left empty. ``Le`` is the T/S record's (the coil's inductance at 1 kHz).

All three parameter files are parsed back by :func:`read_wdr`, :func:`read_hornresp` and
:func:`read_vituixcad`.
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
           "hornresp_mmd", "write_vituixcad", "read_vituixcad", "VITUIXCAD_HEADER", "vituixcad_ke"]

#: VituixCAD's driver-database header (module docstring)
VITUIXCAD_HEADER = ("Manufacturer", "Model", "Type", "Status", "Size [in]", "Re [ohm]", "fs [Hz]", "Qms",
                    "Qes", "Qts", "Rms [Ns/m]", "Mms [g]", "Cms [mm/N]", "Vas [l]", "Sd [cm2]", "BL [Tm]",
                    "Pmax [W]", "Xmax [mm]", "Beta", "Z1k [ohm]", "Z10k [ohm]", "Le [mH]", "Leb [mH]",
                    "Ke [sH]", "Rss [ohm]", "USPL [dB]", "BL\u00b2/Re", "Revision", "Updated")
#: column -> (T/S name, factor from SI)
_VX_COLUMNS = {"Re [ohm]": ("Re", 1.0), "fs [Hz]": ("fs", 1.0), "Qms": ("Qms", 1.0), "Qes": ("Qes", 1.0),
               "Qts": ("Qts", 1.0), "Rms [Ns/m]": ("Rms", 1.0), "Mms [g]": ("Mms", 1e3),
               "Cms [mm/N]": ("Cms", 1e3), "Vas [l]": ("Vas", 1e3), "BL [Tm]": ("Bl", 1.0),
               "Le [mH]": ("Le", 1e3)}
_VX_TEXT = {"Manufacturer", "Model", "Type", "Status", "Revision", "Updated"}

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


def vituixcad_ke(K: float, n: float, f_match_hz: float = 1000.0) -> float:
    """VituixCAD's semi-inductance ``Ke`` [Ω s^½] for Leach's ``K (jω)^n``: ``K`` when ``n = ½``,
    else ``K (2π f_match)^(n − ½)`` (equal magnitude at ``f_match_hz``; module docstring)."""
    return float(K * (2 * math.pi * f_match_hz) ** (n - 0.5))


def write_vituixcad(path: str | Path, ts, *, manufacturer: str = "bayes_emt", model: str = "driver",
                    sd: float | None = None, coil: Mapping[str, float] | None = None) -> Path:
    """A VituixCAD driver-database file (header and one row, module docstring) of a T/S record.

    ``coil`` holds the fitted ``K_semi`` [Ω s^n] and ``n_semi`` of a model with a semi-inductance
    (from the fit's parameter JSON); without it ``Ke`` is left empty. ``sd`` [m²] if not in the record.
    """
    v = _values(ts)
    sd = sd if sd is not None else (ts.inputs if hasattr(ts, "inputs") else ts.get("inputs", {})).get("sd_m2")
    for name, text in (("manufacturer", manufacturer), ("model", model)):
        if "\t" in text or "\n" in text:
            raise ValueError(f"{name} {text!r} holds a tab or newline, which would break the row")
    cells = dict.fromkeys(VITUIXCAD_HEADER, "")
    cells.update({"Manufacturer": manufacturer, "Model": model, "Type": "", "Status": "measured"})
    for col, (name, factor) in _VX_COLUMNS.items():
        if name in v:
            cells[col] = f"{v[name] * factor:.10g}"
    if sd:
        cells["Sd [cm2]"] = f"{float(sd) * 1e4:.10g}"
    if "Bl" in v and "Re" in v:
        cells["BL\u00b2/Re"] = f"{v['Bl'] ** 2 / v['Re']:.10g}"
    revision = "bayes_emt"
    if coil is not None:
        K, n = float(coil["K_semi"]), float(coil["n_semi"])
        cells["Ke [sH]"] = f"{vituixcad_ke(K, n):.10g}"
        if abs(n - 0.5) > 1e-9:
            revision += f"; Ke matched at 1 kHz from K s^n, n = {n:.4g}"
    cells["Revision"] = revision
    lines = ["\t".join(VITUIXCAD_HEADER), "\t".join(cells[c] for c in VITUIXCAD_HEADER)]
    atomic_write_text(path, "\n".join(lines) + "\n")
    return Path(path)


def read_vituixcad(path: str | Path) -> list[dict]:
    """The rows of a VituixCAD driver-database file as ``{column: value}`` (numbers as floats, empty
    cells left out), columns as in its header; a number that does not parse raises, naming the line."""
    lines = Path(path).read_text(encoding="utf-8-sig").splitlines()
    if not lines or lines[0].split("\t")[:2] != ["Manufacturer", "Model"]:
        raise DataFormatError(f"{path}:1: not a VituixCAD driver database "
                              "(header 'Manufacturer<tab>Model<tab>...')")
    header = lines[0].split("\t")
    rows = []
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split("\t")
        if len(cells) > len(header):
            raise DataFormatError(f"{path}:{i}: {len(cells)} cells for {len(header)} columns")
        row = {}
        for col, cell in zip(header, cells, strict=False):
            cell = cell.strip()
            if not cell:
                continue
            if col in _VX_TEXT:
                row[col] = cell
                continue
            try:
                row[col] = float(cell.replace(",", "."))
            except ValueError:
                raise DataFormatError(f"{path}:{i}: column {col!r} is not a number: {cell!r}") from None
        rows.append(row)
    return rows


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
