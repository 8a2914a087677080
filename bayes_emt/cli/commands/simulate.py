"""``bayes-emt simulate``: a simulated measurement from a parameter file.

The parameter file is what ``bayes-emt fit --json`` writes (``{"model", "rings", "n_turns",
"parameters"}``); the output is the native CSV (``.csv``) or a ``.zma`` file. Noise model
(:func:`bayes_emt.io.simulate.simulate`): ``Y (1 + noise (e_r + j e_i))``, ``e_r, e_i`` standard normal.
"""

from __future__ import annotations

from ...io._rows import MIN_POINTS
from ..paths import check_outputs
from ._common import (
    add_output_args,
    add_parser,
    check_model_matches,
    detail,
    int_at_least,
    note,
    quantity,
    seed,
)

EXAMPLES = """\
bayes-emt simulate --params nl_fit.json --out nl_sim.csv
bayes-emt simulate --params ud.json --out ud.zma --noise 0.005 --seed 3 --points 500
bayes-emt simulate --params ul.json --model UL --rings 20 --out ul20.csv --noise 0
"""


def register(sub) -> None:
    p = add_parser(sub, "simulate", help="simulate a measurement from a parameter file",
                   description="Simulate the admittance of a model at the parameters of a JSON file "
                               "and write it as a measurement file.", examples=EXAMPLES)
    p.add_argument("--params", required=True, help='JSON {"model", "parameters"} (as fit --json writes)')
    p.add_argument("--out", required=True, help="output file (.csv native, or .zma)")
    p.add_argument("--model", default=None, metavar="MODEL",
                   help="check that the parameter file holds this model (a spec: UD, NL+winding_capacitance)")
    p.add_argument("--rings", type=int_at_least(1), default=None,
                   help="rings: for UL the discretisation (default: the file's, else 5); "
                        "for NL it must match the file's P1..Pn")
    p.add_argument("--noise", type=float, default=0.002,
                   help="relative complex Gaussian noise per real/imag part (default 0.002 = 0.2 %%)")
    p.add_argument("--seed", type=seed, default=0, help="noise seed, a non-negative integer (default 0)")
    p.add_argument("--omega-min", type=quantity("frequency", bare="rad/s"), default=1e1, metavar="W",
                   help="lowest omega, rad/s, or with a unit: 2Hz (default 10 rad/s)")
    p.add_argument("--omega-max", type=quantity("frequency", bare="rad/s"), default=1e5, metavar="W",
                   help="highest omega, rad/s, or with a unit: 20kHz (default 1e5 rad/s)")
    p.add_argument("--points", type=int_at_least(MIN_POINTS, " (the readers, and so fit, refuse fewer)"),
                   default=2000, help=f"log-spaced points, at least {MIN_POINTS} (default 2000)")
    add_output_args(p)
    p.set_defaults(func=run)


def _with_rings(model, theta, rings: int | None, where: str):
    """The model with ``rings`` rings (UL: any count; NL: must be the file's own)."""
    from ...errors import DataFormatError
    from ...models import build_model

    if rings is None or rings == model.rings:
        return model, theta
    if model.rings is None:
        raise DataFormatError(f"{where}: model {model.label} has no rings; drop --rings")
    try:
        other = build_model(model.spec, rings=rings, n_turns=model.n_turns)
    except ValueError as exc:
        raise DataFormatError(f"--rings: {exc}") from None
    if other.names != model.names:  # the ring parameters themselves are in the file (NL)
        raise DataFormatError(f"{where}: holds {model.label} parameters (P1..P{model.rings}), "
                              f"so --rings {rings} does not fit them")
    return other, theta


def run(args) -> int:
    from ...io import write_measurement
    from ...io.paramfile import read_param_file
    from ...io.simulate import log_omega_grid, simulate

    check_outputs([("--out", args.out)], [("--params", args.params)])
    model, theta = read_param_file(args.params)
    check_model_matches(model, args.model, args.params)
    model, theta = _with_rings(model, theta, args.rings, args.params)
    omega = log_omega_grid(args.omega_min, args.omega_max, args.points)
    meas = simulate(model, theta, omega, noise=args.noise, seed=args.seed, source=str(args.out))
    write_measurement(meas, args.out)
    noise = (f"noise {100 * args.noise:g} % relative per real/imag part, seed {args.seed}" if args.noise > 0
             else "no noise")
    detail(args, "parameters: " + ", ".join(f"{s.name} = {v:.6g} {s.unit}"
                                            for s, v in zip(model.params, theta, strict=True)))
    note(args, f"wrote {args.out}: model {model.label}, {meas.n_points} log-spaced points, "
          f"{omega[0]:.4g}..{omega[-1]:.4g} rad/s ({meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz), {noise}")
    return 0
