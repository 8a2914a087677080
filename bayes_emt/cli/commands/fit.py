"""``bayes-emt fit DATA --model M [--rings N] [--procedure polished|paper] [--json OUT]``: automatic
initial estimate and two-step weighted least squares; prints name, value, unit and
standard error of every parameter, the rms relative residual and chi², the fit's warnings (model
inadequate, parameter at a bound, parameters not identifiable, resonance outside the data:
:mod:`bayes_emt.estimation.adequacy`), and writes
:meth:`~bayes_emt.estimation.results.FitResult.to_json_dict` as JSON (atomically; never over the
measurement file).

``--procedure paper`` stops after the paper's two steps (``fit_admittance(..., polish=False)``);
the default adds the relative-residual polish. Both are run, and the R0 each gives is printed and
written (``R0_by_procedure``): when the coil model misses physics the polish moves R0, and a
negative-resistance shunt's stability depends on R0."""

from __future__ import annotations

from ..paths import check_outputs
from ._common import (
    add_data_args,
    add_exclude_band_arg,
    add_model_args,
    add_output_args,
    add_parser,
    add_re_option,
    detail,
    meter_of,
    model_from_args,
    note,
    print_table,
    print_warning_lines,
)

EXAMPLES = """\
bayes-emt fit speaker.zma --model UD
bayes-emt fit speaker.zma --model NL --rings 5 --json nl_fit.json
bayes-emt fit lcr_export.csv --model UD --freq-unit hz --phase-unit rad --omega-min 60
bayes-emt fit speaker.zma --model UD+winding_capacitance --verbose
"""


def register(sub) -> None:
    p = add_parser(sub, "fit", help="deterministic fit: automatic initial estimate + two-step least squares",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("data", help="measurement file (.zma, CSV/TSV with header, .s1p)")
    add_model_args(p)
    add_data_args(p)
    add_exclude_band_arg(p)
    p.add_argument("--procedure", choices=["polished", "paper"], default="polished",
                   help="polished (default): the paper's two steps, then all parameters with relative "
                        "residuals; paper: the paper's two steps only (R0 and omega0 from the "
                        "1/s-weighted step)")
    p.add_argument("--json", default=None, help="write the result as JSON here")
    add_re_option(p)
    p.add_argument("--priors", default=None, metavar="FILE",
                   help="TOML/JSON prior overrides as for sample: their supports bound the fit; a normal "
                        "(or lognormal) prior on R0 acts as --re")
    p.add_argument("--ts", action="store_true",
                   help="also print the Thiele-Small free-air set (fast intervals)")
    add_output_args(p)
    p.set_defaults(func=run)


def format_value(v: float) -> str:
    return f"{v:.5g}"


def run(args) -> int:
    from ...estimation.fitting import fit_admittance
    from ...io import read_measurement
    from ...io.paramfile import write_json

    check_outputs([("--json", args.json)], [("DATA", args.data), ("--priors", args.priors)])
    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity,
                            magnitude_only=args.magnitude_only).select(args.omega_min, args.omega_max)
    meas = meas.exclude_bands(args.exclude_band)
    model = model_from_args(args)
    re_reading = meter_of(args)
    if args.priors:
        from ...inference.priors import apply_prior_file

        model, _ = apply_prior_file(model, args.priors)
        r0 = model.params["R0"].prior.to_dict()
        if re_reading is None and r0["dist"] in ("normal", "lognormal"):  # a prior: Bayes' rule, no cut
            re_reading = (r0["mu"], r0["sigma"], "prior") if r0["dist"] == "normal" else \
                (r0["median"], r0["median"] * r0["sigma_log"], "prior")
    fits = {name: fit_admittance(meas, model, polish=(name == "polished"), re=re_reading)
            for name in ("polished", "paper")}
    fit = fits[args.procedure]
    r0 = {name: float(f.parameters["R0"]) for name, f in fits.items()}
    se = fit.stderr
    rows = [(s.name, format_value(v), s.unit, format_value(se[s.name]))
            for s, v in zip(model.params, fit.theta, strict=True)]
    note(args, f"model {model.label} on {meas.source}: {meas.n_points} points, "
         f"{meas.omega[0]:.4g}..{meas.omega[-1]:.4g} rad/s ({meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz); "
         f"procedure: {args.procedure}")
    print_table(rows, ("parameter", "value", "unit", "std error"))
    print(f"rms relative residual {fit.rms_rel_residual:.4g}   chi2 {fit.chi2:.4g}")
    detail(args, f"fit time {fit.info['seconds']:.2f} s; initial estimate: {fit.info['initial']['path']}; "
                 f"optimiser: {fit.message}")
    if not fit.success:
        print(f"note: the optimiser did not converge ({fit.message})")
    if fit.cov_z is None:
        print("note: the Jacobian is rank-deficient; no standard errors")
    print_warning_lines(fit.warnings, model=model.label)
    diff = r0["polished"] - r0["paper"]
    print(f"by procedure: R0 polished {r0['polished']:.5g} ohm, paper's two steps {r0['paper']:.5g} ohm "
          f"(difference {diff:+.4g} ohm, {100 * diff / r0['paper']:+.2g} %)")
    if abs(diff) > 0.01 * abs(r0["paper"]):
        print("note: the procedures disagree on R0 by more than 1 %: the coil model may miss physics; a "
              "negative-resistance shunt's stability depends on R0 (shunt --posterior reports by how much)")
    if re_reading is not None:
        how = ("R0 held at the reading (cut), the others fitted at it" if fit.info["re"]["mode"] == "cut"
               else "applied as a penalty (prior)")
        info = fit.info["re"]
        print(f"ohmmeter reading R0 = {info['value']:.5g} +/- {info['sd']:.2g} ohm: {how}; the data "
              f"alone put R0 at {info['R0_data']:.5g} +/- {info['R0_data_sd']:.2g} ohm "
              f"({info['conflict_sd']:.1f} sd apart)")
    if args.ts:
        from ...thiele_small import thiele_small

        print(thiele_small(meas, model, re=re_reading, fast=True, models_for_spread=[]).summary())
    if args.json:
        write_json(args.json, {"kind": fit.kind, **fit.to_json_dict(), "procedure": args.procedure,
                               "R0_by_procedure": r0, "phase": "absent" if meas.phase_absent else "measured"})
        note(args, f"wrote {args.json}")
    from ..exitcodes import status

    return status(not fit.success)
