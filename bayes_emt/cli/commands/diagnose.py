"""``bayes-emt diagnose DATA [--model MODEL] [--json OUT] [--plot DIR]``: discrepancy discovery.

Locates bands where the model and the recording differ beyond the noise (a scan whose family-wise
false-alarm rate is calibrated by simulation from the fitted model), names the catalogue physics
that explains each, adds it, and repeats until no significant mismatch remains. Without ``--model``
it starts from the base model the evidence prefers (I, II, III, UD by Laplace log Z); a broken start
is replaced by the nearest healthy one. With --all-starts the search also runs from UD, III and
NL(5) and keeps the final model one evidence on the same data prefers among all the starts reach, so
the answer does not depend on the start (about three times the CPU time). A final
model that is broken physics (a parameter at its prior's edge, the driver's resonance merged with
another mode, Thiele-Small values outside physical ranges) is refused: the search backs off to the
best model it reached without the defect and says so in one line.
Prints at most 20 lines in the driver's terms: the start and final model, the final Thiele-Small
values, each finding with its band in Hz and its effect on the Thiele-Small values, box terms
(fb in Hz) and the coil's inductance and loss, the unexplained bands, the warnings that change a
decision. ``--verbose`` prints the statistics behind them (log evidence in nats, the band's chi2
before and after, every candidate tried) and the search's progress; ``--json`` writes the whole
record (``final_model`` is a spec that fit, sample, added-mass and shunt accept), ``--plot`` the
residuals before/after with the bands shaded and a Bode overlay.
Exit status 0 with or without findings and warnings; 1 when the time budget cut the search short or
the final fit failed; 2 on a user error.
"""

from __future__ import annotations

from pathlib import Path

from ._common import (
    add_data_args,
    add_exclude_band_arg,
    add_model_args,
    add_output_args,
    add_parser,
    add_re_option,
    int_at_least,
    nonnegative_float,
    seed,
)

#: the figures of --plot DIR (named apart from the report's own residuals.png: nothing is overwritten)
PLOT_NAMES = ("diagnosis_residuals.png", "diagnosis_bode.png")

EXAMPLES = """\
bayes-emt diagnose speaker.zma  (start from the model the evidence prefers)
bayes-emt diagnose speaker.zma --model UD --json diagnosis.json --plot figures/
bayes-emt diagnose bench.csv --model NL --rings 5 --max-rounds 2 --quiet
bayes-emt diagnose woofer.zma --setup free-air --exclude-band 5200:5600
bayes-emt diagnose speaker.zma --model UD --time-budget 0  (no time budget: the same result on any machine)
bayes-emt diagnose freeair.txt --also added100g.txt:0.100  (check the findings on an added-mass run)
"""


def also_arg(text: str) -> tuple[str, float | None]:
    """``FILE[:DELTA_M]`` of ``--also``: the file and the mass added for it [kg; a unit may be given,
    ``:100g``] (``None``: the same driver, another drive level or session)."""
    from ...units import UnitError, parse_quantity

    head, sep, tail = text.rpartition(":")
    if sep and head:
        try:
            dm = parse_quantity(tail, "mass")  # kg, or with a unit: added100g.txt:100g
        except UnitError:
            return text, None
        if not (dm == dm and abs(dm) != float("inf") and dm != 0):
            raise ValueError(f"--also {text}: the added mass after ':' must be a non-zero number of kg")
        return head, dm
    return text, None


