"""``bayes-emt sample DATA --model M``: the posterior by emcee, started from the least-squares fit.

Prints the credible-interval table (median, 5 %, 95 %, ESS, τ, unit), writes the ArviZ
``DataTree`` (netCDF), optionally a JSON summary and plots. With ``--loaded FILE --delta-m KG``
both recordings of an added-mass pair are sampled jointly (shared m, c, k, φ, R0 and coil; each
run its own noise scales): the table then starts with the physical m [kg], c [N s/m], k [N/m]
and φ [N/A]. Exit status 0 when the run
converged, 1 when the step budget ran out first (the result is then flagged, not trusted),
2 on a user error. Every output path is checked before any work (:mod:`bayes_emt.cli.paths`); the
JSON summary carries the least-squares fit's ``warnings`` (the start of the walkers), plus
``not_converged`` when the budget ran out.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..paths import check_outputs
from ._common import (
    add_data_args,
    add_exclude_band_arg,
    add_model_args,
    add_output_args,
    add_parser,
    add_re_option,
    detail,
    int_at_least,
    meter_of,
    model_from_args,
    note,
    print_warnings,
    quantity,
    seed,
)

EXAMPLES = """\
  bayes-emt sample speaker.zma --model UD --out ud.nc --json ud.json --plot figures/
  bayes-emt sample speaker.zma --model UD --out ud.nc --resume          (continue a stopped run)
  bayes-emt sample speaker.zma --model NL --likelihood student --nu sample --max-steps 50000
  bayes-emt sample free.zma --model UD --loaded with_100g.zma --delta-m 0.100 --out pair.nc
  bayes-emt sample speaker.zma --model UD --priors priors.toml --verbose
