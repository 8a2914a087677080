"""The truth corpus, one command: do ``ts``'s 90 % intervals hold independent references?

    OMP_NUM_THREADS=1 python scripts/truth/run.py [--label NAME] [--cache DIR] [--shared DIR]
        [--git OWNER/NAME=GITDIR]... [--only ID]... [--seed 0] [--out scripts/results/truth]

For every driver of ``scripts/truth/corpus.toml`` whose recording is available (``fetch.py``
downloads it at the pinned commit into ``~/.cache/bayes_emt_truth`` and checks its SHA-256;
``--shared DIR`` uses unchanged copies found in DIR):

1. the recording is read with the installed package's reader (``bayes_emt.io.read_measurement``);
   where that reader refuses a DATS export, with this script's own minimal DATS parser (the ``*``
   header's fit as ``meta["bench_fit"]``; the leading rows that repeat one value, below the
   analyser's resolution, dropped); Novak's U/I/velocity recording becomes ``Z = U/I`` on 400
   log-spaced FFT bins over 10 Hz-19.5 kHz (``novak.py``); an entry's added-mass recordings
   (``[[driver.loaded]]``) are read the same way and given to ``thiele_small`` as ``loaded`` (method
   ``added_mass``); a reference that differs from the bench fit in the file's own header is a
   skip line, not a score;
2. ``bayes_emt.thiele_small.thiele_small(meas, seed=SEED)`` with its default settings (column
   ``default``: its ``ci90``, the model mixture with the definitional spread between methods);
   column ``model``: the same result's ``ci90_model``, the model's own interval "if the model were
   exact" (``ci90`` for a package without it); with ``--white`` also a run with ``noise="white"``;
3. Small's model-free values off the curve (column ``model_free``, from the same result's
   ``model_free`` record when the package computes one).

Printed per driver and parameter: each column's value, 90 % interval, the reference, the error
``100 (value - reference) / reference`` [%] and whether the interval holds the reference; then per
column the corpus's coverage (pairs whose interval holds the reference, of all scored pairs) and
the median half-width ``100 (hi - lo) / 2 / value`` [%], and the agreement rate: pairs whose
difference is within √2 times the interval's half on the reference's side, i.e. ISO 13528's En
score at the 90 % level with the reference's uncertainty taken equal to ours (a reference is
another method's value with an uncertainty of its own: against a reference as uncertain as we are,
a calibrated 90 % interval holds it in only about 75 % of pairs, and agrees with it in about 90 %).
Writes ``<out>/truth_<label>.json`` (the
table, the summary, the package version and commit, timings in CPU seconds) and
``<out>/truth_<label>.png`` (intervals as bars against the references, one panel per parameter),
atomically. ``--label`` names the run (e.g. the branch whose package was imported).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from fetch import default_cache, fetch, fetch_loaded, load_corpus, parse_git_options  # noqa: E402

import bayes_emt  # noqa: E402
from bayes_emt.measurement import Measurement  # noqa: E402
from bayes_emt.thiele_small import thiele_small  # noqa: E402

REPO = HERE.parents[1]
#: DATS header keys -> (name, factor to SI) (the `*` style; 0 means "not computed")
DATS_KEYS = {"f(s)": ("fs", 1.0), "R(e)": ("Re", 1.0), "Q(ms)": ("Qms", 1.0), "Q(es)": ("Qes", 1.0),
             "Q(ts)": ("Qts", 1.0), "L(e)": ("Le", 1e-3), "M(ms)": ("Mms", 1e-3), "C(ms)": ("Cms", 1e-3),
             "BL": ("Bl", 1.0), "V(as)": ("Vas", 1e-3)}


def read_dats_minimal(path: Path) -> Measurement:
    """A DATS ``*``-style export: the curve (Hz, ohm, deg) without its leading repeated rows, the
    header's fit as ``meta["bench_fit"]``."""
    values, rows = {}, []
    for ln in path.read_text(encoding="latin-1").splitlines():
        s = ln.strip()
        if s.startswith("*"):
            m = re.match(r"\*\s*([A-Za-z()]+)\s*=\s*([-+0-9.eE]+)", s)
            if m and m.group(1) in DATS_KEYS and float(m.group(2)) != 0:
                name, k = DATS_KEYS[m.group(1)]
                values[name] = float(m.group(2)) * k
            continue
        try:
            rows.append([float(x) for x in s.split()[:3]])
        except ValueError:
            continue
    a = np.array([r for r in rows if len(r) == 3])
    same = np.r_[True, np.any(np.diff(a[:, 1:], axis=0) != 0, axis=1)]  # first of each run of equal rows
    # the resolution band: up to the last run of repeated rows (the analyser's bins below ~10 Hz)
    rep = np.flatnonzero(~same)
    start = int(rep[-1]) + 1 if rep.size and a[rep[-1], 0] < 20.0 else 0
    a = a[start:]
    Z = a[:, 1] * np.exp(1j * np.deg2rad(a[:, 2]))
    return Measurement.from_impedance(2 * math.pi * a[:, 0], Z, meta={
        "source": str(path), "bench_fit": {"bench": "DATS", "source": path.name, "values": values},
        "dropped_below_hz": float(a[0, 0])})


