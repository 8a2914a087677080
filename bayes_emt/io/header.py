"""Column headers of impedance exports: what each column holds, and in which unit.

Recognised spellings (case-insensitive, anywhere in a column name, in brackets or joined by ``_``):

* frequency column: ``f``, ``freq``, ``frequency``, ``omega``, ``ω``, ``w``; units ``Hz``, ``kHz``,
  ``MHz``, ``GHz``, ``rad/s`` (also ``rad_s``, ``rad/sec``, ``rad s^-1``); ``omega``/``ω``/``w``
  mean rad/s;
* value columns: magnitude (``|Z|``, ``mag``, ``abs``, ``magnitude``), phase (``phase``, ``arg``,
  ``angle``, ``theta``), real part (``Re``, ``real``, ``R``, ``Rs``, ``G``), imaginary part (``Im``,
  ``imag``, ``X``, ``Xs``, ``B``); quantity ``Z``/impedance/ohm/``Ω`` or ``Y``/admittance/``S``;
  value units ``ohm``, ``Ω``, ``kΩ``, ``mΩ``, ``S``, ``mS``, ``µS``; phase units ``deg``, ``°``,
  ``rad``;
* an optional fourth column ``weight``.

A column name with a bracketed word that is none of these (``Frequency (furlongs)``) raises, as
does a header that states two different things (``Freq (Hz) (rad/s)``, ``|Z| (S)``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from ..errors import DataFormatError

__all__ = ["Layout", "parse_header"]

_FREQ_SCALE = {"hz": 1.0, "khz": 1e3, "mhz": 1e6, "ghz": 1e9}
_RADPS = re.compile(r"rads?\s*(?:/\s*s(?:ec)?|_s(?:ec)?|\s+per\s+s(?:ec(?:ond)?)?|[\s.·]*s\s*\^?\s*-\s*1)"
                    r"(?![a-z])", re.IGNORECASE)
_TOKEN = re.compile(r"[^\W\d_]+|[|°]")
_GROUP = re.compile(r"[(\[{]([^)\]}]*)[)\]}]")
_OHM = re.compile(r"^([kmMuµμ]?)(?:[oO][hH][mM][sS]?|Ω)$")
_SIEMENS = re.compile(r"^([kmMuµμ]?)(?:[sS]|[sS]iemens|SIEMENS)$")
_PRIME = re.compile(r"(?<![A-Za-z])([ZzYy])\s*(''|\"|'|′′|″|′)")
_PREFIX = {"": 1.0, "k": 1e3, "m": 1e-3, "M": 1e6, "u": 1e-6, "µ": 1e-6, "μ": 1e-6}

_UNIT_LABEL = {"hz": "Hz", "khz": "kHz", "mhz": "MHz", "ghz": "GHz", "rad/s": "rad/s"}
_FREQ_WORDS = {"f", "freq", "frequency", "frequencies", "frq"}
_OMEGA_WORDS = {"omega", "ω", "w"}
_KINDS = {
    "mag": {"|", "mag", "magnitude", "abs", "modulus"},
    "phase": {"phase", "arg", "angle", "ang", "theta", "θ", "phi", "φ"},
    "re": {"re", "real", "r", "rs", "resistance", "g", "conductance"},
    "im": {"im", "imag", "imaginary", "x", "xs", "reactance", "b", "susceptance"},
}
_Z_WORDS = {"z", "impedance", "imp", "r", "rs", "x", "xs", "resistance", "reactance"}
_Y_WORDS = {"y", "admittance", "adm", "g", "b", "conductance", "susceptance"}
_DEG = {"deg", "degs", "degree", "degrees", "°"}
_RAD = {"rad", "rads", "radian", "radians"}
_FILLER = {"of", "in", "the", "value", "data", "ch", "channel", "a", "v"}


@dataclass
class Layout:
    """What the columns of a table hold.

    ``None`` means the header does not say. ``rep`` is ``"magphase"`` or ``"reim"``; ``cols`` are the
    indices of (magnitude, phase) or (real, imaginary) among the value columns 1 and 2; ``scale``
    converts the magnitude/real/imaginary numbers to Ω or S (1 unless the header says kΩ, mS, ...).
    ``signs`` are -1 for a column named with a leading minus (``-Im(Z)``).
    ``units_from`` says where each of ``freq_unit``, ``phase_unit``, ``quantity`` came from.
    """

    freq_unit: str | None = None
    rep: str | None = None
    quantity: str | None = None
    phase_unit: str | None = None
    cols: tuple[int, int] = (1, 2)
    scale: float = 1.0
    signs: tuple[float, float] = (1.0, 1.0)
    weights: bool = False
    units_from: dict = field(default_factory=dict)

    def state(self, attr: str, value: str, source: str) -> None:
        setattr(self, attr, value)
        self.units_from[attr] = source


def _tokens(cell: str) -> tuple[list[str], list[str]]:
    """(all tokens, tokens inside brackets) of a column name; ``rad/s`` becomes ``radps``."""
    text = _RADPS.sub(" radps ", cell)
    inside = [t for g in _GROUP.findall(text) for t in _TOKEN.findall(g)]
    return _TOKEN.findall(text), inside


def _frequency_column(cell: str, where: str) -> str | None:
    toks, inside = _tokens(cell)
    low = [t.lower() for t in toks]
    units = set()
    for t, tl in zip(toks, low, strict=True):
        if tl == "radps" or tl in _OMEGA_WORDS or t == "ω":
            units.add("rad/s")
        elif tl in _FREQ_SCALE:
            units.add(tl)
    if not units and not any(tl in _FREQ_WORDS for tl in low):
        raise DataFormatError(f"{where}: first column {cell!r} is not a frequency column "
                              "(expected e.g. 'Frequency (Hz)' or 'omega (rad/s)')")
    for t in inside:
        tl = t.lower()
        if not (tl == "radps" or tl in _FREQ_SCALE or tl in _FREQ_WORDS or tl in _OMEGA_WORDS):
            raise DataFormatError(f"{where}: unknown unit {t!r} in column {cell!r} "
                                  "(frequency units: Hz, kHz, MHz, GHz, rad/s)")
    if len(units) > 1:
        raise DataFormatError(f"{where}: column {cell!r} states two frequency units "
                              f"({' and '.join(_UNIT_LABEL[u] for u in sorted(units))})")
    return units.pop() if units else None


@dataclass
class _Column:
    kind: str | None = None
    quantities: set = field(default_factory=set)
    scales: set = field(default_factory=set)
    phase_units: set = field(default_factory=set)
    sign: float = 1.0


def _value_column(cell: str, where: str) -> _Column:
    toks, inside = _tokens(cell)
    col, kinds = _Column(), set()
    if cell.lstrip()[:1] in ("-", "−"):
        col.sign = -1.0  # '-Im(Z)', "-Z''": impedance-spectroscopy exports plot minus the reactance
    prime = _PRIME.search(cell)
    if prime:
        kinds.add("im" if prime.group(2) in ("''", '"', "′′", "″") else "re")
        col.quantities.add(prime.group(1).upper())
    for t in toks:
        tl = t.lower()
        m_ohm, m_s = _OHM.match(t), _SIEMENS.match(t)
        if tl in ("db", "dbω", "dbohm", "dbohms"):
            raise DataFormatError(f"{where}: column {cell!r} is in dB; export a linear magnitude "
                                  "(ohm or S) instead")
        if m_ohm or m_s:
            m = m_ohm or m_s
            if m.group(1) == "M" and t.isupper():
                raise DataFormatError(f"{where}: unit {t!r} in column {cell!r} is ambiguous "
                                      "(milli or mega?)")
            col.quantities.add("Z" if m_ohm else "Y")
            col.scales.add(_PREFIX[m.group(1)])
            continue
        if tl in _DEG:
            col.phase_units.add("deg")
        elif tl in _RAD:
            col.phase_units.add("rad")
        if tl in _Z_WORDS:
            col.quantities.add("Z")
        if tl in _Y_WORDS:
            col.quantities.add("Y")
        kinds |= {k for k, words in _KINDS.items() if tl in words}
    for t in inside:
        tl = t.lower()
        known = (_OHM.match(t) or _SIEMENS.match(t) or tl in _DEG or tl in _RAD or tl in _Z_WORDS
                 or tl in _Y_WORDS or tl in _FILLER or any(tl in w for w in _KINDS.values()))
        if not known:
            raise DataFormatError(f"{where}: unknown unit {t!r} in column {cell!r} "
                                  "(value units: ohm, Ω, kΩ, S, mS; phase units: deg, °, rad)")
    if len(kinds) > 1:
        raise DataFormatError(f"{where}: column {cell!r} names several things ({', '.join(sorted(kinds))})")
    if kinds:
        col.kind = kinds.pop()
    elif col.phase_units:
        col.kind = "phase"
    elif col.quantities:
        col.kind = "mag"  # 'Z', 'Impedance', 'Ohm': a magnitude when the other column is a phase
    else:
        raise DataFormatError(f"{where}: cannot tell what column {cell!r} holds "
                              "(expected magnitude/phase or real/imaginary parts)")
    if len(col.phase_units) > 1:
        raise DataFormatError(f"{where}: column {cell!r} states both degrees and radians")
    if col.kind != "phase" and col.phase_units:
        raise DataFormatError(f"{where}: column {cell!r} has an angle unit but is not a phase")
    return col


def parse_header(cells: list[str], where: str) -> Layout:
    """Read a header line's column names into a :class:`Layout`; ``where`` is ``path:line``."""
    if len(cells) not in (3, 4):
        raise DataFormatError(f"{where}: header has {len(cells)} columns; expected frequency and two "
                              "value columns (and optionally a weight column)")
    lay = Layout()
    fu = _frequency_column(cells[0], where)
    if fu is not None:
        lay.state("freq_unit", fu, "header")
    cols = [_value_column(c, where) for c in cells[1:3]]
    kinds = [c.kind for c in cols]
    if sorted(kinds) == ["mag", "phase"]:
        lay.rep, order = "magphase", ("mag", "phase")
    elif sorted(kinds) == ["im", "re"]:
        lay.rep, order = "reim", ("re", "im")
    else:
        raise DataFormatError(f"{where}: columns {cells[1]!r}, {cells[2]!r} are neither magnitude and "
                              "phase nor real and imaginary parts")
    lay.cols = tuple(1 + kinds.index(k) for k in order)
    lay.signs = tuple(cols[i - 1].sign for i in lay.cols)
    if lay.rep == "magphase" and lay.signs[0] < 0:
        raise DataFormatError(f"{where}: a magnitude column cannot be negated ({cells[lay.cols[0]]!r})")
    quantities = set().union(*(c.quantities for c in cols))
    if len(quantities) > 1:
        raise DataFormatError(f"{where}: header mentions both impedance and admittance "
                              f"({cells[1]!r}, {cells[2]!r})")
    if quantities:
        lay.state("quantity", quantities.pop(), "header")
    value_cols = [c for c in cols if c.kind != "phase"]
    scales = set().union(*(c.scales for c in value_cols))
    if len(scales) > 1:
        raise DataFormatError(f"{where}: columns {cells[1]!r}, {cells[2]!r} use different unit prefixes")
    lay.scale = scales.pop() if scales else 1.0
    if lay.rep == "magphase":
        pu = next(c for c in cols if c.kind == "phase").phase_units
        if pu:
            lay.state("phase_unit", pu.pop(), "header")
    if len(cells) == 4:
        if "weight" not in cells[3].lower():
            raise DataFormatError(f"{where}: unexpected fourth column {cells[3]!r} "
                                  "(only 'weight' is allowed)")
        lay.weights = True
    return lay


def freq_scale(unit: str) -> float:
    """Factor from ``unit`` (hz, khz, mhz, ghz) to Hz."""
    return _FREQ_SCALE[unit]
