"""``bayes-emt export SOURCE [--zma OUT] [--frd OUT] [--data FILE | --grid FMIN:FMAX:N] [--wdr OUT]
[--hornresp OUT] [--vituixcad OUT [--fit FIT_JSON]]``: the fitted impedance as ZMA/FRD, T/S
parameters as driver files.

SOURCE is a fit or parameter JSON (``bayes-emt fit --json``; the curve is the model's impedance
on the grid of ``--data`` or on ``--grid``, log-spaced, Hz) or a T/S JSON (``bayes-emt ts
--json``; driver files for WinISD ``--wdr``, Hornresp ``--hornresp`` and a VituixCAD driver-database
line ``--vituixcad``, whose semi-inductance Ke comes from ``--fit``, the fit JSON of a model with a
semi_inductance term). Formats and their sources: :mod:`bayes_emt.io.export`.
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
bayes-emt export ts.json --vituixcad VituixCAD_driver.txt --fit semi_fit.json --name "SEAS E0018"
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
    p.add_argument("--vituixcad", default=None, metavar="OUT",
                   help="VituixCAD driver-database file, header and one row (from a T/S JSON)")
    p.add_argument("--fit", default=None, metavar="FIT_JSON",
                   help="fit JSON of a model with a semi_inductance term: gives VituixCAD's Ke")
    p.add_argument("--name", default="driver", help="the driver's model name in the VituixCAD row")
    p.add_argument("--sd", type=quantity("area"), default=None, metavar="AREA",
                   help="Sd if the T/S JSON lacks it: m^2, or with a unit (85cm2)")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...errors import DataFormatError
    from ...io.export import (
        fitted_impedance,
        grid_hz,
        write_frd,
        write_hornresp,
        write_vituixcad,
        write_wdr,
        write_zma,
    )

    outs = [("--zma", args.zma), ("--frd", args.frd), ("--wdr", args.wdr), ("--hornresp", args.hornresp),
            ("--vituixcad", args.vituixcad)]
    if not any(o for _, o in outs):
        raise ValueError("nothing to write: give --zma, --frd, --wdr, --hornresp or --vituixcad")
    check_outputs(outs, [("SOURCE", args.source), ("--data", args.data), ("--fit", args.fit)])
    try:
        rec = json.loads(Path(args.source).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise DataFormatError(f"{args.source}: not a readable JSON file ({exc})") from None
    is_ts = isinstance(rec, dict) and rec.get("method") in ("free_air", "added_mass", "added_volume")
    if (args.zma or args.frd) and is_ts:
        raise ValueError(f"{args.source} is a T/S record: --zma/--frd need a fit or parameter JSON")
    if (args.wdr or args.hornresp or args.vituixcad) and not is_ts:
        raise ValueError(f"{args.source} is not a T/S record (bayes-emt ts --json): "
                         "--wdr/--hornresp/--vituixcad need one")
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
    if args.vituixcad:
        coil = None
        if args.fit:
            from ...io.paramfile import read_param_file

            fmodel, ftheta = read_param_file(args.fit)
            if "K_semi" not in fmodel.names:
                raise ValueError(f"--fit {args.fit}: model {fmodel.spec} has no semi_inductance term, so no "
                                 "Ke; fit a model such as UD+semi_inductance, or drop --fit")
            coil = {k: float(ftheta[fmodel.names.index(k)]) for k in ("K_semi", "n_semi")}
        write_vituixcad(args.vituixcad, rec, model=args.name, sd=args.sd, coil=coil)
        note(args, f"wrote {args.vituixcad}" + ("" if coil else " (no --fit: Ke left empty)"))
    return 0