def read_entry(entry: dict, path: Path) -> tuple[Measurement, str]:
    if entry["format"] == "novak_npz":
        from novak import measurement

        return measurement(path), "novak.py (Z = U/I)"
    if entry["format"] == "zma":  # a plain impedance file: the package's reader or nothing
        from bayes_emt.io import read_measurement

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return read_measurement(path), "bayes_emt.io.read_measurement"
    try:
        from bayes_emt.io import read_measurement

        meas = read_measurement(path)
        if "bench_fit" in meas.meta:
            return meas, "bayes_emt.io.read_measurement"
    except Exception:  # noqa: BLE001 - the installed reader refuses DATS exports: fall back
        pass
    return read_dats_minimal(path), "run.py's minimal DATS parser"


def bench_fit_mismatch(entry: dict, meas: Measurement, rel: float = 1e-3) -> list[str]:
    """The reference values that differ from the bench fit the file itself carries (DATS header):
    a typing slip in the corpus would otherwise score against a wrong number."""
    values = meas.meta.get("bench_fit", {}).get("values", {})
    out = []
    for name, ref in entry["reference"].items():
        v = values.get(name)
        if v is not None and abs(v - ref) > rel * abs(ref):
            out.append(f"{name}: corpus {ref:g}, file header {v:g}")
    return out


def _ts(meas, seed: int, noise: str | None, loaded=(), intervals: str | None = None):
    kw = {} if noise is None else {"noise": noise}
    if loaded:
        kw["loaded"] = list(loaded)
    if intervals is not None:
        kw["intervals"] = intervals
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = thiele_small(meas, seed=seed, **kw)
    return r, time.process_time() - t0


def _repo_module(rel: str, name: str):
    """``name`` from the package that was imported, else this repository's file ``rel`` loaded under
    that name (so the script runs with another branch's package that lacks it)."""
    import importlib
    import importlib.util

    try:
        return importlib.import_module(name)
    except ImportError:
        spec = importlib.util.spec_from_file_location(name, REPO / rel)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
        return mod


def model_free_of(res, meas, seed: int) -> dict:
    """The result's ``model_free`` record, or (a package without it) Small's method from this
    repository with Re from the result's Re and its interval."""
    mf = getattr(res, "model_free", None)
    if mf is not None:
        return mf
    m = _repo_module("bayes_emt/thiele_small/model_free.py", "bayes_emt.thiele_small.model_free")
    p = res.parameters["Re"]
    sd = 0.0 if p.get("ci90") is None else (p["ci90"][1] - p["ci90"][0]) / (2 * 1.6449)
    try:
        return m.model_free_ts(meas, (p["value"], sd), re_source=f"model R0 ({res.model})",
                               seed=seed).to_json_dict()
    except m.ModelFreeUndefined as exc:
        return {"refused": str(exc)}


def _entry(p: dict | None) -> dict | None:
    if not p or p.get("value") is None:
        return None
    ci = p.get("ci90")
    return {"value": float(p["value"]), "ci90": None if ci is None else [float(x) for x in ci]}


def score(value_ci: dict | None, ref: float) -> dict | None:
    if value_ci is None:
        return None
    v, ci = value_ci["value"], value_ci["ci90"]
    out = {**value_ci, "error_pct": 100.0 * (v - ref) / ref}
    if ci is not None:
        out["covered"] = bool(ci[0] <= ref <= ci[1])
        out["half_width_pct"] = 100.0 * (ci[1] - ci[0]) / 2.0 / abs(v)
        # agreement with a reference as uncertain as we are (ISO 13528's En with the reference's
        # expanded uncertainty taken equal to ours): the difference within sqrt(2) x the interval's
        # half on the reference's side
        half = (ci[1] - v) if ref >= v else (v - ci[0])
        out["agrees"] = bool(abs(v - ref) <= math.sqrt(2.0) * max(half, 0.0))
    return out