def register(sub) -> None:
    p = add_parser(sub, "diagnose", help="locate a model-data mismatch, name the missing physics, model it",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("data", help="measurement file (.zma, CSV/TSV with header, .s1p)")
    add_model_args(p, required=False)
    add_data_args(p)
    add_exclude_band_arg(p)
    p.add_argument("--setup", choices=["free-air", "sealed", "vented", "shaker", "unknown"],
                   default="unknown",
                   help="how the transducer was mounted (default unknown): free-air, sealed and shaker rule "
                        "out a port; unknown tries a port only when |Z| has two maxima with a minimum "
                        "between them (each maximum >= 10 %% above it, within a factor 10 in frequency)")
    p.add_argument("--also", action="append", default=[], metavar="FILE[:MASS]",
                   help="a second recording of the same transducer (with the mass added for it: kg, or "
                        "with a unit, FILE:100g): every "
                        "finding is judged by one log evidence of both recordings together (the finding "
                        "shared, in neither, in this one only; each recording its own resonance, "
                        "damping and coupling); one the pair does not share (joint delta log Z < 5 "
                        "nats) or the other uses with other values is flagged; with a mass the joint "
                        "added-mass fit is printed beside (a diagnostic); the recording is diagnosed "
                        "too, and a term "
                        "only it names is fitted on DATA and flagged when DATA does not need it "
                        "(repeatable)")
    p.add_argument("--no-search-also", action="store_true",
                   help="do not diagnose the --also recordings (only check this diagnosis's findings "
                        "on them)")
    p.add_argument("--all-starts", action="store_true",
                   help="search from UD, III and NL(5) too and keep the final model the evidence prefers "
                        "among all they reach: the answer no longer depends on the start, at about three "
                        "times the CPU time (by default the search runs from the starting model alone)")
    p.add_argument("--json", default=None, metavar="OUT", help="write the diagnosis as JSON here")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help=f"write the residual and Bode figures here ({', '.join(PLOT_NAMES)})")
    p.add_argument("--seed", type=seed, default=0,
                   help="seed of the scan's calibration replicates (default 0)")
    p.add_argument("--max-rounds", type=int_at_least(1), default=4,
                   help="at most this many findings (default 4)")
    p.add_argument("--time-budget", type=nonnegative_float, default=240.0, metavar="SECONDS",
                   help="wall-clock seconds from the command's start after which the search stops: the "
                        "candidates still running are abandoned and a warning names what was cut "
                        "(default 240; the command ends within about 10 %% of it, on a busy machine "
                        "too); 0: no budget, so the result does not depend on the machine's speed or load")
    p.add_argument("--workers", type=int_at_least(0), default=None, metavar="N",
                   help="processes fitting a band's candidates in parallel (default 2, at most one per core; "
                        "1: none; 0: one per core); the findings do not depend on it")
    p.add_argument("--per-decade", type=nonnegative_float, default=None, metavar="N",
                   help="search on at most N points per decade of frequency (default 300, about 1/90 "
                        "octave: a dense sweep is thinned, every point of a sparser one is kept); 0: every "
                        "point")
    add_re_option(p)
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...discovery import diagnose
    from ...io import read_measurement
    from ..paths import check_outputs
    from ._common import model_from_args

    also = [also_arg(a) for a in args.also]
    from ...thiele_small.plausibility import MAX_MASS_KG

    for f, dm in also:  # a mass meant in grams, given bare (kg)
        if dm is not None and abs(dm) > MAX_MASS_KG:
            raise ValueError(f"--also {f}:{dm:g}: {dm:g} kg is heavier than any cone; did you mean "
                             f"{f}:{dm:g}g?")
    check_outputs([("--json", args.json)], [("DATA", args.data)] + [("--also", f) for f, _ in also],
                  folders=[("--plot", args.plot, PLOT_NAMES)])
    meas = read_measurement(
        args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit, quantity=args.quantity,
        magnitude_only=args.magnitude_only
    ).select(args.omega_min, args.omega_max)
    # the second recordings are read before the diagnosis: a bad file fails at once
    others = [(read_measurement(f, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                                quantity=args.quantity, magnitude_only=args.magnitude_only
                                ).select(args.omega_min, args.omega_max), dm)
              for f, dm in also]
    model = model_from_args(args) if args.model else None
    if args.re is not None:  # a Normal prior on R0: the evidences of the candidates see the reading
        if model is None:
            raise ValueError("--re needs --model (the reading becomes a prior on that model's R0)")
        from ...params import Normal

        model = model.with_priors({"R0": Normal(*args.re)}, where="--re")
    from ...discovery.diagnose import START_FAMILIES
    from ...models import parse_model_spec

    starts = () if not args.all_starts else tuple(
        parse_model_spec(s) if args.re is None else  # every start sees the reading, so the evidences compare
        parse_model_spec(s).with_priors({"R0": Normal(*args.re)}, where="--re") for s in START_FAMILIES)
    # the diagnosis's settings, which a second recording's own diagnosis (--also) shares
    settings = dict(
        seed=args.seed,
        max_rounds=args.max_rounds,
        time_budget=args.time_budget or None,
        budget_start=getattr(args, "started_at", None),
        setup=args.setup,
        exclude_band=args.exclude_band,
        workers=args.workers,
        progress=(lambda msg: print("  " + msg, flush=True)) if args.verbose else None,
        **({} if args.per_decade is None else {"per_decade": args.per_decade or None}),
    )
    d = diagnose(meas, model, starts=starts, **settings)
    if also:
        from ...discovery.joint import with_second_recordings

        # each --also recording's own search has a budget of its own, counted from its start
        search = None if args.no_search_also else {k: v for k, v in settings.items() if k != "budget_start"}
        d = with_second_recordings(d, meas.exclude_bands(args.exclude_band), others, search=search)
    thinned = f"; {d.search_note}" if d.search_note else ""
    print(
        f"{meas.source}: {meas.n_points} points{thinned}, {meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz; "
        f"{d.seconds:.0f} s"
    )
    if not args.verbose:
        from ...discovery.summary import MAX_LINES, summary_lines

        for line in summary_lines(d, args.setup, max_lines=MAX_LINES - 1,
                                  f_range=(float(meas.f_hz[0]), float(meas.f_hz[-1]))):
            print(line)
    else:
        _print_details(d)
    if args.json:
        d.save(args.json)
        print(f"wrote {args.json}")
    if args.plot:
        from ...plotting import save_figure
        from ...plotting.discovery import plot_bode_overlay, plot_residuals

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        for name, fig in (
            (PLOT_NAMES[0], plot_residuals(d, meas)),
            (PLOT_NAMES[1], plot_bode_overlay(d, meas)),
        ):
            print(f"wrote {save_figure(fig, folder / name)}")
    # exit 1 only when the result is not to be trusted (a budget cut, a final fit that failed, a final
    # model that is broken physics with nothing sound to back off to); findings and warnings alone, and a
    # refused final model the search backed off from, are a delivered result (exit 0)
    from ..exitcodes import status

    rms = d.final_fit.rms_rel_residual
    broken = any(w.startswith("the final model") and "is broken physics" in w for w in d.warnings)
    return status(d.budget_hit or broken or not d.final_fit.success
                  or not (rms == rms and rms != float("inf")))


