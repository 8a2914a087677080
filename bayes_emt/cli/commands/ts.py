"""``bayes-emt ts DATA [--model MODEL] [--loaded FILE --delta-m MASS]... [--box FILE --box-volume
VOLUME] [--sd AREA] [--re OHM[:SD]] [--mms MASS | --bl BL] [--exclude-band F1:F2]... [--fast]
[--json OUT] [--plot DIR]``: Thiele–Small parameters with 90 % intervals and their spread across
coil models.

Free air alone gives fs, Re, Le, Qms, Qes, Qts, EBP (and with a known Mms or Bl the rest);
added-mass recordings (one or more, each with its mass) are fitted in one joint posterior and
give Bl, Mms, Cms, Kms, Rms; a sealed test box of known volume gives Vas; with Sd also Vas, η0
and SPL at 2.83 V / 1 m. Quantities take a unit (10g, 330cm2, 20L; a bare number is SI), and
values no driver has are refused naming the option. Exit status 0, 1 when a posterior did not
meet its stopping rule, 2 on bad input. The library call is
:func:`bayes_emt.thiele_small.thiele_small`.
"""

from __future__ import annotations

import math

from ..paths import check_outputs
from ._common import (
    add_data_args,
    add_exclude_band_arg,
    add_output_args,
    add_parser,
    add_re_option,
    meter_of,
    note,
    print_warning_lines,
    quantity,
    seed,
)

#: the figure ``--plot DIR`` writes (a name no other command uses: figures never overwrite each other)
PLOT_NAME = "ts_fit.png"

EXAMPLES = """\
bayes-emt ts free_air.zma --model UD
bayes-emt ts free.txt --loaded with10g.txt --delta-m 10g --loaded with20g.txt --delta-m 20g --sd 330cm2
bayes-emt ts free.zma --box in_box.zma --box-volume 20L --sd 0.0330 --re 5.72ohm
bayes-emt ts free.zma --model UD+suspension_creep --mms 0.0149 --sd 0.033 --fast --json ts.json
bayes-emt ts free.zma --exclude-band 5.2kHz:5.6kHz --fast --plot figures/
"""


