"""``bayes-emt hankel DATA``: NL ring count by Hankel singular values.

Fits NL with ``--max-rings`` rings (default 7, as the paper), computes the Hankel singular values
of the blocked admittance ``1/(Zc + R0)`` (``max_rings + 1`` states; modes a decade or more outside
the data's band folded, shown as 0) and chooses n at the sharpest drop
(:func:`bayes_emt.estimation.hankel.choose_rings`).
"""

from __future__ import annotations

from ..paths import check_outputs
from ._common import (
    add_data_args,
    add_output_args,
    add_parser,
    detail,
    int_at_least,
    note,
    positive_float,
    print_table,
)

EXAMPLES = """\
bayes-emt hankel speaker.zma
bayes-emt hankel bench.csv --max-rings 9 --json rings.json
"""


def register(sub) -> None:
    p = add_parser(sub, "hankel", help="choose the NL ring count by Hankel singular values",
                   description=__doc__.split("\n\n", 1)[1], examples=EXAMPLES)
    p.add_argument("data", help="measurement file")
    add_data_args(p)
    p.add_argument("--max-rings", type=int_at_least(2), default=7,
                   help="rings of the over-sized NL fit (default 7)")
    p.add_argument("--n-turns", type=positive_float, default=480.0, help="coil turns N (default 480)")
    p.add_argument("--json", default=None, help="write the result as JSON here")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...estimation.hankel import select_rings
    from ...io import read_measurement
    from ...io.paramfile import write_json

    check_outputs([("--json", args.json)], [("DATA", args.data)])
    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity,
                            magnitude_only=args.magnitude_only).select(args.omega_min, args.omega_max)
    rc = select_rings(meas, args.max_rings, n_turns=args.n_turns)
    detail(args, f"NL({args.max_rings}) fit: " + ", ".join(
        f"{k} = {v:.4g}" for k, v in rc.fit.parameters.items()))
    rows = []
    for i, (h, r) in enumerate(zip(rc.hsv, list(rc.ratios) + [None], strict=True), start=1):
        ratio = "" if r is None else ("inf" if r == float("inf") else f"{r:.3g}")
        role = ("coil current" if i == 1 else "kept" if i <= rc.rings + 1
                else "dropped" if rc.resolved[i - 1] else "dropped (unresolved)")
        rows.append((i, f"{h:.4g}" if h > 0 else "0 (folded)", ratio, role))
    print(f"Hankel singular values of 1/(Zc + R0), NL({args.max_rings}) fit of {meas.source} "
          f"(rms relative residual {rc.fit.rms_rel_residual:.3g}; "
          f"{rc.n_folded} mode(s) outside {rc.band[0]:.4g}..{rc.band[1]:.4g} rad/s folded):")
    print_table(rows, ("state", "HSV [S]", "sigma_i/sigma_i+1", "role"))
    note(args, f"noise floor {rc.noise_floor:.3g} S: states below it are unresolved and count as 0")
    print(f"chosen: n = {rc.rings} rings (largest drop after state {rc.rings + 1}; "
          f"a drop counts if >= {rc.sharp_drop:g}x)")
    if args.json:
        write_json(args.json, rc.to_json_dict())
        note(args, f"wrote {args.json}")
    return 0
