"""``bayes-emt batch DIR|GLOB``: many recordings in parallel on Dask distributed.

Each recording gets its own result folder under ``--out`` (``fit.json``; with ``sample`` the
posterior DataTree ``posterior.nc``, ``posterior.json`` and its checkpoint; a completion marker
``done.json`` written last), and ``summary.csv`` / ``summary.html`` / ``summary.json`` list every
recording with its headline numbers (the fit's, the free-air T/S set fs, Re, Qms, Qes, Qts, the
sampler's) or its one-line error. Re-running the same command skips finished recordings
and continues the rest (sampler chains resume from their checkpoints), so a killed batch loses
at most the files in progress. A broken file is reported and the others complete.
Exit status 0 when every recording finished, 1 when some failed, 2 on a usage error.
"""

from __future__ import annotations

import argparse
import sys

from ..exitcodes import EPILOG as EXIT_EPILOG
from ._common import add_data_args, add_model_args

EPILOG = """\
examples:
  bayes-emt batch recordings/ --model UD --jobs fit
  bayes-emt batch 'lab/**/*.zma' --jobs fit,sample --max-steps 5000 --out runs/2026-11
  bayes-emt batch recordings/ --scheduler tcp://10.0.0.5:8786 --jobs fit,sample
  (re-run the same command after an interruption: finished recordings are skipped)
"""


def register(sub) -> None:
    p = sub.add_parser("batch", help="many recordings in parallel on Dask (resumable, summary table)",
                       description=__doc__, epilog=EPILOG + "\n\n" + EXIT_EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source", metavar="DIR|GLOB",
                   help="a folder (its .zma/.csv/.tsv/.txt/.dat/.s1p files) or a quoted glob pattern")
    add_model_args(p, required=False)
    add_data_args(p)
    p.add_argument("--jobs", default="fit", metavar="JOBS",
                   help="comma-separated jobs per recording: fit, sample, diagnose (default fit; "
                        "sample and diagnose start from the fit)")
    p.add_argument("--scheduler", default="local", metavar="local|ADDRESS",
                   help="'local' starts a local Dask cluster (default); else a scheduler address, "
                        "e.g. tcp://host:8786 (workers need bayes_emt and the same file paths)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local cluster (default: cores, at most 4)")
    p.add_argument("--out", default="bayes_emt_batch", help="output folder (default ./bayes_emt_batch)")
    p.add_argument("--seed", type=int, default=0, help="sampler seed for every recording (default 0)")
    p.add_argument("--max-steps", type=int, default=20000, help="sampler step budget per recording "
                                                                "(default 20000)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quiet", action="store_true", help="no progress bar; print only errors and the totals")
    g.add_argument("--verbose", action="store_true", help="one line per recording as it finishes, "
                                                          "with its warnings")
    p.set_defaults(func=run, model="UD")


def _line(o) -> str:
    if o.status == "error":
        return o.error if o.file in o.error else f"{o.file}: {o.error}"
    s = o.summary
    text = f"{o.file}: {o.status}"
    if "rms_rel_residual" in s:
        text += f", rms rel. residual {s['rms_rel_residual']:.3g}"
    if "f0_hz" in s:
        text += f", f0 {s['f0_hz']:.4g} Hz"
    if "Qts" in s:
        text += f", fs {s['fs_hz']:.4g} Hz, Re {s['Re_ohm']:.4g} ohm, Qts {s['Qts']:.3g}"
    if "converged" in s:
        text += ", sampler " + ("converged" if s["converged"] else "NOT converged")
    return text + (f" ({o.seconds:.1f} s)" if o.seconds else "")


def run(args) -> int:
    from ...batch import BatchSettings, run_batch

    jobs = tuple(j.strip() for j in args.jobs.split(",") if j.strip())
    read = tuple((k, v) for k, v in (("freq_unit", args.freq_unit), ("phase_unit", args.phase_unit),
                                     ("quantity", args.quantity),
                                     ("magnitude_only", args.magnitude_only or None)) if v is not None)
    settings = BatchSettings(jobs=jobs, model=args.model, rings=args.rings, n_turns=args.n_turns,
                             seed=args.seed, max_steps=args.max_steps, read_options=read,
                             omega_min=args.omega_min, omega_max=args.omega_max)
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be at least 1, got {args.workers}")

    def show(o) -> None:
        if o.status == "error":
            print(f"bayes-emt: error: {_line(o)}", file=sys.stderr)
        elif args.verbose:
            print(_line(o))
            for w in o.warnings:
                print(f"    warning: {w}")

    result = run_batch(args.source, args.out, settings, scheduler=args.scheduler, workers=args.workers,
                       progress=False if (args.quiet or args.verbose) else None, on_outcome=show)
    skipped = sum(o.status == "skipped" for o in result.outcomes)
    c = result.counts
    print(f"{len(result.outcomes)} recordings: {c['done']} done ({skipped} finished earlier, skipped), "
          f"{c['error']} failed, {c['pending']} not finished")
    if not args.quiet:
        print(f"wrote {result.out / 'summary.csv'}, {result.out / 'summary.html'} and "
              f"{result.out / 'summary.json'}")
    return 0 if c["error"] == 0 and c["pending"] == 0 else 1
