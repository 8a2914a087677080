"""``bayes-emt export SOURCE [--zma OUT] [--frd OUT] [--data FILE | --grid FMIN:FMAX:N] [--wdr OUT]
[--hornresp OUT]``: the fitted impedance as ZMA/FRD, T/S parameters as driver files.

SOURCE is a fit or parameter JSON (``bayes-emt fit --json``; the curve is the model's impedance
on the grid of ``--data`` or on ``--grid``, log-spaced, Hz) or a T/S JSON (``bayes-emt ts
--json``; driver files for WinISD ``--wdr`` and Hornresp ``--hornresp``). Formats and their
sources: :mod:`bayes_emt.io.export`.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..paths import check_outputs
from ._common import add_output_args, add_parser, note, quantity

EXAMPLES = """\
bayes-emt export ud_fit.json --data speaker.zma --zma ud_fitted.zma
bayes-emt export ud_fit.json --grid 10:20000:500 --frd ud_fitted.frd
bayes-emt export ts.json --wdr driver.wdr --hornresp driver_hornresp.txt
"""


def register(sub) -> None:
    p = add_parser(sub, "export", help="fitted impedance as ZMA/FRD; T/S as WinISD/Hornresp driver files",
                   description=__doc__.split("\n\n", 1)[1], examples=EXAMPLES)
    p.add_argument("source", help="fit/parameter JSON or T/S JSON")
    p.add_argument("--zma", default=None, metavar="OUT", help="write the fitted impedance as .zma")
    p.add_argument("--frd", default=None, metavar="OUT", help="write the fitted impedance in FRD layout")
    p.add_argument("--data", default=None, metavar="FILE", help="use this recording's frequency grid")
    p.add_argument("--grid", default=None, metavar="FMIN:FMAX:N", help="log grid in Hz, e.g. 10:20000:500")
    p.add_argument("--wdr", default=None, metavar="OUT", help="WinISD driver file (from a T/S JSON)")
    p.add_argument("--hornresp", default=None, metavar="OUT", help="Hornresp driver record (from a T/S JSON)")
    p.add_argument("--sd", type=quantity("area"), default=None, metavar="AREA",
                   help="Sd if the T/S JSON lacks it: m^2, or with a unit (85cm2)")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...errors import DataFormatError
    from ...io.export import fitted_impedance, grid_hz, write_frd, write_hornresp, write_wdr, write_zma

    outs = [("--zma", args.zma), ("--frd", args.frd), ("--wdr", args.wdr), ("--hornresp", args.hornresp)]
    if not any(o for _, o in outs):
        raise ValueError("nothing to write: give --zma, --frd, --wdr or --hornresp")
    check_outputs(outs, [("SOURCE", args.source), ("--data", args.data)])
    try:
        rec = json.loads(Path(args.source).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise DataFormatError(f"{args.source}: not a readable JSON file ({exc})") from None
    is_ts = isinstance(rec, dict) and rec.get("method") in ("free_air", "added_mass", "added_volume")
    if (args.zma or args.frd) and is_ts:
        raise ValueError(f"{args.source} is a T/S record: --zma/--frd need a fit or parameter JSON")
    if (args.wdr or args.hornresp) and not is_ts:
        raise ValueError(f"{args.source} is not a T/S record (bayes-emt ts --json): "
                         "--wdr/--hornresp need one")
    if args.zma or args.frd:
        from ...io import read_measurement
        from ...io.paramfile import read_param_file

        model, theta = read_param_file(args.source)
        if (args.data is None) == (args.grid is None):
            raise ValueError("give the frequency grid: --data FILE (its grid) or --grid FMIN:FMAX:N")
        f_hz = read_measurement(args.data).f_hz if args.data else grid_hz(args.grid)
        Z = fitted_impedance(model, theta, f_hz)
        comment = f"bayes_emt: model {model.spec} fitted impedance ({args.source})"
        for path, fn in ((args.zma, write_zma), (args.frd, write_frd)):
            if path:
                fn(path, f_hz, Z, comment=comment)
                note(args, f"wrote {path} ({f_hz.size} points, {f_hz[0]:.4g}..{f_hz[-1]:.4g} Hz)")
    if args.wdr:
        write_wdr(args.wdr, rec, sd=args.sd)
        note(args, f"wrote {args.wdr}")
    if args.hornresp:
        write_hornresp(args.hornresp, rec, sd=args.sd)
        note(args, f"wrote {args.hornresp}")
    return 0