def _print_details(d) -> None:
    """The verbose output: each finding's statistics, the joint checks, every warning."""
    print(
        f"start {d.baseline_model} (rms relative residual {100 * d.baseline_fit.rms_rel_residual:.3g} %) -> "
        f"final {d.final_model} ({100 * d.final_fit.rms_rel_residual:.3g} %)"
    )
    if not d.findings and not d.unexplained:
        print("no significant mismatch")
    for i, f in enumerate(d.findings, 1):
        print(
            f"finding {i}: {f.physics} [{'device' if f.device else 'instrument/session'}] — {f.explanation}"
        )
    for u in d.unexplained:
        print("unexplained: " + u["description"])
    for j in d.joint:
        dm = "" if j["delta_m_kg"] is None else f", {j['delta_m_kg']:g} kg added"
        print(f"joint evidence with {j['source']}{dm}:")
        for t in j["terms"]:
            print(f"  {t['physics']}: {t['note']}")
        if "search" in j:
            sr = j["search"]
            print(f"  its own diagnosis: {sr['baseline_model']} -> {sr['final_model']} "
                  f"({', '.join(sr['findings']) or 'no finding'}; {sr['seconds']:.0f} s)")
            for t in sr["only_other"]:
                print(f"  {t['physics']}: {t['note']}")
        for which, a in j.get("added_mass", {}).items():
            if "error" in a:
                print(f"  joint added-mass fit, {which} {a['model']}: failed ({a['error']})")
                continue
            print(f"  joint added-mass fit, {which} {a['model']}: m {a['m_kg']:.4g} kg, "
                  f"Bl {a['Bl_N_per_A']:.4g} N/A, k {a['k_N_per_m']:.4g} N/m, R0 {a['R0_ohm']:.4g} ohm, "
                  f"consistency p {a['consistency_p_value']:.3g}")
    for w in d.warnings:
        print("warning: " + w)
