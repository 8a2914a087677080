"""``bayes-emt added-mass BASE LOADED --delta-m KG --model M``: physical m, c, k, φ."""

from __future__ import annotations

from ._common import add_data_args, add_model_args, print_table


def register(sub) -> None:
    p = sub.add_parser("added-mass", help="physical m, c, k, phi from an added-mass pair (joint fit)")
    p.add_argument("base", help="recording without the added mass")
    p.add_argument("loaded", help="recording with the added mass")
    p.add_argument("--delta-m", type=float, required=True,
                   help="mass added in LOADED [kg] (negative: removed)")
    add_model_args(p)
    add_data_args(p)
    p.add_argument("--json", default=None, help="write the result as JSON here")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..added_mass import PHYSICAL_UNITS, fit_added_mass
    from ..io import read_measurement
    from ..models import build_model
    from ..paramfile import write_json

    opts = {"freq_unit": args.freq_unit, "phase_unit": args.phase_unit, "quantity": args.quantity}
    base = read_measurement(args.base, **opts).select(args.omega_min, args.omega_max)
    loaded = read_measurement(args.loaded, **opts).select(args.omega_min, args.omega_max)
    model = build_model(args.model, rings=args.rings, n_turns=args.n_turns)
    r = fit_added_mass(base, loaded, args.delta_m, model)
    rows = [(k, f"{r.values[k]:.5g}", PHYSICAL_UNITS[k], f"{r.stderr[k]:.3g}", f"{r.two_fit[k]:.5g}")
            for k in PHYSICAL_UNITS]
    print(f"added mass {args.delta_m:+g} kg, model {model.label}: joint fit of both recordings")
    print_table(rows, ("parameter", "joint fit", "unit", "std error", "two separate fits"))
    print(f"rms relative residual: base {r.rms_rel_residual[0]:.3g}, loaded {r.rms_rel_residual[1]:.3g}")
    if args.json:
        write_json(args.json, r.to_json_dict())
        print(f"wrote {args.json}")
    return 0
