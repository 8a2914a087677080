"""``bayes-emt shunt``: H∞-optimal RC shunt, stability, cross-model evaluation, realisation."""

from __future__ import annotations

from pathlib import Path

from ._common import add_model_args


def register(sub) -> None:
    p = sub.add_parser("shunt", help="optimal RC shunt for a parameter file (SPEC §4)")
    add_model_args(p, required=False)
    p.add_argument("--params", required=True, help='JSON {"model", "parameters"} (as fit --json writes)')
    p.add_argument("--json", default=None, help="write the design as JSON here")
    p.add_argument("--evaluate-on", default=None, metavar="P2.json",
                   help="also evaluate the design on another model's parameters")
    p.add_argument("--implement", action="store_true", help="discretise the controller (eqs. 55-56)")
    p.add_argument("--r-in", type=float, default=0.0996, help="sense resistor R_in [ohm] (Table 7)")
    p.add_argument("--k-in", type=float, default=99.23, help="input gain K_in (Table 7)")
    p.add_argument("--k-out", type=float, default=0.9846, help="output gain K_out (Table 7)")
    p.add_argument("--fs", type=float, default=5000.0, help="DSP sample rate [Hz] (default 5000)")
    p.add_argument("--delay", type=int, default=0, help="computation delay [samples] (default 0)")
    p.add_argument("--plot", default=None, metavar="DIR", help="write receptance and attenuation-map PNGs")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import DataFormatError
    from ..paramfile import read_param_file, write_json
    from ..shunt import Plant, design_rc_shunt, evaluate_rc_shunt
    from ..shunt.implementation import realise_rc_shunt

    model, theta = read_param_file(args.params)
    if args.model is not None and args.model != model.name:
        raise DataFormatError(f"{args.params}: holds model {model.name}, but --model {args.model} was given")
    d = design_rc_shunt(model, theta)
    out = d.to_json_dict()
    out["units"] = {"Rs": "ohm", "Cs": "F", "attenuation_db": "dB", "peak": "s^2 (mass-normalised)",
                    "peak_omega": "rad/s", "Rs_instability": "ohm", "stability_margin": "ohm",
                    "max_pole_real": "1/s"}
    print(f"model {model.label}: optimal RC shunt")
    print(f"  Rs = {d.Rs:.5g} ohm, Cs = {d.Cs:.5g} F, attenuation {d.attenuation_db:.2f} dB "
          f"(peak at {d.peak_omega:.4g} rad/s = {d.peak_omega / 6.283185307:.4g} Hz)")
    print(f"  closed-form start: Rs = {d.closed_form['Rs']:.5g} ohm, Cs = {d.closed_form['Cs']:.5g} F, "
          f"{d.closed_form['attenuation_db']:.2f} dB")
    print(f"  stable: {'yes' if d.stable else 'NO'}; unstable below Rs = {d.Rs_instability:.5g} ohm "
          f"(margin {d.stability_margin:.4g} ohm)")
    if args.evaluate_on:
        m2, th2 = read_param_file(args.evaluate_on)
        ev = evaluate_rc_shunt(m2, th2, d.Rs, d.Cs)
        out["evaluated_on"] = {"params": str(args.evaluate_on), **ev.to_json_dict()}
        print(f"  on {m2.label} ({args.evaluate_on}): attenuation {ev.attenuation_db:.2f} dB, "
              f"stable {'yes' if ev.stable else 'NO'} (margin {ev.stability_margin:.4g} ohm)")
    if args.implement:
        r = realise_rc_shunt(model, theta, d.Rs, d.Cs, R_in=args.r_in, K_in=args.k_in, K_out=args.k_out,
                             fs=args.fs, delay_samples=args.delay)
        out["implementation"] = r.to_json_dict()
        b, a = r.K_z
        print(f"  realisation at fs = {r.fs:g} Hz, delay {r.delay_samples} samples: K(z) = "
              f"({b[0]:.8g} + {b[1]:.8g} z^-1) / ({a[0]:.8g} + {a[1]:.8g} z^-1)")
        print(f"  achieves {r.attenuation_db:.2f} dB (ideal {r.attenuation_ideal_db:.2f} dB); "
              f"sampled-data loop {'stable' if r.stable else 'UNSTABLE'} (max |z| = {r.max_pole_abs:.6f}; "
              f"plant: {r.plant_used})")
    if args.plot:
        from ..plotting.shunt import plot_attenuation_map, plot_receptance

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        plant = Plant(model, theta)
        for name, fig in (("receptance", plot_receptance(plant, d)),
                          ("attenuation_map", plot_attenuation_map(plant, d))):
            path = folder / f"shunt_{model.name}_{name}.png"
            fig.savefig(path, dpi=120)
            print(f"  wrote {path}")
    if args.json:
        write_json(args.json, out)
        print(f"wrote {args.json}")
    return 0
