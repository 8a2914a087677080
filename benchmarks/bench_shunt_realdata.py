"""``shunt --posterior`` on posteriors sampled from real recordings (issue 32).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_shunt_realdata.py DIR [--full] [--draws 1000]

DIR holds ``sample --out`` netCDF files (e.g. ``<recording>.UD.nc`` and
``<recording>.diag.nc``, the latter with the model ``diagnose`` named); they are not in the repository
(the recordings in ../shared/realdata have no licence to copy). For each file, on one thread, CPU
seconds (``time.process_time``) beside wall seconds and the load average:

* ``per_draw``: 1000 mixture draws' plants (:class:`~bayes_emt.shunt.batch.plant.BatchPlant`) and
  each draw's own H∞-optimal shunt (:func:`~bayes_emt.shunt.batch.design.design_draws`, warm-started
  from the posterior median's design), with the number of draws that fell back to the one-at-a-time
  design;
* ``--full``: the whole :func:`~bayes_emt.shunt.robust_shunt` call (``shunt --posterior`` after
  reading the file, default ``epsilon="auto"``), its stage timings, P(unstable) of the robust shunt
  against the ``epsilon`` chosen and the bound shown on the draws the choice never saw.

Writes one JSON line per file on stdout.
"""

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayes_emt.api import read_posterior  # noqa: E402
from bayes_emt.shunt import design_rc_shunt, robust_shunt  # noqa: E402
from bayes_emt.shunt.batch.design import design_draws  # noqa: E402
from bayes_emt.shunt.batch.plant import BatchPlant  # noqa: E402
from bayes_emt.shunt.draws import sample_mixture  # noqa: E402


def per_draw(post, n_draws: int, seed: int = 0) -> dict:
    groups, _ = sample_mixture([(post.model, post.theta(), post.model.label)], [1.0], n_draws, seed=seed)
    g = groups[0]
    c0, w0 = time.process_time(), time.perf_counter()
    med = np.median(g.thetas, axis=0)
    nom = design_rc_shunt(post.model, med)
    c1 = time.process_time()
    bp = BatchPlant(post.model, g.thetas)
    opt = design_draws(bp, (nom.Rs, nom.Cs), R0_start=nom.R0)
    c2 = time.process_time()
    return {"nominal_cpu_s": c1 - c0, "per_draw_cpu_s": c2 - c1, "wall_s": time.perf_counter() - w0,
            "n_fallback": int(opt.fallback.sum()), "newton_iterations": opt.iterations,
            "nominal": {"Rs": nom.Rs, "Cs": nom.Cs, "attenuation_db": nom.attenuation_db,
                        "optimum": nom.optimum, "warnings": [w["code"] for w in nom.warnings]},
            "R0_q05_q95": np.quantile(g.thetas[:, post.model.params.index("R0")], [0.05, 0.95]).tolist()}


def full(post, n_draws: int, epsilon="auto") -> dict:
    """The whole robust_shunt call: CPU and wall seconds, the P(unstable) bound, Qts and the peak
    reduction (median and 90 % interval over the held-back draws)."""
    c0, w0 = time.process_time(), time.perf_counter()
    res = robust_shunt(post, n_draws=n_draws, seed=0, epsilon=epsilon)
    rob = res.report["robust"]
    return {"full_cpu_s": time.process_time() - c0, "full_wall_s": time.perf_counter() - w0,
            "timing_wall_s": res.report["timing"], "n_fallback": res.report["per_draw"]["n_fallback"],
            "robust_p_unstable": rob["p_unstable"], "robust_p_unstable_ci": rob["p_unstable_ci"],
            "epsilon": res.report["epsilon"], "epsilon_choice": res.report["epsilon_choice"],
            "robust_Rs": rob["Rs"], "robust_Cs": rob["Cs"],
            "robust_p_unstable_bound": {k: rob["p_unstable_bound"][k] for k in ("shown", "draws_needed")}
            | {"per_model": rob["p_unstable_bound"]["per_model"]},
            "driver_qts": res.report["driver"]["qts"], "robust_qts_damped": rob["qts_damped"],
            "robust_peak_reduction_db": rob["resonance_peak_reduction_db"],
            "nominal_qts_damped": res.report["nominal"]["qts_damped"],
            "nominal_peak_reduction_db": res.report["nominal"]["resonance_peak_reduction_db"],
            "warnings": [w[:160] for w in res.warnings]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder")
    ap.add_argument("--draws", type=int, default=1000)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--skip-per-draw", action="store_true", help="with --full: the whole call only")
    a = ap.parse_args(argv)
    for path in sorted(Path(a.folder).glob("*.nc")):
        if a.only and not any(o in path.name for o in a.only):
            continue
        post = read_posterior(path)
        rec = {"file": path.name, "model": post.model.label, "draws": a.draws,
               "load_average_1min": os.getloadavg()[0]}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                if not (a.full and a.skip_per_draw):
                    rec.update(per_draw(post, a.draws))
                if a.full:
                    rec.update(full(post, a.draws))
            except Exception as exc:  # noqa: BLE001 - a benchmark records what failed and goes on
                rec["error"] = f"{type(exc).__name__}: {exc}"
        print(json.dumps(rec, default=float), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
