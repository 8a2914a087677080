"""The frozen T/S result: values with 90 % intervals and model spread, JSON in and out, a
plain-text table in the field's units."""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

from .._atomic import atomic_write_text
from .._json import strict_json
from .._record import register_kind
from .._warnlines import group_warnings
from ..errors import DataFormatError
from .relations import DISPLAY, NAMES, UNITS

__all__ = ["ThieleSmall", "read_thiele_small", "METHODS"]

METHODS = ("free_air", "added_mass", "added_volume")


def _fmt(v: float) -> str:
    if v is None or not math.isfinite(v):
        return "-"
    a = abs(v)
    if a == 0:
        return "0"
    if a >= 1000:
        return f"{v:.0f}"
    return f"{v:.4g}" if a >= 0.01 else f"{v:.3g}"


@dataclass(frozen=True)
class ThieleSmall:
    """Thiele–Small parameters of one driver (:func:`~bayes_emt.thiele_small.thiele_small`).

    Attributes
    ----------
    model : the model spec the values come from.
    method : ``"free_air"``, ``"added_mass"`` or ``"added_volume"``.
    parameters : ``{name: {"value", "ci90": [lo, hi] | None, "unit", "model_spread": [lo, hi] | None,
        "model_only"?: {"model", "value", "ci90"}}}`` in SI (names and units:
        :data:`~bayes_emt.thiele_small.relations.UNITS`); ``value`` and ``ci90`` are the median and
        5-95 % of the evidence-weighted mixture over the candidate models (``inputs["mixture"]``;
        the main model alone when no other candidate has weight), ``model_only`` the main model's
        own posterior (``fast``: the fit's Gaussian approximation). With ``intervals="total"``
        (default) or ``"misfit"``, ``ci90`` also holds where a further method's value falls, from
        the definitional spread between methods (:mod:`bayes_emt.thiele_small.definitional`): such
        an entry carries ``ci90_model`` (the mixture's interval before it) and ``definitional_sd``
        (the spread's standard deviation, SI).
    inputs : what was given (files, masses, box volume, Sd, ohmmeter reading, air) and how the
        intervals were obtained (``uncertainty``: ``"posterior"`` or ``"laplace"``).
    warnings : ``{"code", "message", "model"?, "band_hz"?}`` records.
    curve : the fitted free-air impedance curve with its 90 % posterior predictive band and the
        recording's points (:mod:`bayes_emt.thiele_small.curve`), or ``None``; what the figure of
        the fit (:func:`bayes_emt.plotting.thiele_small.plot_ts_fit`) is drawn from.
    model_free : Small's model-free values read off the free-air curve
        (:func:`~bayes_emt.thiele_small.model_free.model_free_ts`: ``{"parameters", "re_source",
        "inputs"}``), ``{"refused": reason}`` where the method is undefined, or None (not computed).
    bench_fit : the bench's own fit of the same recording beside ours
        (:func:`~bayes_emt.thiele_small.references.bench_comparison`), or None.
    """

    model: str
    method: str
    parameters: dict
    inputs: dict = field(default_factory=dict)
    warnings: tuple = ()
    model_free: dict | None = None
    bench_fit: dict | None = None
    curve: dict | None = field(default=None, compare=False, repr=False)

    kind: ClassVar[str] = "thiele_small"

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")

    def __getitem__(self, name: str) -> float:
        return self.parameters[name]["value"]

    def __repr__(self) -> str:
        keys = [k for k in ("fs", "Qts", "Vas") if k in self.parameters]
        vals = ", ".join(f"{k}={self.parameters[k]['value']:.4g} {self.parameters[k]['unit']}" for k in keys)
        return f"ThieleSmall({self.method}, {self.model}: {vals}, {len(self.parameters)} parameters)"

    def rows(self) -> list[tuple[str, str, str, str, str]]:
        """``(name, value, 90 % interval, model spread, unit)`` in display units."""
        out = []
        for name in NAMES:
            p = self.parameters.get(name)
            if p is None:
                continue
            unit, f = DISPLAY[name]
            ci = p.get("ci90")
            sp = p.get("model_spread")
            spread = "-" if sp is None else f"{_fmt(sp[0] * f)} .. {_fmt(sp[1] * f)}"
            interval = "-" if ci is None else f"{_fmt(ci[0] * f)} .. {_fmt(ci[1] * f)}"
            out.append((name, _fmt(p["value"] * f), interval, spread, unit))
        return out

    def reference_head(self) -> tuple[str, ...]:
        """Headers of the reference columns (:meth:`reference_cells`): the model-free value with its
        interval, and the bench's value, its difference from ours and whether our interval holds it."""
        head = ()
        if self.model_free and "parameters" in self.model_free:
            head += ("model-free (90 %)",)
        if self.bench_fit:
            head += (self.bench_fit.get("bench", "bench"), "diff", "in ours")
        return head

    def reference_cells(self, name: str) -> tuple[str, ...]:
        """The reference columns of one parameter in display units (``-`` where absent)."""
        cells = ()
        unit, f = DISPLAY.get(name, ("", 1.0))
        if self.model_free and "parameters" in self.model_free:
            q = self.model_free["parameters"].get(name)
            cells += ("-" if q is None else
                      f"{_fmt(q['value'] * f)} ({_fmt(q['ci90'][0] * f)} .. {_fmt(q['ci90'][1] * f)})",)
        if self.bench_fit:
            b = self.bench_fit["values"].get(name)
            if b is None:
                cells += ("-", "-", "-")
            else:
                d = b["difference_pct"]
                inside = {True: "yes", False: "no", None: "-"}[b["inside_ci90"]]
                cells += (_fmt(b["bench"] * f), "-" if d is None else f"{d:+.1f} %", inside)
        return cells

    def summary(self) -> str:
        """A plain-text table (Hz, Ω, mH, g, mm/N, L, dB) with a header line and the warnings'
        codes (one line each); the model-free and bench columns beside ours when present."""
        extra = self.reference_head()
        rows = [r[:4] + self.reference_cells(r[0]) + r[4:] for r in self.rows()]
        head = ("parameter", "value", "90 % interval", "model spread", *extra, "unit")
        widths = [max(len(str(r[i])) for r in [head, *rows]) for i in range(len(head))]
        line = "  ".join(f"{{:<{w}}}" for w in widths)
        how = self.inputs.get("uncertainty", "posterior")
        how = {"none": "no intervals", "laplace": "intervals from a Gaussian (Laplace) approximation"}.get(
            how, f"intervals from the {how}")
        text = [f"Thiele-Small parameters ({self.method.replace('_', ' ')}, model {self.model}, {how})",
                line.format(*head), "  ".join("-" * w for w in widths)]
        text += [line.format(*r) for r in rows]
        text += self.reference_notes()
        for g in group_warnings(self.warnings):  # one line each; the full text is in to_json()
            who = f" ({', '.join(g['sources'])})" if g["sources"] else ""
            text.append(f"warning [{g['code']}]{g['band']}: {g['short']}{who}")
        return "\n".join(text)

    def reference_notes(self) -> list[str]:
        """One line each: where the model-free column's Re came from, or why it is absent; where
        the bench's fit came from."""
        out = []
        mf = self.model_free
        if mf and "parameters" in mf:
            out.append(f"model-free: Small's method on the curve, Re from the {mf['re_source']}")
            out += [f"model-free: {n}" for n in mf.get("inputs", {}).get("notes", [])]
        elif mf and "refused" in mf:
            out.append(f"model-free: not available ({mf['refused']})")
        if self.bench_fit:
            src = self.bench_fit.get("source")
            out.append(f"{self.bench_fit.get('bench', 'bench')}: the bench's own fit of this recording"
                       + (f" ({src})" if src else "") + "; diff = (bench - value)/value, in ours = inside "
                       "the 90 % interval")
        return out

    def _repr_html_(self) -> str:
        full = [r[:4] + self.reference_cells(r[0]) + r[4:] for r in self.rows()]
        cells = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                        for r in full)
        extra = "".join(f"<th>{html.escape(h)}</th>" for h in self.reference_head())
        warn = "".join(f"<li>{html.escape(w['code'])}: {html.escape(w['message'])}</li>"
                       for w in self.warnings)
        return (f"<p>Thiele–Small parameters ({html.escape(self.method)}, "
                f"model {html.escape(self.model)})</p>"
                "<table><tr><th>parameter</th><th>value</th><th>90 % interval</th><th>model spread</th>"
                f"{extra}<th>unit</th></tr>{cells}</table>"
                + "".join(f"<p>{html.escape(n)}</p>" for n in self.reference_notes())
                + (f"<ul>{warn}</ul>" if warn else ""))

    def to_json_dict(self) -> dict:
        """``{"kind": "thiele_small", "model", "method", "parameters", "inputs", "warnings"}`` (SI,
        strict JSON; ``be.load`` reads it by its kind)."""
        rec = {"kind": self.kind, "model": self.model, "method": self.method,
               "parameters": self.parameters, "inputs": self.inputs,
               "warnings": [dict(w) for w in self.warnings]}
        if self.curve is not None:
            rec["curve"] = self.curve
        if self.model_free is not None:
            rec["model_free"] = self.model_free
        if self.bench_fit is not None:
            rec["bench_fit"] = self.bench_fit
        return strict_json(rec)

    @classmethod
    def from_json_dict(cls, rec: dict) -> ThieleSmall:
        return read_thiele_small(rec)

    def to_json(self) -> str:
        return json.dumps(self.to_json_dict(), indent=2, allow_nan=False)

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_json` atomically to ``path``."""
        path = Path(path)
        atomic_write_text(path, self.to_json() + "\n")
        return path


def read_thiele_small(source: str | Path | dict) -> ThieleSmall:
    """A :class:`ThieleSmall` from its JSON file (or the dict of :meth:`ThieleSmall.to_json_dict`)."""
    where = "<dict>"
    if not isinstance(source, dict):
        where = str(source)
        try:
            source = json.loads(Path(source).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise DataFormatError(f"{where}: not a readable T/S JSON file ({exc})") from None
    missing = [k for k in ("model", "method", "parameters") if k not in source]
    if missing:
        raise DataFormatError(f"{where}: not a T/S record, missing {missing}")
    for name, p in source["parameters"].items():
        if name not in UNITS or not {"value", "ci90", "unit"} <= set(p):
            raise DataFormatError(f"{where}: parameter {name!r} is not a T/S entry with value, ci90, unit")
    return ThieleSmall(model=str(source["model"]), method=str(source["method"]),
                       parameters=dict(source["parameters"]), inputs=dict(source.get("inputs", {})),
                       warnings=tuple(source.get("warnings", ())), model_free=source.get("model_free"),
                       bench_fit=source.get("bench_fit"),
                       curve=source["curve"] if isinstance(source.get("curve"), dict) else None)


register_kind(ThieleSmall)
