"""``bayes-emt sample DATA --model M``: the posterior by emcee, started from the least-squares fit.

Prints the credible-interval table (median, 5 %, 95 %, ESS, τ, unit), writes the ArviZ
``DataTree`` (netCDF), optionally a JSON summary and plots. Exit status 0 when the run
converged, 1 when the step budget ran out first (the result is then flagged, not trusted),
2 on a user error.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_data_args, add_model_args, print_table


def _nu(text: str) -> float | None:
    if text.lower() in ("sample", "sampled", "free"):
        return None
    try:
        val = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number or 'sample', got {text!r}") from None
    if not val > 0:
        raise argparse.ArgumentTypeError(f"degrees of freedom must be positive, got {text!r}")
    return val


def register(sub) -> None:
    p = sub.add_parser("sample", help="posterior by emcee with convergence diagnostics (DataTree out)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", help="measurement file")
    add_model_args(p)
    add_data_args(p)
    p.add_argument("--out", default=None,
                   help="netCDF DataTree output (default: DATA stem + _MODEL.nc in the current folder)")
    p.add_argument("--checkpoint", default=None,
                   help="HDF5 checkpoint, written every step (default: the --out path with .h5)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in the checkpoint (same data, model, priors and seed)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing checkpoint")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--max-steps", type=int, default=20000, help="step budget (default 20000)")
    p.add_argument("--likelihood", choices=["gaussian", "student"], default="gaussian",
                   help="noise distribution of the real and imaginary parts (student: robust to outliers)")
    p.add_argument("--nu", type=_nu, default=4.0,
                   help="Student-t degrees of freedom, or 'sample' to sample it (default 4)")
    p.add_argument("--priors", default=None, metavar="FILE",
                   help="TOML/JSON prior overrides, e.g. [R0] dist = \"lognormal\" median = 2.6 "
                        "sigma_log = 0.05")
    p.add_argument("--json", default=None, metavar="OUT", help="write the summary as JSON here")
    p.add_argument("--plot", default=None, metavar="DIR", help="write corner, Bode-band and trace PNGs here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from ..io import read_measurement
    from ..likelihood import noise_param_set
    from ..models import build_model
    from ..paramfile import write_json
    from ..posterior import DERIVED
    from ..priors import apply_prior_file
    from ..sampling import sample_posterior

    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity).select(args.omega_min, args.omega_max)
    model = build_model(args.model, rings=args.rings, n_turns=args.n_turns)
    nu = args.nu if args.likelihood == "student" else 4.0
    noise = noise_param_set(args.likelihood, nu)
    if args.priors:
        model, noise = apply_prior_file(model, args.priors, noise_params=noise)
    stem = model.label.replace("(", "").replace(")", "")
    out = Path(args.out or f"{Path(args.data).stem}_{stem}.nc")
    ckpt = Path(args.checkpoint) if args.checkpoint else out.with_suffix(".h5")
    if ckpt.resolve() == out.resolve():
        raise ValueError(f"{out}: the checkpoint and the output must be different files")
    post = sample_posterior(meas, model, seed=args.seed, max_steps=args.max_steps, checkpoint=ckpt,
                            resume=args.resume, overwrite=args.overwrite,
                            progress=False if args.quiet else None, likelihood=args.likelihood, nu=nu,
                            noise_params=noise)
    print(f"model {model.label}, {meas.n_points} points, likelihood {post.likelihood.describe()}")
    print(f"{post.n_steps} steps x {post.n_walkers} walkers, tau_max {max(post.tau):.0f} steps, "
          f"burn {post.burn}, thin {post.thin}, {post.draws.shape[0] * post.draws.shape[1]} draws kept, "
          f"acceptance {post.acceptance:.2f}, {post.wall_time:.1f} s")
    print(("CONVERGED: " if post.converged else "NOT CONVERGED: ") + post.message)
    rows = [(r["name"], f"{r['median']:.5g}", f"{r['q05']:.5g}", f"{r['q95']:.5g}", f"{r['ess']:.0f}",
             f"{r['tau']:.0f}", r["unit"]) for r in post.summary_rows()]
    for name, vals in post.derived().items():
        q = np.quantile(vals, [0.5, 0.05, 0.95])
        rows.append((f"{name} (derived)", f"{q[0]:.5g}", f"{q[1]:.5g}", f"{q[2]:.5g}", "", "",
                     DERIVED[name][0]))
    print_table(rows, ("parameter", "median", "5 %", "95 %", "ESS", "tau", "unit"))
    post.save(out)
    print(f"wrote {out} (ArviZ DataTree; checkpoint {ckpt})")
    if args.json:
        write_json(args.json, post.to_json_dict())
        print(f"wrote {args.json}")
    if args.plot:
        from ..plotting.posterior import plot_bode_bands, plot_corner, plot_trace

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        for name, make in (("corner", plot_corner), ("bode", plot_bode_bands), ("trace", plot_trace)):
            path = folder / f"posterior_{stem}_{name}.png"
            make(post).savefig(path, dpi=100)
            print(f"wrote {path}")
    return 0 if post.converged else 1
