"""``bayes-emt hankel DATA``: NL ring count by Hankel singular values (SPEC §3.3)."""

from __future__ import annotations

from ._common import add_data_args, print_table


def register(sub) -> None:
    p = sub.add_parser("hankel", help="choose the NL ring count by Hankel singular values")
    p.add_argument("data", help="measurement file")
    add_data_args(p)
    p.add_argument("--max-rings", type=int, default=7, help="rings of the over-sized NL fit (default 7)")
    p.add_argument("--n-turns", type=float, default=480.0, help="coil turns N (default 480)")
    p.add_argument("--json", default=None, help="write the result as JSON here")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..hankel import SHARP_DROP, select_rings
    from ..io import read_measurement
    from ..paramfile import write_json

    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity).select(args.omega_min, args.omega_max)
    rc = select_rings(meas, args.max_rings, n_turns=args.n_turns)
    rows = []
    for i, h in enumerate(rc.hsv, start=1):
        nxt = rc.hsv[i] if i < rc.hsv.size else None
        ratio = "" if nxt is None else ("inf (folded)" if nxt == 0 else f"{h / nxt:.3g}")
        rows.append((i, f"{h:.4g}" if h > 0 else "0 (outside the band)", ratio))
    print(f"Hankel singular values of 1/(Zc + R0), NL({args.max_rings}) fit on {meas.source} "
          f"(rms relative residual {rc.fit.rms_rel_residual:.3g}):")
    print_table(rows, ("state", "HSV [S]", "drop to next"))
    print(f"chosen: n = {rc.rings} rings (first drop >= {SHARP_DROP:g}x after state {rc.rings + 1})")
    if args.json:
        write_json(args.json, rc.to_json_dict())
        print(f"wrote {args.json}")
    return 0
