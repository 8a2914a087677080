"""``bayes-emt sample DATA --model M``: the posterior by emcee, seeded by the least-squares fit."""

from __future__ import annotations

from pathlib import Path

from ._common import add_data_args, add_model_args, print_table


def register(sub) -> None:
    p = sub.add_parser("sample", help="posterior by emcee with convergence diagnostics (DataTree out)")
    p.add_argument("data", help="measurement file")
    add_model_args(p)
    add_data_args(p)
    p.add_argument("--out", default=None, help="netCDF DataTree output (default: DATA stem + _MODEL.nc)")
    p.add_argument("--checkpoint", default=None,
                   help="HDF5 checkpoint (default: the --out path with .h5); resume with --resume")
    p.add_argument("--resume", action="store_true", help="continue the run in the checkpoint")
    p.add_argument("--overwrite", action="store_true", help="replace an existing checkpoint")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--max-steps", type=int, default=20000, help="step budget (default 20000)")
    p.add_argument("--likelihood", choices=["gaussian", "student"], default="gaussian")
    p.add_argument("--nu", type=float, default=4.0, help="Student-t degrees of freedom (default 4)")
    p.add_argument("--priors", default=None, help="TOML/JSON prior overrides")
    p.add_argument("--json", default=None, help="write the summary as JSON here")
    p.add_argument("--plot", default=None, metavar="DIR", help="write corner and Bode-band PNGs here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..io import read_measurement
    from ..models import build_model
    from ..paramfile import write_json
    from ..priors import apply_prior_file
    from ..sampling import SamplerSettings, sample_posterior

    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity).select(args.omega_min, args.omega_max)
    model = build_model(args.model, rings=args.rings, n_turns=args.n_turns)
    if args.priors:
        model = apply_prior_file(model, args.priors)
    out = Path(args.out or f"{Path(args.data).stem}_{model.label.replace('(', '').replace(')', '')}.nc")
    ckpt = Path(args.checkpoint) if args.checkpoint else out.with_suffix(".h5")
    post = sample_posterior(meas, model, seed=args.seed, max_steps=args.max_steps, checkpoint=ckpt,
                            resume=args.resume, progress=False if args.quiet else None,
                            likelihood=args.likelihood, nu=args.nu, settings=SamplerSettings(),
                            overwrite=args.overwrite)
    print(f"model {model.label}: {post.n_steps} steps x {post.draws.shape[0]} walkers, "
          f"tau_max {max(post.tau):.0f} steps, burn {post.burn}, thin {post.thin}, "
          f"acceptance {post.acceptance:.2f}, {post.wall_time:.1f} s")
    print(("CONVERGED: " if post.converged else "NOT CONVERGED: ") + post.message)
    rows = [(r["name"], f"{r['median']:.5g}", f"{r['q05']:.5g}", f"{r['q95']:.5g}", f"{r['ess']:.0f}",
             f"{r['tau']:.0f}", r["unit"]) for r in post.summary_rows()]
    print_table(rows, ("parameter", "median", "5 %", "95 %", "ESS", "tau", "unit"))
    post.save(out)
    print(f"wrote {out} (ArviZ DataTree; checkpoint {ckpt})")
    if args.json:
        write_json(args.json, post.to_json_dict())
        print(f"wrote {args.json}")
    if args.plot:
        from ..plotting.posterior import plot_bode_bands, plot_corner

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        stem = model.label.replace("(", "").replace(")", "")
        for name, fig in (("corner", plot_corner(post)), ("bode", plot_bode_bands(post))):
            path = folder / f"posterior_{stem}_{name}.png"
            fig.savefig(path, dpi=100)
            print(f"wrote {path}")
    return 0 if post.converged else 1
