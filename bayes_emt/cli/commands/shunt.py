"""``bayes-emt shunt``: H∞-optimal RC shunt, stability, cross-model evaluation, digital realisation;
with ``--posterior``, shunt design under uncertainty.

``--params P.json`` alone: the design for one parameter file (``{"model", "rings"?, "parameters"}``,
as ``fit --json`` writes); ``--model`` is optional and, when given, must name the file's model (a
check, not an override). ``--posterior RUN.nc`` (repeatable: a mixture of models, weighted by
``--log-evidence`` or ``--compare``, else equally): every posterior draw's optimal shunt, the
nominal shunt (designed at ``--params`` if given, else at the posterior median) on every draw,
and a robust shunt minimising ``--risk`` subject to P(unstable) <= ``--epsilon``, chosen on half
the draws and reported on the other half. ``--r-in/--k-in/--k-out/--fs/--delay`` require
``--implement`` (with ``--posterior``: the sampled-data controller enters every draw's stability).
"""

from __future__ import annotations

import math
from pathlib import Path

from ..paths import check_outputs
from ._common import (
    add_output_args,
    add_parser,
    add_re_option,
    check_model_matches,
    detail,
    finite_float,
    int_at_least,
    note,
    positive_float,
    quantity,
    seed,
)

EXAMPLES = """\
bayes-emt shunt --params nl_fit.json
bayes-emt shunt --params ud_fit.json --evaluate-on nl_fit.json --json ud_shunt.json
bayes-emt shunt --params nl_fit.json --implement --fs 5000 --delay 1 --plot figures/
bayes-emt shunt --posterior nl.nc --params nl_fit.json --risk cvar --epsilon 1e-3 --json robust.json
bayes-emt shunt --posterior nl.nc --posterior ud.nc --compare compare.json --plot figures/
"""

TABLE7 = {"r_in": 0.0996, "k_in": 99.23, "k_out": 0.9846, "fs": 5000.0}



def _epsilon(text: str):
    """``--epsilon``: a number, or ``auto``."""
    return "auto" if text.strip().lower() == "auto" else finite_float(text)

