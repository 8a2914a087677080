"""``thiele_small`` with two added masses, posterior included (issue 22, acceptance 7).

A simulated driver of known T/S (:func:`bayes_emt.thiele_small.simulate.simulate_driver`, the
default 6.5" woofer, semi-inductance coil, model ``I+semi_inductance``) recorded in free air and
with 10 g and 20 g added, 2000 log-spaced points each over 10 Hz–2 kHz, 0.5 % noise; the time is
the whole call: three separate fits, the joint fit and the joint posterior to the T/S stopping
rule (:func:`bayes_emt.thiele_small.compute._ts_sampler`), no model spread. Run on one core:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        .venv/bin/python benchmarks/run.py --no-compare -k ts

Target: 30 s (wall). The details add the process CPU time and the machine's load average: on a
shared machine the wall time grows with the load, the CPU time does not. No ``BENCHMARKS`` entry
(the baseline revision has no ``thiele_small``): the figure of merit comes from :func:`measure` on
this tree only.
"""

import os
import time
import warnings

from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver

SPEC = "I+semi_inductance"


def measure() -> dict:
    sim = simulate_driver(SPEC, seed=1, n_points=2000)
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = thiele_small(sim.free, SPEC, loaded=list(sim.loaded), sd=sim.sd, seed=1, models_for_spread=[])
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    inside = sum(p["ci90"][0] <= sim.truth[k] <= p["ci90"][1] for k, p in r.parameters.items())
    return {"results": {"ts_two_added_masses_posterior_s": seconds},
            "targets": {"ts_two_added_masses_posterior_s": ["<=", 30.0]},
            "details": {"ts_two_added_masses": {"points_per_recording": 2000, "model": SPEC,
                                                "cpu_s": cpu, "load_average_1min": os.getloadavg()[0],
                                                "parameters_inside_ci90": f"{inside}/{len(r.parameters)}",
                                                "warnings": [w["code"] for w in r.warnings]}}}
