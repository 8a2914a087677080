"""``bayes-emt demo``: the main job on the bundled data, end to end.

Fits the six models, chooses the NL ring count by Hankel singular values, designs the optimal RC
shunt per model and evaluates each on the best model, then samples the posterior of NL(5) and
writes the DataTree, JSON summaries and plots to ``--out`` (checked before any work, and never over
the ``--data`` file). Each fit's warnings (:mod:`bayes_emt.estimation.adequacy`) are printed and go
into ``fits.json``; the NL fit's, which start the walkers, into ``posterior.json`` too.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

from ..paths import check_outputs
from ._common import int_at_least, print_table, print_warnings, seed

#: what the demo writes into its --out folder
OUTPUTS = ("fits.json", "hankel.json", "shunts.json", "posterior.h5", "posterior.nc", "posterior.json",
           "posterior_corner.png", "posterior_bode.png")


def register(sub) -> None:
    p = sub.add_parser("demo", help="the whole pipeline on the bundled data (simulated from Table 5)")
    p.add_argument("--data", default=None, help="measurement file instead of the bundled dataset")
    p.add_argument("--out", default="bayes_emt_demo", help="output folder (default ./bayes_emt_demo)")
    p.add_argument("--seed", type=seed, default=0, help="sampler seed, a non-negative integer (default 0)")
    p.add_argument("--max-steps", type=int_at_least(1), default=20000,
                   help="sampler step budget (default 20000)")
    p.add_argument("--no-sample", action="store_true", help="skip the posterior (deterministic part only)")
    p.set_defaults(func=run)


def _section(title: str) -> None:
    print(f"\n== {title} " + "=" * max(0, 70 - len(title)))


def run(args) -> int:
    from ...estimation.fitting import fit_admittance
    from ...estimation.hankel import select_rings
    from ...io import read_measurement
    from ...io.datasets import load_paper_bench
    from ...io.paramfile import write_json
    from ...models import MODEL_NAMES, build_model
    from ...shunt import design_rc_shunt, evaluate_rc_shunt

    out = Path(args.out)
    check_outputs(inputs=[("--data", args.data)], folders=[("--out", out, OUTPUTS)])
    out.mkdir(parents=True, exist_ok=True)
    meas = read_measurement(args.data) if args.data else load_paper_bench()
    _section("data")
    print(f"{meas.source}: {meas.n_points} points, {meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz "
          f"({meas.omega[0]:.4g}..{meas.omega[-1]:.4g} rad/s)")
    truth = meas.meta.get("written_meta", {}).get("truth")
    if truth:
        print("simulated from the paper's Table 5 (NL, n = 5) with 0.2 % noise: the truth is known")

    _section("deterministic fits: automatic initial estimate + two-step least squares")
    fits, rows, t_all = {}, [], time.perf_counter()
    for name in MODEL_NAMES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_admittance(meas, build_model(name))
        fits[name] = fit
        p = fit.parameters
        rows.append((fit.model.label, f"{fit.rms_rel_residual:.4f}", f"{p['zeta']:.4g}", f"{p['omega0']:.4g}",
                     f"{p['phi']:.4g}", f"{p['R0']:.4g}", f"{fit.info['seconds']:.2f}"))
    print_table(rows, ("model", "rms rel. resid.", "zeta [1]", "omega0 [rad/s]", "phi [N/A/kg^.5]",
                       "R0 [ohm]", "time [s]"))
    print(f"all six fits: {time.perf_counter() - t_all:.1f} s")
    for fit in fits.values():
        if fit.warnings:
            print(f"{fit.model.label}:")
            print_warnings(fit.warnings, indent="  ")
    write_json(out / "fits.json", {k: f.to_json_dict() for k, f in fits.items()})
    best = min(fits, key=lambda k: fits[k].rms_rel_residual)
    if truth:
        nl = fits["NL"]
        se = nl.stderr
        rows = [(n, f"{truth[n]:.4g}", f"{v:.4g}", f"{se[n]:.2g}", f"{(v - truth[n]) / se[n]:+.1f}")
                for n, v in nl.parameters.items()]
        print("\nNL(5) against the truth (Table 5):")
        print_table(rows, ("parameter", "truth", "estimate", "std error", "z"))

    _section("NL ring count by Hankel singular values (fit with 7 rings)")
    rc = select_rings(meas, 7)
    print("HSV [S]: " + ", ".join(f"{h:.3g}" for h in rc.hsv))
    print(f"chosen: n = {rc.rings} rings")
    write_json(out / "hankel.json", rc.to_json_dict())

    _section(f"optimal RC shunt per model; each evaluated on the best-fitting model ({best})")
    rows, designs = [], {}
    ref = fits[best]
    for name in MODEL_NAMES:
        d = design_rc_shunt(fits[name].model, fits[name].theta)
        ev = evaluate_rc_shunt(ref.model, ref.theta, d.Rs, d.Cs)
        designs[name] = {**d.to_json_dict(), f"evaluated_on_{best}": ev.to_json_dict()}
        rows.append((fits[name].model.label, f"{d.Rs:.4f}", f"{d.Cs:.4g}", f"{d.attenuation_db:.2f}",
                     f"{ev.attenuation_db:.2f}" if ev.stable else "UNSTABLE", f"{ev.stability_margin:.3f}"))
    print_table(rows, ("design model", "Rs [ohm]", "Cs [F]", "own model [dB]", f"on {best} [dB]",
                       f"margin on {best} [ohm]"))
    print("(margin: how far Rs may fall before the loop is unstable; negative = unstable already)")
    write_json(out / "shunts.json", designs)

    if not args.no_sample:
        from ...inference.sampling import sample_posterior
        from ...plotting import save_figure
        from ...plotting.posterior import plot_bode_bands, plot_corner

        model = build_model("NL", rings=rc.rings)
        _section(f"posterior of {model.label} by emcee (seed {args.seed})")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fits["NL"] if rc.rings == 5 else fit_admittance(meas, model)
        post = sample_posterior(meas, model, fit=fit, seed=args.seed, max_steps=args.max_steps,
                                checkpoint=out / "posterior.h5", overwrite=True)
        print(("converged" if post.converged else "NOT CONVERGED: " + post.message)
              + f": {post.n_steps} steps x {post.draws.shape[0]} walkers, tau_max {max(post.tau):.0f}, "
              f"{post.wall_time:.0f} s")
        rows = []
        for r in post.summary_rows():
            cover = ""
            if truth and r["name"] in truth:
                cover = "yes" if r["q05"] <= truth[r["name"]] <= r["q95"] else "no"
            rows.append((r["name"], f"{r['median']:.4g}", f"{r['q05']:.4g}", f"{r['q95']:.4g}",
                         f"{r['ess']:.0f}", f"{r['tau']:.0f}", r["unit"], cover))
        print_table(rows, ("parameter", "median", "5 %", "95 %", "ESS", "tau [steps]", "unit",
                           "truth in 90 %"))
        post.save(out / "posterior.nc")
        warns = list(fit.warnings)
        if not post.converged:
            warns.append({"code": "not_converged", "message": post.message})
        write_json(out / "posterior.json", {**post.to_json_dict(), "warnings": warns})
        for name, fig in (("corner", plot_corner(post, names=list(post.names[:4]) + ["R5", "sigma_rel"])),
                          ("bode", plot_bode_bands(post))):
            save_figure(fig, out / f"posterior_{name}.png", dpi=100)
    _section("outputs")
    for f in sorted(out.iterdir()):
        print(f"  {f.resolve()}  ({f.stat().st_size / 1024:.0f} kB)")
    if not args.no_sample and not post.converged:
        print("the posterior did NOT converge within the budget (see above): exit code 1")
        return 1
    return 0
