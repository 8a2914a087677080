"""Run every benchmark on this tree and on a baseline revision, side by side, and print the ratios;
then the figures of merit, written to ``benchmarks/results.json`` and ``benchmarks/RESULTS.md``.

Each ``bench_*.py`` module may define ``BENCHMARKS``: a dict ``name -> callable`` (no arguments;
one call is one timed unit of work), optionally ``setup()`` run once before timing and ``TARGETS``
``{name: seconds}``; and ``measure()``, run on this tree only, returning the module's figures of
merit: ``{"results": {key: value or {label: value}}, "targets": {"key" or "key.label":
[">=" or "<=", number]}, "details": {...}}``. The results of every module are merged into
``results.json`` (keys of modules not run this time are kept, so a new ``bench_*.py`` adds its keys
without touching the others) and ``RESULTS.md`` is regenerated from it.

The same benchmark files (this tree's) are loaded by two worker processes: one imports
``bayes_emt`` from this working tree, the other from the baseline revision extracted with
``git archive``. The driver interleaves their calls (A B, B A, A B, ...) so that the drift of
a shared machine falls on both sides alike; the ratios compare code with code, here and now, never
with times stored from another machine, day or build of numpy and scipy. Time is the best (minimum)
of at least ``--repeat`` calls after one warm-up call, more for quick benchmarks until each side
has spent ``--min-time`` seconds (a shared machine's noise only ever adds time, so the minimum is
the steadiest estimate of the code's cost, as :mod:`timeit` argues); memory is the peak of
Python-side allocations in one further call (``tracemalloc``, which sees numpy's buffers).

    .venv/bin/python benchmarks/run.py                  # this tree vs the pinned baseline revision
    .venv/bin/python benchmarks/run.py --baseline HEAD  # the effect of uncommitted changes
    .venv/bin/python benchmarks/run.py -k shunt         # only benchmarks whose name contains 'shunt'
    .venv/bin/python benchmarks/run.py --save-baseline  # pin HEAD as the baseline from now on
    .venv/bin/python benchmarks/run.py --no-compare -k bessel   # only the Bessel figures of merit

The pinned revision lives in ``benchmarks/baseline.json``. Targets (acceptance numbers such as
"< 10 s for all six fits") are checked on this tree's times here, never in timed unit tests; a
missed target, or a benchmark that fails on this tree, makes the exit code 1.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
import tracemalloc
from pathlib import Path

import report

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BASELINE = HERE / "baseline.json"


# ---- worker: one process, one source tree, commands on stdin, one JSON line per answer ------------
def worker(src: Path, k: str) -> None:
    """Load this folder's benchmarks with ``bayes_emt`` imported from ``src``; then answer
    ``time NAME`` (seconds of one call), ``memory NAME`` (peak MiB of one call), ``measure STEM``
    (that module's figures of merit) and ``quit``."""
    sys.path.insert(0, str(src))
    import bayes_emt

    where = Path(bayes_emt.__file__).resolve()
    if src.resolve() not in where.parents:
        raise RuntimeError(f"imported bayes_emt from {where}, not from {src}")
    fns, targets, errors, measures = {}, {}, {}, {}
    for stem in sorted(p.stem for p in HERE.glob("bench_*.py")):
        try:
            spec = importlib.util.spec_from_file_location(stem, HERE / f"{stem}.py")
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            if hasattr(mod, "setup"):
                mod.setup()
        except Exception as exc:  # the baseline may predate what a benchmark uses
            errors[stem] = f"{type(exc).__name__}: {exc}"
            continue
        if hasattr(mod, "measure") and k in stem:
            measures[stem] = mod.measure
        for name, fn in getattr(mod, "BENCHMARKS", {}).items():
            if k in f"{stem}.{name}":
                fns[f"{stem}.{name}"] = fn
                if name in getattr(mod, "TARGETS", {}):
                    targets[f"{stem}.{name}"] = mod.TARGETS[name]

    protocol = sys.stdout
    sys.stdout = sys.stderr  # whatever the benchmarks print must not mix with the answers

    def answer(obj) -> None:
        protocol.write(json.dumps(obj) + "\n")
        protocol.flush()

    answer({"names": sorted(fns), "targets": targets, "errors": errors, "measures": sorted(measures)})
    for line in sys.stdin:
        cmd, _, name = line.strip().partition(" ")
        if cmd == "quit":
            return
        try:
            if cmd == "time":
                t0 = time.perf_counter()
                fns[name]()
                answer({"value": time.perf_counter() - t0})
            elif cmd == "measure":
                answer({"value": measures[name]()})
            elif cmd == "memory":
                tracemalloc.start()
                try:
                    fns[name]()
                    answer({"value": tracemalloc.get_traced_memory()[1] / 2**20})
                finally:
                    tracemalloc.stop()
            else:
                answer({"error": f"unknown command {cmd!r}"})
        except Exception as exc:
            answer({"error": f"{type(exc).__name__}: {exc}"})


class _Worker:
    """The driver's handle on one worker process."""

    def __init__(self, src: Path, k: str, label: str):
        env = {**os.environ, "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1"), "MPLBACKEND": "Agg"}
        self.label = label
        self.err = tempfile.TemporaryFile(mode="w+")  # a pipe nobody reads could fill and block
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--worker", str(src),
                                      "-k", k], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.err, text=True, env=env, cwd=src, bufsize=1)
        self.info = self._read()

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            self.err.seek(0)
            raise SystemExit(f"bench: the {self.label} worker died:\n{self.err.read().strip()[-5000:]}")
        return json.loads(line)

    def ask(self, cmd: str, name: str) -> tuple[float | None, str | None]:
        self.proc.stdin.write(f"{cmd} {name}\n")
        self.proc.stdin.flush()
        rec = self._read()
        return rec.get("value"), rec.get("error")

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.write("quit\n")
            self.proc.stdin.close()
            self.proc.wait(timeout=60)


