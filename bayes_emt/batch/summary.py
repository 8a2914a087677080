"""The batch summary table, CSV, HTML and JSON, rebuilt from the result folders themselves.

Per recording: the fit's headline numbers, the free-air Thiele–Small set (fs [Hz], Re [Ω], Qms,
Qes, Qts: the posterior's medians when ``sample`` ran, else the fit's; ``T/S from`` says which,
as ``fit``, ``sample`` and ``ts`` print it) and the sampler's health. ``summary.json`` has the same
rows with each T/S value's 90 % interval and unit (strict JSON).

The table is a function of what is on disk (each folder's completion marker or error record), not
of one run's memory, so it is right after a kill, after a resume, and when rebuilt on its own.
Both files are written atomically. The HTML is a Jinja2 template (autoescaped), one self-contained
page.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import jinja2

from .._atomic import atomic_write_text
from .._json import strict_json
from .inputs import BatchInput
from .jobs import read_error, read_marker

__all__ = ["COLUMNS", "summary_rows", "write_summary"]

#: (key, header with unit, format) of the summary columns after file/status.
COLUMNS = (
    ("points", "points", "{:d}"),
    ("f_min_hz", "f min [Hz]", "{:.4g}"),
    ("f_max_hz", "f max [Hz]", "{:.4g}"),
    ("rms_rel_residual", "rms rel. residual [1]", "{:.4g}"),
    ("f0_hz", "f0 [Hz]", "{:.5g}"),
    ("omega0_rad_s", "omega0 [rad/s]", "{:.5g}"),
    ("zeta", "zeta [1]", "{:.4g}"),
    ("phi_N_per_A_sqrtkg", "phi [N/(A kg^0.5)]", "{:.4g}"),
    ("R0_ohm", "R0 [ohm]", "{:.5g}"),
    ("fs_hz", "fs [Hz]", "{:.4g}"),
    ("Re_ohm", "Re [ohm]", "{:.4g}"),
    ("Qms", "Qms [1]", "{:.4g}"),
    ("Qes", "Qes [1]", "{:.4g}"),
    ("Qts", "Qts [1]", "{:.4g}"),
    ("ts_from", "T/S from", "{}"),
    ("converged", "sampler converged", "{}"),
    ("steps", "sampler steps", "{:d}"),
    ("ess_min", "min ESS", "{:.0f}"),
    ("seconds", "time [s]", "{:.1f}"),
)

_TEMPLATE = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined).from_string("""\
<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>bayes-emt batch summary</title>
<style>
body { font-family: sans-serif; margin: 1.5em; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.5em; text-align: right; }
td.text, th { text-align: left; }
tr.error td { background: #fde2e2; }
tr.pending td { background: #f3f3f3; color: #666; }
</style></head>
<body>
<h1>bayes-emt batch summary</h1>
<p>{{ counts.done }} done, {{ counts.error }} failed, {{ counts.pending }} not finished,
of {{ total }} recordings. Jobs: {{ jobs }}; model {{ model }}.</p>
<table id="summary">
<thead><tr><th>file</th><th>status</th>{% for h in headers %}<th>{{ h }}</th>{% endfor %}
<th>warnings / error</th></tr></thead>
<tbody>
{% for row in rows %}<tr class="{{ row.status }}"><td class="text">{{ row.file }}</td>
<td class="text">{{ row.status }}</td>{% for v in row.cells %}<td>{{ v }}</td>{% endfor %}
<td class="text">{{ row.note }}</td></tr>
{% endfor %}</tbody></table>
</body></html>
""")


def _cell(value, fmt: str) -> str:
    if value is None:
        return ""
    try:
        return fmt.format(value)
    except (ValueError, TypeError):
        return str(value)


def summary_rows(inputs: list[BatchInput], out: Path) -> list[dict]:
    """One row per input: ``file``, ``folder``, ``status`` (done / error / pending), the
    :data:`COLUMNS` values (raw numbers), ``warnings`` and ``error``."""
    rows = []
    for inp in inputs:
        folder = Path(out) / inp.name
        row = {"file": str(inp.path), "folder": inp.name, "status": "pending", "error": "", "warnings": ""}
        marker = read_marker(folder)
        err = read_error(folder) if marker is None else None
        if marker is not None:
            row.update(status="done", **marker.get("summary", {}), seconds=marker.get("seconds"),
                       warnings=" | ".join(marker.get("warnings", [])))
        elif err is not None:
            row.update(status="error", error=err.get("error", ""))
        rows.append(row)
    return rows


def write_summary(inputs: list[BatchInput], out: Path, *, jobs: tuple[str, ...], model: str) -> dict:
    """Write ``summary.csv``, ``summary.html`` and ``summary.json`` in ``out``; returns the counts by
    status."""
    out = Path(out)
    rows = summary_rows(inputs, out)
    keys = [k for k, _, _ in COLUMNS]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["file", "folder", "status"] + [h for _, h, _ in COLUMNS] + ["warnings", "error"])
    for r in rows:
        values = ["" if r.get(k) is None else r.get(k) for k in keys]
        w.writerow([r["file"], r["folder"], r["status"], *values, r["warnings"], r["error"]])
    atomic_write_text(out / "summary.csv", buf.getvalue())
    counts = {s: sum(r["status"] == s for r in rows) for s in ("done", "error", "pending")}
    units = {k: h for k, h, _ in COLUMNS}
    atomic_write_text(out / "summary.json", json.dumps(strict_json(
        {"jobs": list(jobs), "model": model, "counts": counts, "columns": units,
         "rows": [{k: r.get(k) for k in ("file", "folder", "status", *keys, "ts", "warnings", "error")}
                  for r in rows]}), indent=2, allow_nan=False) + "\n")
    html_rows = [{"file": r["file"], "status": r["status"],
                  "cells": [_cell(r.get(k), fmt) for k, _, fmt in COLUMNS],
                  "note": r["error"] or r["warnings"]} for r in rows]
    atomic_write_text(out / "summary.html", _TEMPLATE.render(
        rows=html_rows, headers=[h for _, h, _ in COLUMNS], counts=counts, total=len(rows),
        jobs=", ".join(jobs), model=model))
    return counts
