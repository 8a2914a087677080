"""Bundled datasets."""

from __future__ import annotations

from pathlib import Path

from .data import Measurement

__all__ = ["paper_bench_path", "load_paper_bench", "PAPER_BENCH_SEED", "PAPER_BENCH_NOISE"]

PAPER_BENCH_SEED = 20261122
PAPER_BENCH_NOISE = 0.002


def paper_bench_path() -> Path:
    """The bundled default dataset (simulated from the paper's Table 5; see ``data/README.md``)."""
    return Path(__file__).resolve().parent / "data" / "paper_bench.csv"


def load_paper_bench() -> Measurement:
    from .io import read_measurement

    return read_measurement(paper_bench_path())
