"""Regenerate the bundled concealed-effect recording ``bayes_emt/data/concealed_bench.csv``.

Simulated, not measured: the paper's device (NL, n = 5 rings, N = 480 turns, Table 5 parameters,
SPEC.md §5) with a **second mechanical mode** in series that the paper's models do not contain
(SPEC §7 ``second_resonance``, ``Z ← Z + φ2² s / (s² + 2 ζ2 ω2 s + ω2²)``): a fixture mode at
ω2 = 2500 rad/s (≈ 398 Hz), ζ2 = 0.02, φ2 = 3.87 N/(A kg^½). Its real-part peak
φ2² / (2 ζ2 ω2) ≈ 0.15 Ω is a few per cent of |Z| there: hidden in a Bode plot at a glance,
far above the noise (0.2 % relative per real/imaginary part). Same grid as ``paper_bench.csv``
(2000 log-spaced angular frequencies over 1e1..1e5 rad/s), seed 20261123.

``bayes-emt demo`` diagnoses this recording: the diagnosis is not told about the mode.

    .venv/bin/python data/make_concealed_bench.py
"""

from bayes_emt import build_model, simulate
from bayes_emt.io import write_measurement
from bayes_emt.io.datasets import (
    CONCEALED_BENCH_EFFECT,
    CONCEALED_BENCH_NOISE,
    CONCEALED_BENCH_SEED,
    concealed_bench_path,
)
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES


def main() -> None:
    model = parse_model_spec("NL+second_resonance", rings=5)
    assert build_model("NL", rings=5).ndim + 3 == model.ndim
    truth = {**PAPER_TABLES["NL"], **CONCEALED_BENCH_EFFECT}
    meas = simulate(model, truth, noise=CONCEALED_BENCH_NOISE, seed=CONCEALED_BENCH_SEED,
                    source="concealed_bench (simulated: Table 5 NL(5) + a hidden second mode)")
    write_measurement(meas, concealed_bench_path())
    print(f"wrote {concealed_bench_path()}")


if __name__ == "__main__":
    main()
