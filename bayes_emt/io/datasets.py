"""Bundled datasets.

``paper_bench.csv`` ships inside the package (``bayes_emt/data/``, package data) so an installed
``bayes-emt demo`` finds it; ``data/README.md`` in the source tree documents it and
``data/make_paper_bench.py`` regenerates it (bit for bit on one machine and library build; to
within about 1e-15 relative on another processor, whose SIMD kernels round differently).
"""

from __future__ import annotations

import math
from pathlib import Path

from ..measurement import Measurement

__all__ = ["paper_bench_path", "load_paper_bench", "PAPER_BENCH_SEED", "PAPER_BENCH_NOISE",
           "concealed_bench_path", "load_concealed_bench", "CONCEALED_BENCH_SEED", "CONCEALED_BENCH_NOISE",
           "CONCEALED_BENCH_EFFECT", "REALDATA_FILES", "load_realdata"]

PAPER_BENCH_SEED = 20261122
PAPER_BENCH_NOISE = 0.002
CONCEALED_BENCH_SEED = 20261123
CONCEALED_BENCH_NOISE = 0.002
#: The effect concealed in ``concealed_bench.csv`` (the catalogue's ``second_resonance``): a fixture mode at
#: omega2 = 2500 rad/s (398 Hz), damping ratio 0.02, coupling 3.87 N/(A kg^0.5) (peak ~0.15 ohm).
CONCEALED_BENCH_EFFECT = {"zeta2": 0.02, "omega2": 2500.0, "phi2": 3.87}


def paper_bench_path() -> Path:
    """Path of the bundled default dataset.

    Simulated, not measured: NL (n = 5, N = 480) at the paper's Table 5 parameters, 2000
    log-spaced angular frequencies over 1e1..1e5 rad/s, 0.2 % relative complex Gaussian noise
    (:func:`bayes_emt.io.simulate.simulate`), seed :data:`PAPER_BENCH_SEED`; see ``data/README.md``.
    """
    return Path(__file__).resolve().parent.parent / "data" / "paper_bench.csv"


def load_paper_bench() -> Measurement:
    """The bundled default dataset as a :class:`Measurement` (omega [rad/s], Y [S]).

    ``meta["written_meta"]["truth"]`` holds the parameters it was simulated from.
    """
    from . import read_measurement

    return read_measurement(paper_bench_path())


def concealed_bench_path() -> Path:
    """Path of the bundled concealed-effect recording: the paper's NL(5) device at Table 5 with a
    hidden second mechanical mode (:data:`CONCEALED_BENCH_EFFECT`), 0.2 % noise, seed
    :data:`CONCEALED_BENCH_SEED`, on the same grid as :func:`paper_bench_path`; see ``data/README.md``
    and ``data/make_concealed_bench.py``."""
    return Path(__file__).resolve().parent.parent / "data" / "concealed_bench.csv"


def load_concealed_bench() -> Measurement:
    """The concealed-effect recording as a :class:`Measurement`; ``meta["written_meta"]["truth"]``
    holds every parameter it was simulated from, the hidden mode's included."""
    from . import read_measurement

    return read_measurement(concealed_bench_path())


#: The real loudspeaker recordings of ``../shared/realdata`` (never copied into this repository):
#: file -> (reader options, useful band in Hz or None), as that folder's README describes them:
#: the LS10-44 .zma is unreliable below 10 Hz and at its last point; the run2 .txt files state no
#: frequency unit (Hz) and are very noisy above 1 kHz.
REALDATA_FILES: dict[str, tuple[dict, tuple[float, float] | None]] = {
    "dayton_LS10-44.zma": ({}, (10.0, 20300.0)),  # drops only the last point (20.64 kHz)
    "dayton_LS10-44_freeair_run2.txt": ({"freq_unit": "hz"}, (10.0, 1000.0)),
    "dayton_LS10-44_added100g_run2.txt": ({"freq_unit": "hz"}, (10.0, 1000.0)),
    "seas_E0018_freeair.zma": ({}, None),
    "koan_mid_sealed.zma": ({}, None),
    "koan_tweeter.zma": ({}, None),
}


def load_realdata(folder: str | Path, name: str) -> Measurement:
    """One of :data:`REALDATA_FILES` from ``folder``, restricted to its useful band."""
    from . import read_measurement

    opts, band = REALDATA_FILES[name]
    meas = read_measurement(Path(folder) / name, **opts)
    if band is not None:
        meas = meas.select(2 * math.pi * band[0], 2 * math.pi * band[1])
    return meas
