"""``benchmarks/results.json`` and ``benchmarks/RESULTS.md``: the figures of merit, merged per module.

``results.json`` holds, at its top level, every figure a ``bench_*.py`` module's ``measure()``
returned under ``"results"`` (e.g. ``loglike_evals_per_s``, a dict per model), plus ``targets``
(``{"key" or "key.label": [op, number]}``), ``details`` and ``modules`` (revision, date and
duration of each module's last measurement) keyed by module, ``machine`` and the last side-by-side
``comparison`` with the baseline revision. A module's keys are replaced when it is measured again
and kept otherwise, so modules added later (evidence, shunt) extend the file without re-running
the others. ``RESULTS.md`` is regenerated from it every time.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import sys
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS_JSON = HERE / "results.json"
RESULTS_MD = HERE / "RESULTS.md"


def machine() -> dict:
    """What the numbers were measured on (they change with the machine and its load)."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for pkg in ("numpy", "scipy", "emcee", "h5py", "lmfit"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = "absent"
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {"cpu": cpu, "cpus": os.cpu_count(), "python": sys.version.split()[0],
            "platform": platform.platform(), "versions": versions,
            "load_average_1_5_15_min": None if load is None else [round(x, 2) for x in load],
            "omp_num_threads": os.environ.get("OMP_NUM_THREADS", "unset")}


def _load() -> dict:
    if RESULTS_JSON.exists():
        return json.loads(RESULTS_JSON.read_text())
    return {}


def _write(data: dict) -> None:
    tmp = RESULTS_JSON.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    tmp.replace(RESULTS_JSON)
    tmp = RESULTS_MD.with_suffix(".md.tmp")
    tmp.write_text(markdown(data))
    tmp.replace(RESULTS_MD)


def merge(measured: dict, *, revision: str, dirty: bool) -> dict:
    """Merge ``{module: measure() output}`` into results.json, regenerate RESULTS.md; the merged data."""
    data = _load()
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    data["machine"] = machine()
    for key in ("targets", "details", "modules", "owners"):
        data.setdefault(key, {})
    for stem, out in measured.items():
        old = {k for k, owner in data["owners"].items() if owner == stem}
        for key in old:
            data.pop(key, None)
            data["owners"].pop(key)
        data["targets"] = {k: v for k, v in data["targets"].items() if k.split(".")[0] not in old}
        for key, value in out.get("results", {}).items():
            data[key] = value
            data["owners"][key] = stem
        data["targets"].update(out.get("targets", {}))
        data["details"][stem] = out.get("details", {})
        data["modules"][stem] = {"revision": revision + (" + uncommitted changes" if dirty else ""),
                                 "date": now, "seconds": round(out.get("seconds", 0.0), 1)}
    _write(data)
    return data


def record_comparison(sha: str, res: dict) -> None:
    """Store the side-by-side timing ratios (this tree / baseline) of the last comparison."""
    data = _load()
    rows = {}
    for name, r in res.items():
        t, tb = r["now"]["seconds"], r["base"]["seconds"]
        rows[name] = {"now_s": t, "baseline_s": tb, "ratio": t / tb if t and tb else None,
                      "baseline_error": r["base"]["error"], "error": r["now"]["error"]}
    data["comparison"] = {"baseline": sha, "benchmarks": rows,
                          "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")}
    data.setdefault("machine", machine())
    _write(data)


def _rows(data: dict, only: set | None = None):
    """``(key, label, value, target, ok)`` for every figure (per-model dicts flattened)."""
    for key in sorted(data.get("owners", {})):
        if only is not None and data["owners"][key] not in only:
            continue
        value = data.get(key)
        items = value.items() if isinstance(value, dict) else [(None, value)]
        for label, v in items:
            name = key if label is None else f"{key}.{label}"
            target = data.get("targets", {}).get(name)
            ok = None
            if target is not None and isinstance(v, int | float):
                op, thr = target
                ok = v >= thr if op == ">=" else v <= thr
            yield key, label, v, target, ok


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def table(data: dict, only: set | None = None) -> str:
    lines = [f"{'figure':<44}{'value':>14}{'target':>14}"]
    for key, label, v, target, ok in _rows(data, only):
        name = key if label is None else f"{key}.{label}"
        tgt = "" if target is None else f"{target[0]} {_fmt(target[1])} {'✓' if ok else '✗'}"
        lines.append(f"{name:<44}{_fmt(v):>14}{tgt:>14}")
    return "\n".join(lines)


def missed(data: dict, only: set | None = None) -> list[str]:
    return [key if label is None else f"{key}.{label}"
            for key, label, v, target, ok in _rows(data, only) if ok is False]


def markdown(data: dict) -> str:
    """RESULTS.md: the figures with their targets, the machine, per-module notes, the comparison."""
    m = data.get("machine", {})
    out = ["# Benchmark results", "",
           "Generated by `./run bench` (`benchmarks/run.py`) from `benchmarks/results.json`; do not edit.",
           "Absolute times depend on the machine and on what else runs on it (the load average is "
           "recorded): compare ratios measured side by side in one invocation.", "",
           "## Machine", "",
           f"- CPU: {m.get('cpu', '?')} ({m.get('cpus', '?')} cpus), {m.get('platform', '?')}",
           f"- Python {m.get('python', '?')}; "
           + ", ".join(f"{k} {v}" for k, v in m.get("versions", {}).items()),
           f"- load average (1, 5, 15 min) when written: {m.get('load_average_1_5_15_min')}; "
           f"OMP_NUM_THREADS={m.get('omp_num_threads')}", "",
           "## Figures of merit", "", "| figure | value | target | met |", "|---|---|---|---|"]
    for key, label, v, target, ok in _rows(data):
        name = key if label is None else f"{key}.{label}"
        tgt = "" if target is None else f"{target[0]} {_fmt(target[1])}"
        out.append(f"| `{name}` | {_fmt(v)} | {tgt} | {'' if ok is None else ('yes' if ok else '**no**')} |")
    out += ["", "## Per module", ""]
    for stem, info in sorted(data.get("modules", {}).items()):
        out.append(f"### `{stem}` ({info['date']}, revision {info['revision']}, {info['seconds']} s)")
        out.append("")
        details = data.get("details", {}).get(stem, {})
        for note in details.get("notes", []):
            out.append(f"- {note}")
        rest = {k: v for k, v in details.items() if k != "notes"}
        if rest:
            out += ["", "```json", json.dumps(rest, indent=1, sort_keys=True), "```"]
        out.append("")
    comp = data.get("comparison")
    if comp:
        out += [f"## Side by side with the baseline revision {comp['baseline'][:12]} ({comp['date']})", "",
                "| benchmark | baseline [s] | now [s] | now / baseline |", "|---|---|---|---|"]
        for name, r in comp["benchmarks"].items():
            out.append(f"| {name} | {_fmt(r['baseline_s'])} | {_fmt(r['now_s'])} | {_fmt(r['ratio'])} |")
        out.append("")
    return "\n".join(out) + "\n"
