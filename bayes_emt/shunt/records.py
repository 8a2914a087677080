"""Text and HTML around the shunt results: the plain-text summary tables (units in every row)."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

from ..errors import DataFormatError

__all__ = ["design_summary", "html_table", "table", "read_json_record"]


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


def read_json_record(path, what: str) -> dict | list:
    """The JSON a shunt result's ``save`` wrote to ``path``; a missing or unreadable file is a
    one-line :class:`~bayes_emt.errors.DataFormatError` naming it and ``what`` was expected."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataFormatError(f"{path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise DataFormatError(f"{path}: not a JSON {what} ({exc})") from None
