"""Reading and writing measurement files.

Formats met in practice (SPEC §6), told apart by suffix and content, never by guessing:

* ``.zma``: frequency [Hz], |Z| [Ω], phase [deg] by the format's convention; ``*`` header lines;
  tab- or space-separated; sometimes no header at all.
* CSV/TSV/space-separated tables with a header line (LCR-meter and audio-analyser exports):
  magnitude/phase or real/imaginary, impedance or admittance, Hz or rad/s, degrees or radians,
  units taken from the header (:mod:`bayes_emt.io.header`) or, when it does not say, from the
  caller (``freq_unit``, ``phase_unit``, ``quantity``).
* Touchstone ``.s1p``/``.ts`` (S, Z or Y; MA, DB or RI; Hz to GHz; reference resistance), also
  recognised by its option line under another suffix.
* The native CSV written by :func:`write_measurement`: ``omega_rad_s,Y_real_S,Y_imag_S`` with ``#``
  comment lines holding the metadata.

Every problem raises :class:`~bayes_emt.errors.DataFormatError` as ``path:line: what is wrong``.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path
from typing import Literal

import numpy as np

from .._atomic import atomic_path
from ..errors import DataFormatError
from ..measurement import Measurement
from ._rows import read_text
from .dats import looks_like_dats, read_dats
from .klippel import looks_like_klippel, read_klippel
from .lim import looks_like_lim, read_lim
from .rew import looks_like_rew, read_rew
from .table import NATIVE_HEADER, NATIVE_MARKER, read_table
from .touchstone import looks_like_touchstone, read_touchstone

__all__ = ["read_measurement", "write_measurement"]

#: bench exports recognised from their own text, tried in order: (name, is-this-mine, reader)
_BENCHES = (("DATS", looks_like_dats, read_dats, ()),
            ("Klippel LPM", looks_like_klippel, read_klippel, ()),
            ("REW", looks_like_rew, read_rew, ("quantity",)))

FreqUnit = Literal["hz", "khz", "mhz", "ghz", "rad/s"]
PhaseUnit = Literal["deg", "rad"]
Quantity = Literal["Z", "Y"]
_CHOICES = {"freq_unit": ("hz", "khz", "mhz", "ghz", "rad/s"), "phase_unit": ("deg", "rad"),
            "quantity": ("Z", "Y")}


def _options(freq_unit, phase_unit, quantity) -> dict:
    """The caller's options, normalised (``'Hz'`` -> ``'hz'``, ``'z'`` -> ``'Z'``); bad values raise."""
    out = {}
    for name, value in (("freq_unit", freq_unit), ("phase_unit", phase_unit), ("quantity", quantity)):
        if value is not None:
            value = str(value).upper() if name == "quantity" else str(value).lower()
            if value not in _CHOICES[name]:
                raise ValueError(f"{name} must be one of {', '.join(_CHOICES[name])}; got {value!r}")
        out[name] = value
    return out


