"""Text, HTML and JSON around the shunt results: the summary tables, and reading a saved
:class:`~bayes_emt.shunt.design.ShuntDesign` back."""

from __future__ import annotations

import html
import json
import math
from dataclasses import fields
from pathlib import Path

from ..errors import DataFormatError

__all__ = ["design_summary", "html_table", "read_shunt_design", "design_from_json_dict", "table"]


def table(rows, header) -> list[str]:
    """Left-aligned plain-text table lines."""
    rows = [tuple(str(c) for c in r) for r in rows]
    widths = [max([len(str(h))] + [len(r[i]) for r in rows]) for i, h in enumerate(header)]
    line = "  ".join(f"{h:<{w}}" for h, w in zip(header, widths, strict=True))
    out = [line.rstrip(), "  ".join("-" * w for w in widths)]
    out += ["  ".join(f"{c:<{w}}" for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    return out


def _g(v, spec=".5g") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-" if v is None or math.isnan(v) else ("inf" if v > 0 else "-inf")
    return format(v, spec)


def design_summary(d) -> str:
    """The plain-text summary of a :class:`~bayes_emt.shunt.design.ShuntDesign`."""
    rows = [("Rs", _g(d.Rs), "ohm"), ("Cs", _g(d.Cs), "F"),
            ("attenuation", _g(d.attenuation_db, ".3f"), "dB"),
            ("peak frequency", _g(d.peak_omega / (2 * math.pi), ".4g"), "Hz"),
            ("stable", "yes" if d.stable else "NO", ""),
            ("instability threshold Rs", _g(d.Rs_instability), "ohm"),
            ("stability margin", _g(d.stability_margin_ohm, ".4g"), "ohm"),
            ("R0 assumed", _g(d.R0, ".5g"), "ohm"),
            ("R0 uncertainty compared", _g(d.r0_uncertainty_ohm, ".4g"), "ohm")]
    rows += [(f"  {k}", _g(v, ".4g"), "ohm") for k, v in d.r0_uncertainty.items()]
    lines = [f"H-infinity optimal RC shunt, model {d.model} ({d.optimum})"]
    lines += table(rows, ("quantity", "value", "unit"))
    lines += [f"WARNING [{w['code']}]: {w['message']}" for w in d.warnings]
    lines += [f"note: {n}" for n in d.notes]
    return "\n".join(lines)


def html_table(text: str) -> str:
    """A summary as preformatted HTML (notebooks)."""
    return f"<pre>{html.escape(text)}</pre>"


def design_from_json_dict(rec: dict, *, where: str = "shunt design"):
    """A :class:`~bayes_emt.shunt.design.ShuntDesign` from its :meth:`to_json_dict` (nulls, the JSON
    form of non-finite numbers, read back as NaN, or +inf for an unstable design's attenuation)."""
    from .design import ShuntDesign

    if not isinstance(rec, dict):
        raise DataFormatError(f"{where}: expected a JSON object")
    names = [f.name for f in fields(ShuntDesign)]
    missing = [n for n in names[:14] if n not in rec]
    if missing:
        raise DataFormatError(f"{where}: not a shunt design (missing {', '.join(missing)})")
    kw = {}
    for n in names:
        if n not in rec:
            continue
        v = rec[n]
        if v is None and n not in ("max_pole_real", "min_damping_ratio", "r0_uncertainty_ohm"):
            v = math.inf if n == "attenuation_db" and not rec.get("stable", True) else math.nan
        if n == "peaks":
            v = tuple(tuple(p) for p in v)
        elif n in ("warnings", "notes"):
            v = tuple(dict(w) if isinstance(w, dict) else w for w in v)
        kw[n] = v
    return ShuntDesign(**kw)


def read_shunt_design(path: str | Path):
    """Read a design written by :meth:`ShuntDesign.save` (or ``shunt --json``)."""
    p = Path(path)
    try:
        rec = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataFormatError(f"{path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise DataFormatError(f"{path}: not a JSON shunt design ({exc})") from None
    return design_from_json_dict(rec, where=str(path))
