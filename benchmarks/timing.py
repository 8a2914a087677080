"""Timing helpers for the figures of merit: interleaved calls, best of many.

On a shared machine noise only ever adds time, so the minimum over repeated calls is the steadiest
estimate of a piece of code's cost (the argument of :mod:`timeit`); calls of the contenders are
interleaved (A B, B A, ...) so a slow spell of the machine falls on both.
"""

from __future__ import annotations

import time


def best_interleaved(fns: dict, *, min_calls: int = 7, min_time: float = 1.0, max_calls: int = 400) -> dict:
    """``{name: best seconds of one call}`` for argument-free callables, after one warm-up each."""
    for fn in fns.values():
        fn()
    runs = {name: [] for name in fns}
    names = list(fns)
    i = 0
    while i < max_calls and (i < min_calls or any(sum(r) < min_time for r in runs.values())):
        for name in (names if i % 2 == 0 else names[::-1]):
            t0 = time.perf_counter()
            fns[name]()
            runs[name].append(time.perf_counter() - t0)
        i += 1
    return {name: min(r) for name, r in runs.items()}
