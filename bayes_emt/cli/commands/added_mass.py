"""``bayes-emt added-mass BASE LOADED --delta-m KG --model M``: physical m, c, k, φ.

Fits each recording separately, applies the paper's formulas (Appendix B) to the two fits, then
fits both recordings jointly with shared m, c, k, φ, R0 and coil parameters (the base run sees m,
the loaded run m + Δm). Prints both, with standard errors, and an F-test of whether the pair is
consistent with one set of shared parameters.
"""

from __future__ import annotations

from ..paths import check_outputs
from ._common import (
    add_data_args,
    add_model_args,
    add_output_args,
    add_parser,
    add_re_option,
    detail,
    meter_of,
    model_from_args,
    note,
    print_table,
    quantity,
)

EXAMPLES = """\
bayes-emt added-mass free_air.zma with_100g.zma --delta-m 0.100 --model UD
bayes-emt added-mass bench.zma bench_minus.zma --delta-m -0.645 --model NL --json physical.json
bayes-emt added-mass free.txt loaded.txt --delta-m 0.1 --model UD --phase-unit rad --omega-max 6283
"""


def register(sub) -> None:
    p = add_parser(sub, "added-mass", help="physical m, c, k, phi from an added-mass pair (joint fit)",
                   description=__doc__.split("\n\n", 1)[1], examples=EXAMPLES)
    p.add_argument("base", help="recording without the added mass")
    p.add_argument("loaded", help="recording with the added mass")
    p.add_argument("--delta-m", type=quantity("mass", sign="nonzero"), required=True, metavar="MASS",
                   help="mass added in LOADED: kg, or with a unit (100g); negative: removed")
    add_model_args(p)
    add_data_args(p)
    add_re_option(p)
    p.add_argument("--json", default=None, help="write the result as JSON here")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...added_mass.fit import PHYSICAL_NAMES, PHYSICAL_UNITS, fit_added_mass
    from ...io import read_measurement
    from ...io.paramfile import write_json

    check_outputs([("--json", args.json)], [("BASE", args.base), ("LOADED", args.loaded)])
    from ...thiele_small.plausibility import check_inputs

    check_inputs(deltas=[args.delta_m])  # 8.017 meaning grams is refused before any fit
    opts = {"freq_unit": args.freq_unit, "phase_unit": args.phase_unit, "quantity": args.quantity,
            "magnitude_only": args.magnitude_only}
    base = read_measurement(args.base, **opts).select(args.omega_min, args.omega_max)
    loaded = read_measurement(args.loaded, **opts).select(args.omega_min, args.omega_max)
    model = model_from_args(args)
    r = fit_added_mass(base, loaded, args.delta_m, model)
    two_se = r.two_fit.get("stderr", {})
    rows = [(k, f"{r.values[k]:.5g}", f"{r.stderr[k]:.2g}", f"{r.two_fit[k]:.5g}",
             f"{two_se.get(k, float('nan')):.2g}", PHYSICAL_UNITS[k]) for k in PHYSICAL_NAMES]
    note(args, f"added mass {args.delta_m:+g} kg, model {model.label}, "
               f"{base.n_points} + {loaded.n_points} points")
    detail(args, f"base {base.source}: {base.f_hz[0]:.4g}..{base.f_hz[-1]:.4g} Hz; "
                 f"loaded {loaded.source}: {loaded.f_hz[0]:.4g}..{loaded.f_hz[-1]:.4g} Hz")
    print_table(rows, ("parameter", "joint fit", "std error", "two fits", "std error", "unit"))
    mech = [(n, f"{r.base[n]:.5g}", f"{r.separate['base'][n]:.5g}", f"{r.loaded[n]:.5g}",
             f"{r.separate['loaded'][n]:.5g}", model.params[n].unit) for n in ("zeta", "omega0", "phi")]
    print("\neach run: implied by the joint fit vs its separate fit")
    print_table(mech, ("parameter", "base joint", "base alone", "loaded joint", "loaded alone", "unit"))
    c = r.consistency
    print(f"\nrms relative residual: base {r.rms_rel_residual[0]:.3g}, loaded {r.rms_rel_residual[1]:.3g}; "
          f"consistency F = {c['F']:.3g} (dof {c['dof'][0]}, {c['dof'][1]}), p = {c['p_value']:.3g}")
    if c["p_value"] < 1e-3:
        print("the two runs do not share one set of parameters within their scatter: treat the standard "
              "errors as lower bounds")
    from ...thiele_small import thiele_small

    print("\n" + thiele_small(base, model, loaded=[(loaded, args.delta_m)], re=meter_of(args), fast=True,
                              models_for_spread=[]).summary())
    if args.json:
        write_json(args.json, r.to_json_dict())
        note(args, f"wrote {args.json}")
    if not r.success:
        print(f"note: the joint optimiser did not converge ({r.message}): the values are not to be trusted")
    from ..exitcodes import status

    return status(not r.success)