def read_measurement(path: str | Path, *, freq_unit: FreqUnit | None = None,
                     phase_unit: PhaseUnit | None = None, quantity: Quantity | None = None) -> Measurement:
    """Read a measurement file into a :class:`~bayes_emt.measurement.Measurement` (admittance [S], rad/s).

    Parameters
    ----------
    path : str or Path
        ``.zma``, a CSV/TSV table with a header, the native CSV, or Touchstone ``.s1p``/``.ts``.
    freq_unit : {'hz', 'rad/s', 'khz', 'mhz', 'ghz'}, optional
        Unit of the frequency column when the header does not say.
    phase_unit : {'deg', 'rad'}, optional
        Unit of the phase column when the header does not say.
    quantity : {'Z', 'Y'}, optional
        Whether the values are impedance [Ω] or admittance [S] when the header does not say.

    Returns
    -------
    Measurement
        Sorted by frequency. ``meta`` holds ``source`` (the path), ``format`` (zma, csv, tsv, text,
        native, touchstone), ``freq_unit``, ``phase_unit``, ``quantity`` and ``representation`` as
        read, ``units_from`` (header, option or zma convention, per unit), ``header``,
        ``n_header_lines`` (lines before the first data line) and ``notices`` (what was done
        that the user should know, e.g. sorting); the native format adds ``written_meta``.

    Raises
    ------
    DataFormatError
        With ``path:line: what is wrong`` for a missing, empty or binary file, a wrong column count,
        a non-numeric or non-finite cell, a non-positive frequency or magnitude, a duplicate
        frequency, fewer than 3 points, a unit the header does not state and no option gives, or an
        option that contradicts the header.
    """
    path = Path(path)
    options = _options(freq_unit, phase_unit, quantity)
    suffix = path.suffix.lower()
    if re.fullmatch(r"\.s\d+p", suffix) and suffix != ".s1p":
        raise DataFormatError(f"{path}: a {suffix[2:-1]}-port Touchstone file; a transducer's "
                              "terminals are one port (.s1p)")
    if looks_like_lim(path):
        _refuse_options(path, "LIMP .lim", options)
        return read_lim(path)
    text = read_text(path)
    bench = _bench_reader(text)
    if bench is not None:
        name, read, allowed = bench
        _refuse_options(path, name, {k: v for k, v in options.items() if k not in allowed})
        return read(path, text, **{k: options[k] for k in allowed})
    ts_line = looks_like_touchstone(text)
    if suffix in (".s1p", ".ts") or ts_line is not None:
        given = [f"--{k.replace('_', '-')}" for k, v in options.items() if v is not None]
        if given:
            raise DataFormatError(f"{path}: a Touchstone file states its own units; drop {', '.join(given)}")
        meas = read_touchstone(path, text)
        if suffix not in (".s1p", ".ts"):
            note = (f"{path}:{ts_line}: read as Touchstone (its option line), although named "
                    f"{suffix or 'without a suffix'}")
            meas = meas.with_meta(notices=(*meas.meta["notices"], note))
        return meas
    return read_table(path, text, options, is_zma=suffix == ".zma")


def _bench_reader(text: str):
    """``(bench name, reader, options it takes)`` of the first bench format that recognises the
    file, else ``None``."""
    for name, looks, read, allowed in _BENCHES:
        if looks(text):
            return name, read, allowed
    return None


def _refuse_options(path: Path, bench: str, options: dict) -> None:
    given = [f"--{k.replace('_', '-')}" for k, v in options.items() if v is not None]
    if given:
        raise DataFormatError(f"{path}: a {bench} export states its own units (Hz, ohm, deg); "
                              f"drop {', '.join(given)}")


def write_measurement(meas: Measurement, path: str | Path) -> Path:
    """Write ``meas`` atomically in the format its suffix names.

    ``.csv`` (also ``.txt`` or no suffix): the native CSV, header ``omega_rad_s,Y_real_S,Y_imag_S``
    (angular frequency [rad/s], admittance [S]; plus ``weight`` when the measurement has weights),
    numbers as shortest round-trip reprs, so reading it back gives the same floats.
    ``.zma``: frequency [Hz], |Z| [Ω], phase [deg] to 10 significant digits (weights are not
    stored; a warning says so). Both carry the metadata as JSON on a comment line, which
    :func:`read_measurement` returns as ``meta["written_meta"]``.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    meta = json.dumps(dict(meas.meta), default=str, sort_keys=True)
    if suffix == ".zma":
        if meas.weights is not None:
            warnings.warn(f"{path}: .zma has no weight column; the weights are not written",
                          UserWarning, stacklevel=2)
        Z = meas.Z
        lines = [f"* {NATIVE_MARKER}: frequency (Hz), |Z| (ohm), phase (deg)", f"* meta: {meta}",
                 "* freq(Hz)\t|Z|(ohm)\tphase(deg)"]
        lines += [f"{f:.10g}\t{abs(z):.10g}\t{math.degrees(np.angle(z)):.10g}"
                  for f, z in zip(meas.f_hz, Z, strict=True)]
    elif suffix in (".csv", ".txt", ""):
        lines = [f"# {NATIVE_MARKER}: angular frequency (rad/s), admittance (S)", f"# meta: {meta}",
                 NATIVE_HEADER + (",weight" if meas.weights is not None else "")]
        w = meas.weights if meas.weights is not None else [None] * meas.n_points
        for om, y, wi in zip(meas.omega, meas.Y, w, strict=True):
            row = f"{float(om)!r},{float(y.real)!r},{float(y.imag)!r}"
            lines.append(row + (f",{float(wi)!r}" if wi is not None else ""))
    else:
        raise DataFormatError(f"{path}: cannot write {suffix!r}; use .csv (native) or .zma")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