def register(sub) -> None:
    p = add_parser(sub, "shunt", help="optimal RC shunt for a parameter file, or robust over posteriors "
                   "(H∞-optimal)", description=__doc__.split("\n\n", 1)[1], examples=EXAMPLES)
    p.add_argument("--params", default=None, metavar="P.json",
                   help='parameter file {"model", "rings"?, "parameters"} (as fit --json writes); with '
                        "--posterior: the point estimate of the nominal design")
    p.add_argument("--posterior", action="append", default=None, metavar="RUN.nc",
                   help="posterior file (sample --out); repeat for a mixture of models")
    p.add_argument("--risk", choices=["cvar", "mean", "worst"], default="cvar",
                   help="risk measure of the attenuation over draws (default cvar)")
    p.add_argument("--alpha", type=finite_float, default=0.9,
                   help="CVaR level (default 0.9: the worst 10 %%)")
    p.add_argument("--epsilon", type=_epsilon, default="auto",
                   help="bound on P(unstable) per model, or 'auto' (default): the smallest of 0.001, "
                        "0.002, 0.005, 0.01, ... that the posterior draws the choice never sees can show "
                        "(none unstable among N >= ln(1 - confidence)/ln(1 - epsilon) of them)")
    p.add_argument("--draws", type=int_at_least(2), default=1000, help="posterior draws used (default 1000)")
    p.add_argument("--seed", type=seed, default=0,
                   help="seed of the draw choice and the half split (default 0)")
    p.add_argument("--confidence", type=finite_float, default=0.95,
                   help="level of the Clopper-Pearson interval on P(unstable) (default 0.95)")
    p.add_argument("--log-evidence", type=finite_float, action="append", default=None, metavar="LZ",
                   help="log evidence [nats] of each --posterior, in order (mixture weights)")
    p.add_argument("--compare", default=None, metavar="C.json",
                   help="bayes-emt compare JSON with the models' log evidences (mixture weights)")
    p.add_argument("--model", default=None, metavar="MODEL",
                   help="optional check: the model (spec) the parameter file must hold")
    p.add_argument("--json", default=None, metavar="OUT", help="write the design as JSON here")
    p.add_argument("--evaluate-on", default=None, metavar="P2.json",
                   help="also evaluate the design on another parameter file (e.g. the best model)")
    p.add_argument("--implement", action="store_true",
                   help="discretise the controller (eqs. 55-56, Tustin) and evaluate it")
    p.add_argument("--r-in", type=positive_float, default=None,
                   help="sense resistor R_in [ohm] (Table 7: 0.0996)")
    p.add_argument("--k-in", type=positive_float, default=None, help="input gain K_in (Table 7: 99.23)")
    p.add_argument("--k-out", type=positive_float, default=None, help="output gain K_out (Table 7: 0.9846)")
    p.add_argument("--fs", type=quantity("frequency", bare="Hz"), default=None,
                   help="DSP sample rate [Hz, or with a unit: 5kHz] (default 5000)")
    p.add_argument("--delay", type=int_at_least(0), nargs="?", const=1, default=None, metavar="SAMPLES",
                   help="computation delay in samples (flag alone: 1; default 0)")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help="write PNGs (receptance and attenuation map; with --posterior: gain bands, "
                        "distributions, stability boundary)")
    p.add_argument("--ohmmeter-tolerance", type=finite_float, default=None, metavar="OHM",
                   help="tolerance [ohm] of a DC resistance measurement of R0: the stability margin is "
                        "compared with it too (besides the fit's standard error, the procedures' R0 and, "
                        "with --evaluate-on or several --posterior, the other models' R0)")
    p.add_argument("--r0-interval", choices=["total", "model"], default="total",
                   help="with --posterior: 'total' (default) widens each model's R0 draws by the spread "
                        "between the fit's R0 and the recording's low-frequency plateau (the Re interval "
                        "ts reports), so every draw's design, the stability constraint and the margins see "
                        "it; 'model': the posterior's R0 alone (if the model were exact)")
    p.add_argument("--bandwidth", type=quantity("frequency", bare="rad/s"), default=None, metavar="W",
                   help="the shunt realisation's bandwidth [rad/s, or with a unit: 2kHz]: the stability "
                        "constraint leaves out the "
                        "ideal loop above it (needed with a capacitance across the terminals); default: "
                        "ideal loop")
    add_re_option(p)
    add_output_args(p)
    p.set_defaults(func=run)


def _fmt_margin(ev) -> str:
    extra = ""
    if ev.max_pole_real is not None:
        extra = f"; max Re(pole) {ev.max_pole_real:.4g} 1/s, min damping ratio {ev.min_damping_ratio:.3f}"
    return (f"stable: {'yes' if ev.stable else 'NO'}; unstable below Rs = {ev.Rs_instability:.5f} ohm "
            f"(margin {ev.stability_margin:.4f} ohm{extra})")


def name_peaks(d, model, theta) -> list[tuple[float, float, str]]:
    """``(omega [rad/s], value [s²], what it is)`` for each peak of the design: the low end of the
    band the design looks at (omega0/40: the shunt's electrical resonance with the coil lies at or
    below it), the driver's mechanical resonance (open-terminal fs and where the shunt moved it), a
    second mechanical mode, or the shunt's electrical resonance."""
    from ...shunt.batch.plant import SPAN

    _, w0, _ = (float(v) for v in model.mechanics(theta))
    names = model.as_dict(theta)
    modes = [(w0, f"the driver's mechanical resonance (open terminals {w0 / (2 * math.pi):.4g} Hz)")]
    if "omega2" in names:
        w2 = float(names["omega2"])
        modes.append((w2, f"the second mechanical mode (open terminals {w2 / (2 * math.pi):.4g} Hz)"))
    out = []
    for w, v in d.peaks:
        if abs(math.log(w / (w0 / SPAN))) < 1e-6:
            name = (f"the low end of the design band (omega0/{SPAN:g}): the shunt's electrical resonance "
                    "with the coil lies at or below it, and below it the response rises (see the warning)")
        else:
            near = min(modes, key=lambda m: abs(math.log(w / m[0])))
            name = near[1] if abs(math.log(w / near[0])) < math.log(4.0) else (
                "the shunt's electrical resonance (Cs with the coil's inductance)")
        out.append((float(w), float(v), name))
    return out