def _more(i: int, recs: list[dict], repeat: int, min_time: float, max_calls: int) -> bool:
    """Whether to make call ``i`` (0 is the warm-up) on each side that has not failed."""
    if i <= repeat:
        return True
    return i < max_calls and any(sum(r["runs"]) < min_time for r in recs if not r["error"])


def compare(now: _Worker, base: _Worker, repeat: int, min_time: float, max_calls: int = 200) -> dict:
    """Interleaved timings ``{name: {"now"/"base": {"seconds", "peak_mib", "error"}}}``."""
    out = {}
    for name in now.info["names"]:
        sides = {"now": now, "base": base if name in base.info["names"] else None}
        rec = {s: {"runs": [], "peak_mib": None, "error": None} for s in sides}
        if sides["base"] is None:
            rec["base"]["error"] = "not in the baseline (" + ("; ".join(base.info["errors"].values())
                                                               or "no such benchmark") + ")"
        order = [s for s in ("now", "base") if sides[s] is not None]
        i = 0
        while _more(i, [rec[s] for s in order], repeat, min_time, max_calls):
            for s in (order if i % 2 == 0 else order[::-1]):
                if rec[s]["error"]:
                    continue
                value, err = sides[s].ask("time", name)
                if err:
                    rec[s]["error"] = err
                elif i > 0:
                    rec[s]["runs"].append(value)
            i += 1
        for s in order:
            if not rec[s]["error"]:
                rec[s]["peak_mib"], rec[s]["error"] = sides[s].ask("memory", name)
        out[name] = {s: {"seconds": min(r["runs"]) if r["runs"] and not r["error"] else None,
                         "median_seconds": statistics.median(r["runs"]) if r["runs"] else None,
                         "calls": len(r["runs"]), "peak_mib": r["peak_mib"], "error": r["error"]}
                     for s, r in rec.items()}
    return out


# ---- driver ------------------------------------------------------------------------------------
def _git(*args: str) -> str:
    proc = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"bench: git {' '.join(args)}: {proc.stderr.strip() or 'failed'}")
    return proc.stdout.strip()


def _extract(rev: str, dest: Path) -> str:
    """Extract ``rev``'s tree into ``dest/src`` (no checkout, no worktree bookkeeping); its SHA."""
    sha = _git("rev-parse", "--verify", f"{rev}^{{commit}}")
    tar = dest / "tree.tar"
    with tar.open("wb") as fh:
        proc = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", sha], stdout=fh,
                              stderr=subprocess.PIPE)
    if proc.returncode != 0:
        raise SystemExit(f"bench: git archive {sha}: {proc.stderr.decode(errors='replace').strip()}")
    with tarfile.open(tar) as tf:
        tf.extractall(dest / "src", filter="data")
    tar.unlink()
    return sha


