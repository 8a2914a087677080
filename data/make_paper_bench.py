"""Regenerate the bundled default dataset ``bayes_emt/data/paper_bench.csv`` (deterministic).

Simulated, not measured: model NL with n = 5 rings and N = 480 turns at the parameters of the
source paper's Table 5, 2000 log-spaced angular frequencies over 1e1..1e5 rad/s,
relative complex Gaussian noise of 0.2 % per real/imaginary part, seed 20261122.

    .venv/bin/python data/make_paper_bench.py
"""

from bayes_emt import build_model, simulate
from bayes_emt.io import write_measurement
from bayes_emt.io.datasets import PAPER_BENCH_NOISE, PAPER_BENCH_SEED, paper_bench_path
from bayes_emt.reference import PAPER_TABLES


def main() -> None:
    meas = simulate(build_model("NL", rings=5), PAPER_TABLES["NL"], noise=PAPER_BENCH_NOISE,
                    seed=PAPER_BENCH_SEED, source="paper_bench (simulated from the source paper's Table 5)")
    write_measurement(meas, paper_bench_path())
    print(f"wrote {paper_bench_path()}")


if __name__ == "__main__":
    main()
