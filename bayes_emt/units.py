"""Quantities with an explicit unit, read at the edge: ``8.017g``, ``85cm2``, ``20L``, ``1kHz``,
``6.1ohm``; a bare number keeps its SI meaning. Inside the package everything is SI (labels, not
objects: the house style's rule 3).

Why a table and not a units library (pint, astropy.units): the package reads a dozen kinds of
quantity from a command line or a keyword argument and converts each once to a float; a
table-driven parser of ~150 lines does that with no dependency, gives the one-line refusal the
command line needs (naming the option, the unit and the units it accepts) and cannot leak a
``Quantity`` object into the numerical code. Frequencies come in two SI flavours, Hz and rad/s:
each option says which one a bare number means, and a unit converts between them by 2π.

Grammar: ``NUMBER [space] UNIT``, the unit case-insensitive except that a capital ``M`` (mega)
is refused where lower case would read it as milli (``MOhm``, ``Mg``), ``^2``/``²`` and ``^3``/``³``
accepted (``cm^2``, ``cm²``, ``cm2``), ``·``/``*``/space in ``T·m`` optional.
"""

from __future__ import annotations

import math
import re

__all__ = ["UnitError", "UNITS", "SI_UNIT", "parse_quantity", "as_si", "suggest"]


class UnitError(ValueError):
    """A quantity whose unit is unknown, of the wrong dimension, or whose number is not finite."""


#: dimension → {unit (lower case, normalised): factor to the dimension's SI unit}
UNITS: dict[str, dict[str, float]] = {
    "mass": {"kg": 1.0, "g": 1e-3, "mg": 1e-6, "gram": 1e-3, "grams": 1e-3},
    "area": {"m2": 1.0, "cm2": 1e-4, "mm2": 1e-6, "in2": 0.0254**2, "sqin": 0.0254**2},
    "volume": {"m3": 1.0, "l": 1e-3, "litre": 1e-3, "liter": 1e-3, "litres": 1e-3, "liters": 1e-3,
               "ml": 1e-6, "cm3": 1e-6, "dm3": 1e-3, "ft3": 0.3048**3, "cuft": 0.3048**3, "in3": 0.0254**3},
    # frequency: the factor is to Hz; rad/s is 1/(2π) Hz
    "frequency": {"hz": 1.0, "khz": 1e3, "rad/s": 1.0 / (2.0 * math.pi), "krad/s": 1e3 / (2.0 * math.pi)},
    "resistance": {"ohm": 1.0, "ohms": 1.0, "Ω": 1.0, "mohm": 1e-3, "mΩ": 1e-3, "kohm": 1e3, "kΩ": 1e3},
    "force_factor": {"tm": 1.0, "n/a": 1.0},
    "density": {"kg/m3": 1.0, "g/l": 1.0, "g/cm3": 1e3},
    "speed": {"m/s": 1.0},
}

#: the SI unit each dimension's bare number means (frequency: see ``bare`` of :func:`parse_quantity`)
SI_UNIT = {"mass": "kg", "area": "m2", "volume": "m3", "frequency": "Hz", "resistance": "ohm",
           "force_factor": "T m", "density": "kg/m3", "speed": "m/s"}

_WHAT = {"mass": "a mass", "area": "an area", "volume": "a volume", "frequency": "a frequency",
         "resistance": "a resistance", "force_factor": "a force factor", "density": "a density",
         "speed": "a speed"}
#: the units named in a refusal, per dimension
_SHOWN = {"mass": "kg, g, mg", "area": "m2, cm2, mm2, in2", "volume": "m3, L, mL, cm3, ft3, in3",
          "frequency": "Hz, kHz, rad/s", "resistance": "ohm, mohm, kohm", "force_factor": "T*m (= N/A)",
          "density": "kg/m3, g/L", "speed": "m/s"}

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?inf(?:inity)?|nan)\s*(.*?)\s*$",
                     re.IGNORECASE)


def _norm(unit: str) -> str:
    u = unit.replace("²", "2").replace("³", "3").replace("^", "").replace("·", "").replace("*", "")
    u = u.replace(" ", "")
    return u if u in ("Ω", "mΩ", "kΩ") else u.lower()


def _dimension_of(unit: str) -> str | None:
    for dim, table in UNITS.items():
        if unit in table:
            return dim
    return None


def parse_quantity(text: str, dimension: str, *, bare: str | None = None) -> float:
    """The value of ``text`` (``"8.017g"``, ``"85 cm2"``, ``"0.0330"``) in ``dimension``'s SI unit.

    Parameters
    ----------
    text : a number, optionally followed by a unit of ``dimension`` (:data:`UNITS`).
    dimension : a key of :data:`UNITS`.
    bare : frequencies only: the unit a bare number means and the result is given in, ``"Hz"``
        (default) or ``"rad/s"`` (``--omega-min 60`` is rad/s, ``--exclude-band 20:1000`` Hz).

    Raises
    ------
    UnitError
        One line: the text, what is wrong, the units accepted.
    """
    if dimension not in UNITS:
        raise ValueError(f"unknown dimension {dimension!r}; known: {', '.join(UNITS)}")
    m = _NUMBER.match(str(text))
    if m is None:
        raise UnitError(f"{text!r} is not a number with an optional unit (e.g. {_example(dimension)})")
    value = float(m.group(1))
    unit = m.group(2)
    if not math.isfinite(value):
        raise UnitError(f"{text!r} is not a finite number")
    out_bare = (bare or "Hz").lower() if dimension == "frequency" else None
    if not unit:
        return value
    u = _norm(unit)
    table = UNITS[dimension]
    if unit.lstrip()[:1] == "M" and u[:1] == "m" and table.get(u, 1.0) < 1.0:
        # 'MOhm', 'Mg': mega, which lower case would silently read as milli (1e9 apart)
        raise UnitError(f"{text!r}: {unit} reads as mega; write m for milli (e.g. 20mohm, 500mg)")
    if u not in table:
        other = _dimension_of(u)
        if other is not None:
            raise UnitError(f"{text!r}: {unit} is {_WHAT[other]}, not {_WHAT[dimension]} "
                            f"(use {_SHOWN[dimension]})")
        raise UnitError(f"{text!r}: unknown unit {unit!r} for {_WHAT[dimension]} (use {_SHOWN[dimension]})")
    si = value * table[u]
    if dimension == "frequency" and out_bare == "rad/s":
        return si * 2.0 * math.pi
    return si


def _example(dimension: str) -> str:
    return {"mass": "8.017g", "area": "85cm2", "volume": "20L", "frequency": "1kHz",
            "resistance": "6.1ohm", "force_factor": "7.5Tm", "density": "1.18kg/m3",
            "speed": "343m/s"}[dimension]


def as_si(value, dimension: str, name: str, *, bare: str | None = None) -> float | None:
    """``value`` (a number in SI, or a string with a unit) as an SI float; ``None`` stays ``None``.
    ``name`` (a keyword or an option) heads the error: ``sd: '85in': unknown unit ...``."""
    if value is None:
        return None
    if isinstance(value, str):
        try:
            return parse_quantity(value, dimension, bare=bare)
        except UnitError as exc:
            raise UnitError(f"{name}: {exc}") from None
    try:
        return float(value)
    except (TypeError, ValueError):
        raise UnitError(f"{name}: expected a number or a string with a unit, got {value!r}") from None


def suggest(value_si: float, dimension: str, unit: str) -> str:
    """How a person writes the same number as the one given in ``unit``: ``8.017g`` for a bare
    8.017 that was meant in grams (the refusal's hint)."""
    return f"{value_si:g}{unit}"