def run(args) -> int:
    from ...io.paramfile import read_param_file, write_json
    from ...shunt import design_rc_shunt, evaluate_rc_shunt
    from ...shunt.implementation import realise_rc_shunt
    from ...shunt.safety import r0_uncertainty_of_files
    from ._common import print_warnings

    rig = {k: getattr(args, k) for k in ("r_in", "k_in", "k_out", "fs")}
    if not args.implement and (any(v is not None for v in rig.values()) or args.delay is not None):
        raise ValueError("--r-in, --k-in, --k-out, --fs and --delay apply to --implement only")
    if args.posterior:
        from ...shunt.batch.plant import SampledShunt
        from ._robust_shunt import run_posterior

        sampled = None
        if args.implement:
            rig = {k: (TABLE7[k] if v is None else v) for k, v in rig.items()}
            sampled = SampledShunt(rig["r_in"], rig["k_in"], rig["k_out"], rig["fs"], args.delay or 0)
        return run_posterior(args, sampled)
    posterior_only = {"--log-evidence": args.log_evidence, "--compare": args.compare}
    for flag, v in posterior_only.items():
        if v:
            raise ValueError(f"{flag} applies to --posterior only")
    if args.params is None:
        raise ValueError("give --params P.json (one design) or --posterior RUN.nc (design under uncertainty)")
    inputs = [("--params", args.params), ("--evaluate-on", args.evaluate_on)]
    model, theta = read_param_file(args.params)
    check_model_matches(model, args.model, args.params)
    plots = [f"shunt_{model.spec}_{name}.png" for name in ("receptance", "attenuation_map")]
    check_outputs([("--json", args.json)], inputs, folders=[("--plot", args.plot, plots)])
    ohmmeter = args.ohmmeter_tolerance
    if args.re is not None:  # an ohmmeter reading: its 90 % half-width is the tolerance the margin must beat
        value, sd = args.re
        ohmmeter = max(ohmmeter or 0.0, 1.645 * sd)
        r0 = float(model.as_dict(theta)["R0"])
        if abs(r0 - value) > 3 * sd:
            print(f"warning [r0_disagrees_with_ohmmeter]: R0 = {r0:.5g} ohm in {args.params} is "
                  f"{(r0 - value) / sd:+.1f} SD from the ohmmeter's {value:.5g} ohm: refit with --re before "
                  "trusting this shunt's stability margin")
    r0_unc = r0_uncertainty_of_files(args.params, others=[args.evaluate_on] if args.evaluate_on else (),
                                     ohmmeter=ohmmeter)
    from ...shunt.robust import refuse_undefined

    refuse_undefined(model, theta, str(args.params))
    d = design_rc_shunt(model, theta, bandwidth=args.bandwidth, r0_uncertainty=r0_unc)
    out = d.to_json_dict()
    out["params"] = str(args.params)
    out["units"] = {"Rs": "ohm", "Cs": "F", "attenuation_db": "dB", "peak": "s^2 (mass-normalised m*G)",
                    "peak_omega": "rad/s", "Rs_instability": "ohm", "stability_margin": "ohm",
                    "stability_margin_ohm": "ohm", "r0_uncertainty_ohm": "ohm", "max_pole_real": "1/s"}
    cf = d.closed_form
    print(f"model {model.label} ({args.params}): H-infinity optimal RC shunt ({d.optimum})")
    print(f"  Rs = {d.Rs:.5f} ohm, Cs = {d.Cs:.5g} F: attenuation {d.attenuation_db:.3f} dB "
          f"(peak at {d.peak_omega:.4g} rad/s = {d.peak_omega / (2 * math.pi):.4g} Hz)")
    detail(args, "  parameters: " + ", ".join(f"{s.name} = {v:.5g} {s.unit}"
                                              for s, v in zip(model.params, theta, strict=True)))
    if math.isfinite(cf["Rs"]):
        note(args, f"  fixed-point closed form: Rs = {cf['Rs']:.5f} ohm, Cs = {cf['Cs']:.5g} F "
              f"({cf['attenuation_db']:.3f} dB; coil at omega0: L = {cf['L_eq']:.4g} H, "
              f"R = {cf['R_eq']:.3g} ohm)")
    else:
        note(args, "  no fixed-point closed form: the coupling is too strong for the coil's inductance "
              f"(phi^2 >= 2 L omega0^2 with L = {cf['L_eq']:.4g} H at omega0), as for most loudspeakers; "
              "the optimiser started from the coil tuned to omega0 instead")
    for w, v, name in name_peaks(d, model, theta):
        rel = 20 * math.log10(v / d.peak_open)
        print(f"  peak at {w / (2 * math.pi):.4g} Hz ({w:.4g} rad/s), {rel:.2f} dB re the open peak: {name}")
    print("  " + _fmt_margin(d))
    unc = ("none given" if d.r0_uncertainty_ohm is None else f"{d.r0_uncertainty_ohm:.4g} ohm ("
           + ", ".join(f"{k} {v:.4g}" for k, v in d.r0_uncertainty.items()) + ")")
    print(f"  stability margin {d.stability_margin_ohm:.4g} ohm; R0 uncertainty {unc}")
    print_warnings(list(d.warnings))
    for n in d.notes:
        print(f"note: {n}")
    if args.evaluate_on:
        m2, th2 = read_param_file(args.evaluate_on)
        ev = evaluate_rc_shunt(m2, th2, d.Rs, d.Cs, bandwidth=args.bandwidth)
        out["evaluated_on"] = {"params": str(args.evaluate_on), **ev.to_json_dict()}
        print(f"  on {m2.label} ({args.evaluate_on}): attenuation {ev.attenuation_db:.3f} dB; "
              + _fmt_margin(ev))
    if args.implement:
        rig = {k: (TABLE7[k] if v is None else v) for k, v in rig.items()}
        r = realise_rc_shunt(model, theta, d.Rs, d.Cs, R_in=rig["r_in"], K_in=rig["k_in"], K_out=rig["k_out"],
                             fs=rig["fs"], delay_samples=args.delay or 0)
        out["implementation"] = r.to_json_dict()
        (b0, b1), (a0, a1) = r.K_s
        print(f"  controller (56): K(s) = ({b0:.8g} s + {b1:.8g}) / s   "
              f"[R_in = {r.R_in:g} ohm, K_in = {r.K_in:g}, K_out = {r.K_out:g}]")
        (b0, b1), (a0, a1) = r.K_z
        delay = f" z^-{r.delay_samples}" if r.delay_samples else ""
        print(f"  Tustin at fs = {r.fs:g} Hz: K(z) ={delay} ({b0:.10g} {b1:+.10g} z^-1) / "
              f"({a0:.10g} {a1:+.10g} z^-1)")
        print(f"  achieves {r.attenuation_db:.3f} dB (ideal shunt {r.attenuation_ideal_db:.3f} dB); "
              f"sampled-data loop {'stable' if r.stable else 'UNSTABLE'} (max |z| = {r.max_pole_abs:.6f}; "
              f"plant: {r.plant_used})")
    if args.plot:
        from ...plotting import save_figure
        from ...plotting.shunt import plot_attenuation_map, plot_receptance

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        for name, fig in (("receptance", plot_receptance(d, model, theta)),
                          ("attenuation_map", plot_attenuation_map(d, model, theta))):
            path = folder / f"shunt_{model.spec}_{name}.png"  # the names checked above
            save_figure(fig, path, dpi=120)
            note(args, f"  wrote {path}")
    if args.json:
        write_json(args.json, out)
        note(args, f"wrote {args.json}")
    return 0
