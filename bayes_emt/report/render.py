"""Render a run folder's saved outputs into one self-contained HTML file (Jinja2 templates shipped
as package data; figures embedded as ``data:`` URIs, so the file can be mailed or archived alone).

The template gets numbers, never pre-formatted text: the filters below print each with its unit
(``q``), angular frequencies with their value in Hz beside (``omega``), and frequency bands in
both units (``band``), so no number reaches the page without its unit.
"""

from __future__ import annotations

import datetime as _dt
import math
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from jinja2 import ChainableUndefined, Environment, PackageLoader, select_autoescape

from .._atomic import atomic_write_text
from . import layout as L
from .figures import redraw_posterior_figures
from .load import RunFiles, finite
from .sections import collect_sections, collect_warnings

__all__ = ["build_report", "render_report", "fmt_quantity"]

TWO_PI = 2.0 * math.pi


def fmt_quantity(x, unit: str = "", spec: str = ".4g") -> str:
    """``x`` formatted by ``spec`` followed by ``unit`` (``–`` when missing or not finite; a word
    such as ``"unstable"`` is shown as it is)."""
    if not finite(x):
        return x if isinstance(x, str) and x else "–"
    text = format(x, spec)
    return f"{text} {unit}".strip() if unit not in ("", "1") else text


def _pm(x, err, unit: str = "", spec: str = ".2f") -> str:
    if not finite(x):
        return "–"
    if not finite(err):
        return fmt_quantity(x, unit, spec)
    return f"{format(x, spec)} ± {format(err, spec)}" + (f" {unit}" if unit else "")


def _omega(w, spec: str = ".4g") -> str:
    if not finite(w):
        return "–"
    return f"{format(w, spec)} rad/s ({format(w / TWO_PI, spec)} Hz)"


def _band(band_hz, band_rad=None) -> str:
    if not band_hz or len(band_hz) != 2 or not all(finite(b) for b in band_hz):
        return "–"
    text = f"{band_hz[0]:.4g}–{band_hz[1]:.4g} Hz"
    if band_rad and all(finite(b) for b in band_rad):
        text += f" ({band_rad[0]:.4g}–{band_rad[1]:.4g} rad/s)"
    return text


def _unit(u) -> str:
    """Display form of the units the JSON files carry."""
    table = {"ohm": "Ω", "N/A/kg^.5": "N/(A kg½)", "N/(A kg^0.5)": "N/(A kg½)"}
    return table.get(u, u or "")


def _environment() -> Environment:
    env = Environment(loader=PackageLoader("bayes_emt.report", "templates"),
                      autoescape=select_autoescape(["html", "j2"]), undefined=ChainableUndefined,
                      trim_blocks=True, lstrip_blocks=True)
    env.filters.update(q=fmt_quantity, pm=_pm, omega=_omega, band=_band, unit=_unit)
    env.tests["number"] = finite
    return env


def _version() -> str:
    try:
        return version("bayes_emt")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
        return "unknown"


def render_report(run_dir: str | Path, *, problems: list[str] | None = None) -> str:
    """The report of ``run_dir`` as an HTML string (nothing written); ``problems`` are extra
    one-line warnings to show on top."""
    rf = RunFiles(Path(run_dir), list(problems or []))
    run = rf.json(L.RUN)
    sections = collect_sections(rf, run)
    warns = collect_warnings(rf, run)
    warns += [{"source": "report", "code": "unreadable", "message": p} for p in rf.problems]
    outputs = sorted(p.name for p in rf.root.iterdir() if p.is_file() and p.name != L.REPORT) \
        if rf.root.is_dir() else []
    ctx = {"run": run or {}, "sections": sections, "by_id": {s["id"]: s for s in sections},
           "warnings": warns, "root": str(rf.root.resolve()), "outputs": outputs,
           "generated": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"), "version": _version(),
           "not_run": [s for s in sections if not s["ran"]]}
    return _environment().get_template("report.html.j2").render(**ctx)


def build_report(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """Write the report of ``run_dir`` (default ``run_dir/report.html``) atomically; return its path.

    The posterior's Bode and corner figures are first redrawn from ``posterior.nc`` if their PNGs
    are missing (the one figure source the report can use on its own).

    Raises
    ------
    FileNotFoundError : ``run_dir`` is not a folder.
    """
    root = Path(run_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"{run_dir}: no such run folder")
    target = Path(out) if out is not None else root / L.REPORT
    problems = redraw_posterior_figures(root)
    atomic_write_text(target, render_report(root, problems=problems))
    return target