def _fmt(x: float | None, spec: str) -> str:
    return "n/a" if x is None else format(x, spec)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", default=None, help="git revision to compare with "
                    "(default: the one pinned in benchmarks/baseline.json)")
    ap.add_argument("--repeat", type=int, default=3, help="least timed calls per benchmark and side")
    ap.add_argument("--min-time", type=float, default=1.0,
                    help="go on calling a quick benchmark until each side has spent this many seconds")
    ap.add_argument("-k", default="", help="substring filter on benchmark names")
    ap.add_argument("--save-baseline", action="store_true", help="pin HEAD as the baseline revision")
    ap.add_argument("--json", type=Path, help="also write the numbers to this JSON file")
    ap.add_argument("--no-compare", action="store_true", help="skip the side-by-side timings")
    ap.add_argument("--no-measure", action="store_true", help="skip the figures of merit")
    ap.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.worker, args.k)
        return 0

    if args.save_baseline:
        sha = _git("rev-parse", "HEAD")
        BASELINE.write_text(json.dumps({"revision": sha, "note": "benchmarks/run.py compares this tree "
                                        "with this revision, both run here and now"}, indent=2) + "\n")
        print(f"baseline pinned to {sha[:12]} in {BASELINE}")
        return 0
    missed, failed = [], {}
    if not args.no_compare:
        m, f = _compare_with_baseline(args)
        missed += m
        failed.update(f)
    if not args.no_measure:
        m, f = _measure(args)
        missed += m
        failed.update(f)
    if failed:
        print("failed on this tree: " + "; ".join(f"{k}: {v}" for k, v in failed.items()))
    if missed:
        print("targets missed: " + ", ".join(missed))
    return 1 if missed or failed else 0


def _compare_with_baseline(args) -> tuple[list, dict]:
    pinned = json.loads(BASELINE.read_text()).get("revision") if BASELINE.exists() else None
    rev = args.baseline or pinned
    if not rev:
        raise SystemExit("bench: no baseline revision: pass --baseline REV or pin one with --save-baseline")

    with tempfile.TemporaryDirectory(prefix="bayes_emt_bench_") as tmp:
        sha = _extract(rev, Path(tmp))
        dirty = " + uncommitted changes" if _git("status", "--porcelain", "--untracked-files=no") else ""
        print(f"this tree: {ROOT} ({_git('rev-parse', '--short=12', 'HEAD')}{dirty})")
        print(f"baseline:  {rev} = {sha[:12]} (extracted to a temporary folder)")
        print(f"machine:   {os.cpu_count()} cpus, Python {sys.version.split()[0]}, "
              f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', '1')}; calls interleaved, best of "
              f">= {args.repeat} calls (>= {args.min_time:g} s) per side\n")
        now = _Worker(ROOT, args.k, "this tree's")
        base = _Worker(Path(tmp) / "src", args.k, "baseline's")
        try:
            res = compare(now, base, args.repeat, args.min_time)
        finally:
            now.close()
            base.close()

    print(f"{'benchmark':<44}{'baseline [s]':>13}{'now [s]':>10}{'ratio':>7}{'calls':>6}{'peak [MiB]':>12}"
          f"{'ratio':>7}{'target [s]':>12}")
    missed, failed = [], dict(now.info["errors"])
    for name, r in res.items():
        t, tb = r["now"]["seconds"], r["base"]["seconds"]
        m, mb = r["now"]["peak_mib"], r["base"]["peak_mib"]
        target = now.info["targets"].get(name)
        tgt = ""
        if target is not None:
            ok = t is not None and t < target
            tgt = f"{target:>11.3g}{'✓' if ok else '✗'}"
            if not ok:
                missed.append(name)
        if r["now"]["error"]:
            failed[name] = r["now"]["error"]
        print(f"{name:<44}{_fmt(tb, '13.4f'):>13}{_fmt(t, '10.4f'):>10}"
              f"{_fmt(t / tb if t and tb else None, '7.2f'):>7}{r['now']['calls']:>6}{_fmt(m, '12.1f'):>12}"
              f"{_fmt(m / mb if m and mb else None, '7.2f'):>7}{tgt:>12}")
        if r["base"]["error"]:
            print(f"  baseline: {r['base']['error']}")
    if args.json:
        args.json.write_text(json.dumps({"baseline": sha, "results": res, "targets": now.info["targets"]},
                                        indent=2) + "\n")
    report.record_comparison(sha, res)
    return missed, failed


def _measure(args) -> tuple[list, dict]:
    """Every module's ``measure()`` on this tree, one worker; merged into results.json/RESULTS.md."""
    now = _Worker(ROOT, args.k, "this tree's")
    out, failed = {}, dict(now.info["errors"])
    try:
        for stem in now.info["measures"]:
            print(f"\nmeasuring {stem} ...", flush=True)
            t0 = time.perf_counter()
            value, err = now.ask("measure", stem)
            if err:
                failed[stem] = err
                continue
            value["seconds"] = time.perf_counter() - t0
            out[stem] = value
    finally:
        now.close()
    merged = report.merge(out, revision=_git("rev-parse", "--short=12", "HEAD"),
                           dirty=bool(_git("status", "--porcelain", "--untracked-files=no")))
    print()
    print(report.table(merged, only=set(out)))
    return report.missed(merged, only=set(out)), failed


if __name__ == "__main__":
    sys.exit(main())
