"""Robust shunt speed (issue 12, acceptance 5: 1000 posterior draws processed in < 60 s).

    .venv/bin/python benchmarks/bench_robust_shunt.py [--draws 1000] [--reference 10]
    .venv/bin/python benchmarks/run.py -k robust_shunt        # through the common runner

The draws are a Laplace approximation of the NL(5) posterior of the bundled data (Gaussian in
sampling space around the least-squares fit, with its covariance; seeded): the same size and
spread as an emcee posterior without the minutes of sampling. One call of
``robust_shunt_1000_draws`` is everything ``bayes-emt shunt --posterior`` computes for 1000 draws:
the threshold cache, every draw's H∞ optimum, the nominal shunt on every draw, the robust choice on
the design half and the report on the held-back half. ``shunt_seconds_per_draw`` is its time divided
by the number of draws (:data:`DERIVED`); the standalone run also times :func:`design_rc_shunt`
on a few draws in the same process and prints the speed-up of the batch over calling it per draw,
a ratio that stays meaningful on a busy machine where absolute times do not.

Plugging in: the module follows ``benchmarks/run.py``'s contract (``BENCHMARKS``, ``setup()``,
``TARGETS``); :data:`DERIVED` maps a derived figure to ``(benchmark, factor)`` for a runner that
reports per-unit figures.
"""

import argparse
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayes_emt import build_model  # noqa: E402
from bayes_emt.estimation.fitting import fit_admittance  # noqa: E402
from bayes_emt.io.datasets import load_paper_bench  # noqa: E402
from bayes_emt.shunt import design_rc_shunt  # noqa: E402
from bayes_emt.shunt.batch.design import design_draws  # noqa: E402
from bayes_emt.shunt.batch.plant import BatchPlant  # noqa: E402
from bayes_emt.shunt.draws import DrawGroup  # noqa: E402
from bayes_emt.shunt.robust import design_robust_shunt  # noqa: E402

N_DRAWS = 1000
_STATE: dict = {}


def laplace_draws(n: int = N_DRAWS, seed: int = 0):
    """``(model, thetas (n, k))``: the NL(5) least-squares fit of the bundled data and draws from
    its Gaussian (Laplace) approximation in sampling space."""
    model = build_model("NL")
    fit = fit_admittance(load_paper_bench(), model)
    rng = np.random.default_rng(seed)
    z = rng.multivariate_normal(fit.z, fit.cov_z, size=n)
    return model, model.params.from_z(z)


def setup() -> None:
    if "model" not in _STATE:
        _STATE["model"], _STATE["thetas"] = laplace_draws()


def _robust():
    return design_robust_shunt([DrawGroup(_STATE["model"], _STATE["thetas"], "laplace")])


def _per_draw():
    m, th = _STATE["model"], _STATE["thetas"]
    d = design_rc_shunt(m, np.median(th, axis=0))
    return design_draws(BatchPlant(m, th), (d.Rs, d.Cs))


def _reference_10():
    m, th = _STATE["model"], _STATE["thetas"]
    return [design_rc_shunt(m, t) for t in th[:10]]


BENCHMARKS = {"robust_shunt_1000_draws": _robust, "per_draw_optima_1000_draws": _per_draw,
              "design_rc_shunt_10_draws": _reference_10}
TARGETS = {"robust_shunt_1000_draws": 60.0}
DERIVED = {"shunt_seconds_per_draw": ("robust_shunt_1000_draws", 1.0 / N_DRAWS)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--draws", type=int, default=N_DRAWS)
    ap.add_argument("--reference", type=int, default=10, help="draws designed one by one for the ratio")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    model, thetas = laplace_draws(args.draws)
    print(f"Laplace draws of the NL(5) fit: {args.draws} ({time.perf_counter() - t:.1f} s to fit and draw)")
    t = time.perf_counter()
    res = design_robust_shunt([DrawGroup(model, thetas, "laplace")])
    total = time.perf_counter() - t
    t = time.perf_counter()
    for th in thetas[: args.reference]:
        design_rc_shunt(model, th)
    per_call = (time.perf_counter() - t) / args.reference
    rep = res.to_json_dict()
    print(f"robust shunt over {args.draws} draws: {total:.1f} s (target < 60 s for 1000), "
          f"shunt_seconds_per_draw {total / args.draws:.4f} s")
    print("  breakdown: " + ", ".join(f"{k} {v:.1f} s" for k, v in rep["timing"].items()))
    print(f"design_rc_shunt one draw at a time: {per_call:.3f} s per draw; the batch's per-draw optima took "
          f"{rep['timing']['per_draw_designs_s'] / args.draws * 1e3:.2f} ms per draw: "
          f"{per_call * args.draws / rep['timing']['per_draw_designs_s']:.0f}x faster; the whole pipeline "
          f"{per_call * args.draws / total:.0f}x faster than the per-draw designs alone")
    print(f"robust Rs {res.robust.Rs:.5f} ohm, Cs {res.robust.Cs:.5g} F; nominal Rs {res.nominal.Rs:.5f} ohm")
    return 0 if total * N_DRAWS / args.draws < TARGETS["robust_shunt_1000_draws"] else 1


if __name__ == "__main__":
    sys.exit(main())