def summarise(rows: list[dict], column: str) -> dict:
    cells = [r["columns"][column] for r in rows
             if r["columns"].get(column) and "covered" in r["columns"][column]]
    if not cells:
        return {"pairs": 0}
    cov = sum(c["covered"] for c in cells)
    agree = sum(c.get("agrees", False) for c in cells)
    return {"pairs": len(cells), "covered": int(cov), "coverage": cov / len(cells),
            "agreeing": int(agree), "agreement": agree / len(cells),
            "median_half_width_pct": float(np.median([c["half_width_pct"] for c in cells])),
            "median_abs_error_pct": float(np.median([abs(c["error_pct"]) for c in cells]))}


def _commit() -> str:
    src = Path(bayes_emt.__file__).resolve().parents[1]
    try:
        out = subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=10)
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "bayes_emt"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        if out.returncode != 0 or not out.stdout.strip():
            return "unknown (not a git checkout: pass --code)"
        return out.stdout.strip() + ("+uncommitted" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--label", default="default", help="name of this run (output file names)")
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument("--shared", type=Path, default=None,
                    help="a directory holding unchanged copies of corpus recordings (checked by SHA-256)")
    ap.add_argument("--only", action="append", default=[], metavar="ID", help="run only these corpus ids")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--git", action="append", default=[], metavar="OWNER/NAME=GITDIR",
                    help="read that repository's recordings from a local clone (fetch.py --git)")
    ap.add_argument("--intervals", default=None, help="ts's intervals= option (default: the package's)")
    ap.add_argument("--white", action="store_true",
                    help="also run ts with noise='white' (column 'white'; the default noise is white today)")
    ap.add_argument("--out", type=Path, default=REPO / "scripts" / "results" / "truth")
    ap.add_argument("--code", default=None,
                    help="what the imported package is, when it is not a git checkout (e.g. 'branch@commit', "
                         "for a tree exported with git archive and put first on PYTHONPATH)")
    ap.add_argument("--replot", type=Path, default=None, metavar="JSON",
                    help="only redraw the picture of a run's JSON (beside it, same name .png)")
    a = ap.parse_args(argv)
    if a.replot is not None:
        print("wrote", draw(json.loads(a.replot.read_text()), a.replot.with_suffix(".png")))
        return 0
    cache = a.cache or default_cache()
    entries = [e for e in load_corpus() if not a.only or e["id"] in a.only]
    rows, drivers, notes = [], [], []
    white_ok = a.white
    gitdirs = parse_git_options(a.git)
    for e in entries:
        path = fetch(e, cache, a.shared, gitdirs=gitdirs)
        loaded_paths = fetch_loaded(e, cache, a.shared, gitdirs=gitdirs)
        if path is None or loaded_paths is None:
            continue
        meas, reader = read_entry(e, path)
        loaded = [(read_entry(e, q)[0], dm) for q, dm in loaded_paths]
        bad = bench_fit_mismatch(e, meas)
        if bad:
            print(f"skip {e['id']}: its reference differs from the file's own bench fit ({'; '.join(bad)})",
                  file=sys.stderr)
            continue
        res, cpu = _ts(meas, a.seed, None, loaded, a.intervals)
        info = {"id": e["id"], "unit": e["unit"], "reader": reader, "n_points": meas.n_points,
                "added_masses_kg": [dm for _, dm in loaded], "method": res.method,
                "f_range_hz": [float(meas.f_hz[0]), float(meas.f_hz[-1])], "model": res.model,
                "cpu_s": {"default": cpu}, "warnings": [w.get("code") for w in res.warnings],
                "model_spread": res.inputs.get("model_spread", {}).get("included")}
        white = None
        if white_ok:
            try:
                white, cpu_w = _ts(meas, a.seed, "white", loaded)
                info["cpu_s"]["white"] = cpu_w
            except TypeError:  # this package has no noise option
                white_ok = False
                notes.append("the installed bayes_emt has no noise= option: no 'white' column")
        mf = model_free_of(res, meas, a.seed)
        info["model_free"] = ("refused: " + mf["refused"] if "refused" in mf
                              else f"Re from the {mf['re_source']}")
        drivers.append(info)
        for name in e["compare"]:
            ref = float(e["reference"][name])
            cols = {"default": score(_entry(res.parameters.get(name)), ref)}
            p = res.parameters.get(name)
            if p and "ci90_model" in p:  # the model's own interval, before the definitional spread
                cols["model"] = score(_entry({**p, "ci90": p["ci90_model"]}), ref)
            elif p:
                cols["model"] = cols["default"]
            if white is not None:
                cols["white"] = score(_entry(white.parameters.get(name)), ref)
            if "parameters" in mf and name != "Re":  # its Re is the model's (an input, not a reading)
                cols["model_free"] = score(_entry(mf["parameters"].get(name)), ref)
            rows.append({"driver": e["id"], "parameter": name, "reference": ref,
                         "reference_kind": e["reference_kind"],
                         "columns": {k: v for k, v in cols.items() if v}})
        print(f"# {e['id']}: {e['unit']}; {meas.n_points} points {meas.f_hz[0]:.4g}-{meas.f_hz[-1]:.4g} Hz, "
              f"read by {reader}; " + "".join(f"+ {1e3 * dm:g} g added; " for _, dm in loaded)
              + f"reference: {e['reference_kind']}; method {res.method}, model {res.model}; "
              f"ts {cpu:.1f} CPU s", flush=True)
    if not rows:
        print("no recording available: run scripts/truth/fetch.py (network to GitHub) first", file=sys.stderr)
        return 1
    columns = list(dict.fromkeys(c for r in rows for c in r["columns"]))
    head = f"{'driver':<26} {'param':<5} {'reference':>10}"
    for c in columns:
        head += f" | {c + ' value':>16} {'ci90':>19} {'err %':>7} {'in':>3}"
    print(head)
    for r in rows:
        line = f"{r['driver']:<26} {r['parameter']:<5} {_fmt(r['reference']):>10}"
        for c in columns:
            x = r["columns"].get(c)
            if x is None:
                line += f" | {'-':>16} {'-':>19} {'-':>7} {'-':>3}"
                continue
            ci = "-" if x["ci90"] is None else f"{_fmt(x['ci90'][0])}..{_fmt(x['ci90'][1])}"
            inside = "-" if "covered" not in x else ("yes" if x["covered"] else "no")
            line += f" | {_fmt(x['value']):>16} {ci:>19} {x['error_pct']:>+7.1f} {inside:>3}"
        print(line)
    summary = {c: summarise(rows, c) for c in columns}
    for c, s in summary.items():
        if s["pairs"]:
            print(f"{c}: coverage {s['covered']}/{s['pairs']} = {100 * s['coverage']:.0f} % of "
                  "(driver, parameter) "
                  f"pairs; median 90 % half-width {s['median_half_width_pct']:.2f} %; median |error| "
                  f"{s['median_abs_error_pct']:.2f} %; agreement with a reference as uncertain as the "
                  f"interval (En, ISO 13528) {s['agreeing']}/{s['pairs']} = {100 * s['agreement']:.0f} %")
    for n in notes:
        print("note:", n)
    load = os.getloadavg()
    rec = {"label": a.label, "bayes_emt_version": getattr(bayes_emt, "__version__", "unknown"),
           "bayes_emt_path": str(Path(bayes_emt.__file__).resolve().parent),
           "bayes_emt_commit": a.code or _commit(),
           "seed": a.seed, "drivers": drivers, "rows": rows, "summary": summary, "notes": notes,
           "load_average": list(load), "command": " ".join([Path(sys.executable).name, *sys.argv])}
    a.out.mkdir(parents=True, exist_ok=True)
    from bayes_emt._atomic import atomic_write_text

    jpath = a.out / f"truth_{a.label}.json"
    atomic_write_text(jpath, json.dumps(rec, indent=1, allow_nan=False) + "\n")
    ppath = draw(rec, a.out / f"truth_{a.label}.png")
    print(f"wrote {jpath} and {ppath}")
    return 0


def draw(rec: dict, path: Path) -> Path:
    """The picture of a run's JSON record: intervals as bars against the references."""
    from bayes_emt.plotting import save_figure

    plot_reference_intervals = _repo_module("bayes_emt/plotting/truth.py",
                                            "bayes_emt.plotting.truth").plot_reference_intervals
    cov = "; ".join(f"{c} {100 * s['coverage']:.0f} %, median half-width {s['median_half_width_pct']:.1f} %"
                    for c, s in rec["summary"].items() if s["pairs"])
    fig = plot_reference_intervals(rec["rows"], title=f"ts 90 % intervals against independent references "
                                   f"({rec['label']}, bayes_emt {rec['bayes_emt_commit']}): {cov}")
    return save_figure(fig, path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
