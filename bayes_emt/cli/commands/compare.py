"""``bayes-emt compare DATA``: model comparison by evidence.

For every model spec in ``--models`` (resolved by ``bayes_emt.api.as_model``; NL and UL get one
model per ring count of ``--rings``) the log evidence log Z [nats] comes from two independent
estimators, nested sampling from the prior (dynesty) and bridge sampling on the emcee posterior,
with Laplace at the optimum as a screen; then Bayes factors between all candidates on Kass &
Raftery's scale (|ln B| < 1 inconclusive), PSIS-LOO beside them, how each log Z moves when every
prior width is doubled, and, with several ring counts, the NL ring count by evidence beside the
Hankel-singular-value choice. Results go to ``--json`` after every model, so a re-run with the
same ``--json`` skips finished models and resumes an interrupted one from its checkpoints
(posteriors, nested runs and checkpoints in ``--work``, default ``OUT stem + _runs``).
Exit status 0, or 1 when a result is flagged (see the warnings), 2 on a user error.
"""

from __future__ import annotations

from pathlib import Path

from ._common import add_data_args, add_output_args, add_parser, detail, note

EXAMPLES = """\
bayes-emt compare speaker.zma --models I,UD,NL --json evidence.json --plot figures/
bayes-emt compare bench.csv --models NL --rings 1-7 --json rings.json
bayes-emt compare speaker.zma --models UD,UD+winding_capacitance --methods laplace,bridge --max-steps 5000
(re-run with the same --json to resume: finished models are reused)
"""


def register(sub) -> None:
    p = add_parser(sub, "compare", help="model comparison by evidence (nested + bridge sampling)",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("data", help="measurement file")
    add_data_args(p)
    p.add_argument("--models", default="I,II,III,UD,UL,NL",
                   help="comma-separated model specs (default I,II,III,UD,UL,NL)")
    p.add_argument("--rings", default=None,
                   help="ring counts for NL/UL, e.g. 1-7 or 2,3,5 (default: the model's own, 5)")
    p.add_argument("--json", default=None, metavar="OUT", help="results JSON (written after every model; "
                   "re-run with the same OUT to resume)")
    p.add_argument("--work", default=None, metavar="DIR",
                   help="folder for posteriors, nested runs and checkpoints (default: OUT stem + _runs)")
    p.add_argument("--plot", default=None, metavar="DIR", help="write the log Z bar chart here")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--methods", default="laplace,bridge,nested",
                   help="evidence estimators to run (default laplace,bridge,nested)")
    p.add_argument("--nlive", type=int, default=None, help="nested sampling live points (default 100)")
    p.add_argument("--walks", type=int, default=None, help="random-walk steps per new point (default 100)")
    p.add_argument("--sample", choices=("rwalk", "slice"), default=None,
                   help="nested sampling's move: rwalk (default, random walk) or slice (slice sampling: "
                        "right on skewed posteriors where rwalk is low, at 2-3x the time)")
    p.add_argument("--nested-prior", choices=("posterior", "prior"), default="posterior",
                   help="where nested sampling starts: posterior (default; its prior repartitioned onto "
                        "a heavy-tailed fit of the emcee draws, same log Z, H of a few nats) or prior "
                        "(the model's own prior: independent of the chain, can find a mode it missed, "
                        "but misses the posterior of the NL models by hundreds of nats)")
    p.add_argument("--nested-repeats", type=int, default=1, help="nested runs per model (default 1)")
    p.add_argument("--max-steps", type=int, default=None, help="emcee step budget (default 20000)")
    add_output_args(p, progress=True)
    p.set_defaults(func=run)


def _models(text: str) -> list[str]:
    from ...api import as_model

    names = [m.strip() for m in text.split(",") if m.strip()]
    if not names:
        raise ValueError("--models: no model given")
    for name in names:
        try:
            as_model(name)
        except (ValueError, KeyError) as exc:
            raise ValueError(f"--models: {name}: {exc.args[0] if exc.args else exc}") from None
    return names


def run(args) -> int:
    from ...api import compare
    from ...evidence.nested import NestedSettings
    from ...evidence.rings import parse_rings
    from ...io import read_measurement

    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    if args.walks is not None and args.sample == "slice":
        raise ValueError("--walks: random-walk steps do not apply to --sample slice")
    knobs = (("n_live", args.nlive), ("walks", args.walks), ("sample", args.sample))
    nested = NestedSettings(**{k: v for k, v in knobs if v is not None})
    names = _models(args.models)
    rings = None if args.rings is None else parse_rings(args.rings)
    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity,
                            magnitude_only=args.magnitude_only).select(args.omega_min, args.omega_max)
    if args.json and Path(args.json).resolve() == Path(args.data).resolve():
        raise ValueError(f"{args.json}: the results file must not be the data file")
    note(args, f"comparing {', '.join(names)} on {meas.source} ({meas.n_points} points, "
         f"{meas.omega[0]:.4g}..{meas.omega[-1]:.4g} rad/s), seed {args.seed}, methods {', '.join(methods)}")

    def show(m, reused):
        by = ", ".join(f"{k} {v['log_evidence']:.2f}"
                       + (f" +- {v['err']:.2f}" if v.get("err") is not None else "")
                       for k, v in m.by_method.items() if v.get("log_evidence") is not None)
        print(f"  {m.name}: log Z = {m.log_evidence:.2f} +- {m.log_evidence_err:.2f} nats ({by}; "
              f"{'reused' if reused else f'{m.seconds_total:.0f} s'})", flush=True)
        detail(args, f"    {m.n_params} parameters; likelihood calls "
                     + ", ".join(f"{k} {v}" for k, v in m.calls.items())
                     + "; seconds " + ", ".join(f"{k} {v:.1f}" for k, v in m.seconds.items()))
        for w in m.warnings:
            detail(args, f"    warning: {w}")

    cmp = compare(meas, names, seed=args.seed, methods=methods, rings=rings, max_steps=args.max_steps,
                  nested=nested, nested_prior=args.nested_prior, nested_repeats=args.nested_repeats,
                  results=args.json, workdir=args.work, progress=not args.quiet, on_model=show)
    print(cmp.summary(), end="")
    if args.json:
        cmp.save(args.json)
        note(args, f"wrote {args.json}")
    if args.plot:
        from ...plotting import save_figure
        from ...plotting.evidence import plot_evidence

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        path = save_figure(plot_evidence(cmp), folder / "evidence.png")
        note(args, f"wrote {path}")
    from ..exitcodes import status

    # 1: a model's evidence is not to be trusted (its chain missed the stopping rule, or every
    # estimator failed);
    # warnings alone leave a delivered result (0)
    def untrusted(m) -> bool:
        estimates = [v.get("log_evidence") for v in m.by_method.values()]
        return not m.converged or not any(isinstance(x, int | float) and x == x for x in estimates)

    return status(any(untrusted(m) for m in cmp.models))