"""

DEFAULT_NU = 4.0


def _nu(text: str) -> float | str:
    if text.lower() in ("sample", "sampled", "free"):
        return "sample"
    try:
        val = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number or 'sample', got {text!r}") from None
    if not (val > 0 and math.isfinite(val)):
        raise argparse.ArgumentTypeError(f"degrees of freedom must be positive, got {text!r}")
    return val


def register(sub) -> None:
    p = add_parser(sub, "sample", help="posterior by emcee with convergence diagnostics (DataTree out)",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("data", help="measurement file")
    add_model_args(p, required=False)
    add_data_args(p)
    add_exclude_band_arg(p)
    p.add_argument("--out", default=None,
                   help="netCDF DataTree output (default: DATA stem + _MODEL.nc in the current folder)")
    p.add_argument("--checkpoint", default=None,
                   help="HDF5 checkpoint, written every step (default: the --out path with .h5)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in the checkpoint (same data, model, priors and seed)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing checkpoint")
    p.add_argument("--seed", type=seed, default=0, help="random seed, a non-negative integer (default 0)")
    p.add_argument("--max-steps", type=int_at_least(1), default=20000, help="step budget (default 20000)")
    p.add_argument("--likelihood", choices=["gaussian", "student"], default="gaussian",
                   help="noise distribution of the real and imaginary parts (student: robust to outliers)")
    p.add_argument("--noise", choices=["correlated", "white"], default=None,
                   help="white (default; the only choice with --likelihood student): independent errors, "
                        "the posterior if the model were exact; correlated: instrument noise plus a model "
                        "discrepancy correlated over log-frequency (slower; the docs' intervals page says "
                        "what it does on real drivers)")
    p.add_argument("--nu", type=_nu, default=None,
                   help="Student-t degrees of freedom, or 'sample' to sample it (default 4; "
                        "with --likelihood student only)")
    p.add_argument("--priors", default=None, metavar="FILE",
                   help="TOML/JSON prior overrides, e.g. [R0] dist = \"lognormal\" median = 2.6 "
                        "sigma_log = 0.05")
    p.add_argument("--loaded", default=None, metavar="FILE",
                   help="second recording of an added-mass pair (DATA is then the base run): sample both "
                        "jointly for the physical m, c, k, phi_raw")
    p.add_argument("--delta-m", type=quantity("mass", sign="nonzero"), default=None, metavar="MASS",
                   help="mass added in the --loaded recording: kg, or with a unit (100g); negative: removed")
    add_re_option(p)
    p.add_argument("--json", default=None, metavar="OUT", help="write the summary as JSON here")
    p.add_argument("--plot", default=None, metavar="DIR", help="write corner, Bode-band and trace PNGs here")
    add_output_args(p, progress=True)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...added_mass.fit import PHYSICAL_NAMES
    from ...errors import DataFormatError
    from ...estimation.fitting import fit_admittance
    from ...inference.likelihood import noise_param_set
    from ...inference.priors import apply_priors
    from ...inference.sampling import check_checkpoint
    from ...io import read_measurement
    from ...io.priorfile import read_prior_file
    from ...params import prior_from_dict

    if (args.loaded is None) != (args.delta_m is None):
        raise ValueError("--loaded and --delta-m go together: the added-mass pair needs the second "
                         "recording and the mass added to it [kg]")
    if args.nu is not None and args.likelihood != "student":
        raise ValueError(f"--nu {args.nu} applies to --likelihood student only (the Gaussian likelihood "
                         "has no degrees of freedom); add --likelihood student or drop --nu")
    if args.delta_m is not None:  # 8.017 meaning grams is refused before any sampling
        from ...thiele_small.plausibility import check_inputs

        check_inputs(deltas=[args.delta_m])
    nu = None if args.nu == "sample" else DEFAULT_NU if args.nu is None else args.nu
    if args.loaded is not None and nu is None:
        raise ValueError("--nu sample is not offered with --loaded; give a number of degrees of freedom")
    kind = args.noise or "white"
    if args.model is None:  # the model the evidence supports for this recording
        from ...thiele_small.compute import evidence_supported_model

        opts0 = {"freq_unit": args.freq_unit, "phase_unit": args.phase_unit, "quantity": args.quantity}
        meas0 = read_measurement(args.data, **opts0).select(args.omega_min, args.omega_max)
        model, probs = evidence_supported_model(meas0.exclude_bands(args.exclude_band), noise=kind)
        ws = ", ".join(f"{m} {p:.2g}" for m, p in sorted(probs.items(), key=lambda kv: -kv[1]))
        print(f"model {model.label}: the most probable of the candidates (Laplace evidence, {kind} noise; "
              f"probabilities {ws}); --model to choose another")
    else:
        model = model_from_args(args)
    stem = model.label.replace("(", "").replace(")", "") + ("_pair" if args.loaded is not None else "")
    out = Path(args.out or f"{Path(args.data).stem}_{stem}.nc")
    ckpt = Path(args.checkpoint) if args.checkpoint else out.with_suffix(".h5")
    plots = ("corner", "trace") + (("bode",) if args.loaded is None else ())
    check_outputs([("--out", out), ("--checkpoint", ckpt), ("--json", args.json)],
                  [("DATA", args.data), ("--loaded", args.loaded), ("--priors", args.priors)],
                  folders=[("--plot", args.plot, [f"posterior_{stem}_{n}.png" for n in plots])])
    check_checkpoint(ckpt, resume=args.resume, overwrite=args.overwrite)
    opts = {"freq_unit": args.freq_unit, "phase_unit": args.phase_unit, "quantity": args.quantity,
            "magnitude_only": args.magnitude_only}
    meas = read_measurement(args.data, **opts).select(args.omega_min, args.omega_max)
    meas = meas.exclude_bands(args.exclude_band)
    loaded = None if args.loaded is None else read_measurement(args.loaded, **opts).select(args.omega_min,
                                                                                          args.omega_max)
    loaded = None if loaded is None else loaded.exclude_bands(args.exclude_band)
    if kind == "correlated" and args.likelihood == "student":
        raise ValueError("--noise correlated needs the gaussian likelihood; use --noise white with "
                         "--likelihood student")
    noise = noise_param_set(args.likelihood, nu, kind)
    physical = None
    if args.priors:
        overrides = read_prior_file(args.priors)
        if loaded is not None:
            from ...added_mass.fit import JointModel

            phys = {}
            for name in [n for n in PHYSICAL_NAMES if n in overrides]:
                try:
                    phys[name] = prior_from_dict(overrides.pop(name), where=f"{args.priors}: {name}")
                except (ValueError, TypeError) as exc:
                    msg = str(exc)
                    raise DataFormatError(msg if msg.startswith(f"{args.priors}: {name}")
                                          else f"{args.priors}: {name}: {msg}") from None
            physical = JointModel(model, args.delta_m).physical.with_priors(phys)
        model, noise = apply_priors(model, overrides, noise_params=noise, where=str(args.priors))
    meter = meter_of(args)
    if meter is not None and loaded is not None and meter.cut:
        from ...estimation.meter import Meter

        note(args, "--re with --loaded: the added-mass pair takes the reading as a prior on R0 "
                   "(--re-mode prior)")
        meter = Meter(meter.value, meter.sd, "prior")
    if meter is not None:  # the cut samples with R0 held at the reading (meter.prior()), then moves the draws
        model = model.with_priors({"R0": meter.prior()}, where="--re")
    # the least-squares fit under these priors: the walkers' start, and the warnings it carries
    fit, warns = None, []
    if loaded is None:
        fit = fit_admittance(meas, model, re=meter)
        warns = list(fit.warnings)
    else:
        for label, m in (("base run", meas), ("loaded run", loaded)):
            warns += [{"code": w["code"], "message": f"{label}: {w['message']}"}
                      for w in fit_admittance(m, model).warnings]
    for spec in list(model.params) + list(noise):
        detail(args, f"prior {spec.name:10s} {spec.prior.to_dict()} [{spec.unit}]")
    detail(args, f"checkpoint {ckpt}, seed {args.seed}, budget {args.max_steps} steps")
    common = {"seed": args.seed, "max_steps": args.max_steps, "checkpoint": ckpt, "resume": args.resume,
              "overwrite": args.overwrite, "progress": False if args.quiet else None,
              "likelihood": args.likelihood, "nu": nu, "noise_params": noise, "noise": kind}
    from ...errors import Interrupted
    from ...inference.sampling import interruption

    try:
        post = _sample(args, meas, loaded, model, fit, physical, common, meter)
        return _outputs(args, post, warns, out, ckpt, stem, plots)
    except KeyboardInterrupt as exc:  # a bare signal outside the sampler's steps: say what is kept
        if isinstance(exc, Interrupted) and exc.reported:
            raise
        raise interruption(exc, ckpt) from None


def _sample(args, meas, loaded, model, fit, physical, common, meter=None):
    """The posterior of one recording (under the ohmmeter reading ``meter``, if any), or the joint
    one of an added-mass pair."""
    from ...inference.sampling import sample_posterior

    if loaded is None:
        if meter is not None:
            from ...inference.meter_cut import sample_with_meter

            post = sample_with_meter(meas, model, meter, fit=fit, **common)
        else:
            post = sample_posterior(meas, model, fit=fit, **common)
        print(f"model {model.label}, {meas.n_points} points, likelihood {post.likelihood.describe()}")
    else:
        from ...added_mass.posterior import sample_added_mass

        post = sample_added_mass(meas, loaded, args.delta_m, model, physical_params=physical, **common)
        print(f"added-mass pair {args.data} + {args.loaded} (added {args.delta_m:+g} kg), "
              f"model {model.label}, "
              f"{meas.n_points} + {loaded.n_points} points, likelihood {post.likelihood.describe()}")
    return post


def _outputs(args, post, warns, out, ckpt, stem, plots) -> int:
    """Print, save and plot a finished posterior (exit code: 0 converged, 1 not)."""
    from ...io.paramfile import write_json

    print(f"{post.n_steps} steps x {post.n_walkers} walkers, tau_max {max(post.tau):.0f} steps, "
          f"burn {post.burn}, thin {post.thin}, {post.draws.shape[0] * post.draws.shape[1]} draws kept, "
          f"acceptance {post.acceptance:.2f}, {post.wall_time:.1f} s")
    print(("CONVERGED: " if post.converged else "NOT CONVERGED: ") + post.message)
    for v in post.history:
        detail(args, f"check at step {v['step']}: tau_max {v['tau_max']:.0f}, "
                     f"chain {v['n_over_tau']:.1f} tau, tau change {v['tau_change']:.3g}, "
                     f"min ESS {v['ess_min']:.0f}")
    print(post.summary(), end="")
    from ...thiele_small import from_posterior

    ts_lines = from_posterior(post).summary().splitlines()
    print("\n" + "\n".join(ln for ln in ts_lines if not ln.startswith("warn")))
    from ...inference.sampling import conflict_message, prior_conflicts

    conflicts = prior_conflicts(post.likelihood.params, post.flat())
    if conflicts:
        warns.append({"code": "prior_conflict", "message": conflict_message(conflicts),
                      "parameters": [c["name"] for c in conflicts]})
    if not post.converged:
        warns.append({"code": "not_converged", "message": post.message})
    print_warnings(warns)
    post.save(out)
    note(args, f"wrote {out} (ArviZ DataTree; checkpoint {ckpt})")
    if args.json:
        # the kind lets a report find it whatever its name
        write_json(args.json, {"kind": "posterior_summary", **post.to_json_dict(), "warnings": warns})
        note(args, f"wrote {args.json}")
    if args.plot:
        from ...plotting import save_figure
        from ...plotting.posterior import plot_bode_bands, plot_corner, plot_trace

        folder = Path(args.plot)
        folder.mkdir(parents=True, exist_ok=True)
        makers = {"corner": plot_corner, "trace": plot_trace, "bode": plot_bode_bands}
        for name in plots:
            make = makers[name]
            path = folder / f"posterior_{stem}_{name}.png"
            save_figure(make(post), path, dpi=100)
            note(args, f"wrote {path}")
    from ..exitcodes import status

    return status(not post.converged)