def register(sub) -> None:
    p = add_parser(sub, "ts", help="Thiele-Small parameters with credible intervals (free air, added mass, "
                   "added volume)", description=__doc__.split("\n\n", 1)[1], examples=EXAMPLES)
    p.add_argument("data", help="free-air recording")
    p.add_argument("--model", default=None, metavar="MODEL",
                   help="model spec (default: the model the evidence supports among II, III, UD, NL(2), "
                        "NL(3) and the most probable of them with a semi-inductance or suspension creep)")
    p.add_argument("--loaded", action="append", default=[], metavar="FILE",
                   help="a recording with an added mass (repeat; each needs its --delta-m, in order)")
    p.add_argument("--delta-m", action="append", type=quantity("mass", sign="nonzero"), default=[],
                   metavar="MASS", help="mass added for the matching --loaded: kg, or with a unit (8.017g)")
    p.add_argument("--box", default=None, metavar="FILE", help="a recording in a sealed test box")
    p.add_argument("--box-volume", type=quantity("volume"), default=None, metavar="VOLUME",
                   help="the test box's net volume: m^3, or with a unit (20L, 0.7ft3)")
    p.add_argument("--sd", type=quantity("area"), default=None, metavar="AREA",
                   help="effective cone area Sd: m^2, or with a unit (85cm2)")
    add_re_option(p)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--mms", type=quantity("mass"), default=None, metavar="MASS",
                   help="known moving mass: kg, or with a unit (14.9g)")
    g.add_argument("--bl", type=quantity("force_factor"), default=None, metavar="BL",
                   help="known force factor [T m]")
    p.add_argument("--air-density", type=quantity("density"), default=1.18, help="kg/m^3 (default 1.18)")
    p.add_argument("--sound-speed", type=quantity("speed"), default=343.0, help="m/s (default 343)")
    p.add_argument("--spread-models", default=None, metavar="MODELS",
                   help="comma-separated candidate models for the model spread (default II,III,UD with the "
                        "model's physics terms; 'none' for none)")
    p.add_argument("--fast", action="store_true",
                   help="intervals from the least-squares fit's covariance instead of the posterior")
    p.add_argument("--noise", choices=["correlated", "white"], default="white",
                   help="white (default): independent errors, the intervals if the model were exact (the "
                        "model mixture carries model form); correlated: instrument noise plus a model "
                        "discrepancy correlated over log-frequency (slower; on the truth corpus it did not "
                        "improve coverage, see the docs' intervals page)")
    p.add_argument("--intervals", choices=["total", "misfit", "model"], default="total",
                   help="total (default): the model's posterior plus the definitional spread between "
                        "methods (the model vs Small's model-free method; Re: the plateau reading vs the "
                        "fit), what another bench may report (as misfit when the model describes the "
                        "curve to its noise); misfit: only the part of that spread the "
                        "model's own curve does not explain; model: the model's posterior alone, the "
                        "intervals if the model were exact")
    p.add_argument("--no-plateau", action="store_true",
                   help="do not read Re off the recording's low-frequency rows below the analyser's "
                        "resolution (a bench that sweeps from about 1 Hz keeps them)")
    p.add_argument("--seed", type=seed, default=0, help="sampler seed (default 0)")
    add_data_args(p)
    add_exclude_band_arg(p)
    p.add_argument("--json", default=None, help="write the result as JSON here")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help=f"write {PLOT_NAME} here: |Z| and phase with the fitted curve, its 90 %% posterior "
                        "predictive band and the file's own fit (if it has one), and the residual")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...thiele_small import thiele_small

    if len(args.loaded) != len(args.delta_m):
        raise ValueError(f"--loaded and --delta-m must come in pairs: {len(args.loaded)} --loaded, "
                         f"{len(args.delta_m)} --delta-m")
    if (args.box is None) != (args.box_volume is None):
        raise ValueError("--box and --box-volume go together")
    inputs = [("DATA", args.data)] + [("--loaded", f) for f in args.loaded]
    if args.box:
        inputs.append(("--box", args.box))
    check_outputs([("--json", args.json)], inputs, folders=[("--plot", args.plot, (PLOT_NAME,))])
    spread = None
    if args.spread_models is not None:
        spread = [] if args.spread_models.strip().lower() == "none" else \
            [s.strip() for s in args.spread_models.split(",") if s.strip()]
    f_range = None
    if args.omega_min is not None or args.omega_max is not None:
        f_range = tuple(None if w is None else w / (2 * math.pi) for w in (args.omega_min, args.omega_max))
    meter = meter_of(args)
    r = thiele_small(args.data, args.model, loaded=list(zip(args.loaded, args.delta_m, strict=True)),
                     box=None if args.box is None else (args.box, args.box_volume), sd=args.sd, re=meter,
                     mms=args.mms, bl=args.bl, air_density=args.air_density, sound_speed=args.sound_speed,
                     fast=args.fast, seed=args.seed, models_for_spread=spread, f_range_hz=f_range,
                     exclude_band=args.exclude_band, noise=args.noise, intervals=args.intervals,
                     plateau=not args.no_plateau,
                     read_options={"freq_unit": args.freq_unit, "phase_unit": args.phase_unit,
                                   "quantity": args.quantity, "magnitude_only": args.magnitude_only})
    table = r.summary().splitlines()
    print("\n".join(ln for ln in table if not ln.startswith("warning [")))
    print_warning_lines(r.warnings)
    sp = r.inputs["model_spread"]
    probs = ", ".join(f"{m['model']} {'-' if m['probability'] is None else format(m['probability'], '.2g')}"
                      for m in sp["models"])
    used = ", ".join(sp["included"]) or "no model"
    note(args, f"model spread over {used} of {', '.join(sp['candidates'])} "
               f"(model probabilities: {probs}; {r.inputs['model_spread_method']})")
    mix = r.inputs.get("mixture") or {}
    if len(mix.get("weights") or {}) > 1:
        ws = ", ".join(f"{m} {w:.2g}" for m, w in sorted(mix["weights"].items(), key=lambda kv: -kv[1]))
        print(f"90 % intervals: evidence-weighted mixture over the models (weights {ws}; {r.inputs['noise']} "
              "noise)")
    if args.json:
        r.save(args.json)
        note(args, f"wrote {args.json}")
    if args.plot:
        from pathlib import Path

        from ...plotting import save_figure
        from ...plotting.thiele_small import plot_ts_fit

        Path(args.plot).mkdir(parents=True, exist_ok=True)
        note(args, f"wrote {save_figure(plot_ts_fit(r), Path(args.plot) / PLOT_NAME, dpi=110)}")
    from ..exitcodes import status

    return status(any(w.get("code") == "not_converged" for w in r.warnings))
