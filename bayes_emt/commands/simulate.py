"""``bayes-emt simulate``: a simulated measurement from a parameter file."""

from __future__ import annotations

from ._common import add_model_args


def register(sub) -> None:
    p = sub.add_parser("simulate", help="simulate a measurement from a parameter file")
    add_model_args(p, required=False)
    p.add_argument("--params", required=True, help='JSON {"model", "parameters"} (as fit --json writes)')
    p.add_argument("--out", required=True, help="output file (.csv native, or .zma)")
    p.add_argument("--noise", type=float, default=0.002,
                   help="relative complex Gaussian noise per real/imag part (default 0.002 = 0.2 %%)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--omega-min", type=float, default=1e1, help="rad/s (default 10)")
    p.add_argument("--omega-max", type=float, default=1e5, help="rad/s (default 1e5)")
    p.add_argument("--points", type=int, default=2000, help="log-spaced points (default 2000)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import DataFormatError
    from ..io import write_measurement
    from ..paramfile import read_param_file
    from ..simulate import log_omega_grid, simulate

    model, theta = read_param_file(args.params)
    if args.model is not None and args.model != model.name:
        raise DataFormatError(f"{args.params}: holds model {model.name}, but --model {args.model} was given")
    omega = log_omega_grid(args.omega_min, args.omega_max, args.points)
    meas = simulate(model, theta, omega, noise=args.noise, seed=args.seed, source=str(args.out))
    write_measurement(meas, args.out)
    print(f"wrote {args.out}: model {model.label}, {meas.n_points} points, "
          f"{omega[0]:.4g}..{omega[-1]:.4g} rad/s, noise {args.noise:g} (relative), seed {args.seed}")
    return 0
