"""The demo's wall-clock time budget (``bayes-emt demo --time-budget SECONDS``).

The budget is split into one share per step, in the order the steps run, the steps an engineer
needs most getting the most: the least-squares fits (and the Thiele–Small values the report reads
from them), the evidence and the preferred model's posterior, the shunt designs, the robust shunt,
the diagnosis. Each step's deadline is where its cumulative share ends, so time a step leaves
unused goes to the steps after it, and a step that overran leaves less to them. A step at its
deadline stops at a point that still gives a valid, smaller result (an emcee chain ends at a block
boundary with its convergence verdict judged on what it has; nested sampling, the evidence's
cross-check, is not started; the robust shunt and the diagnosis stop by their own time budgets)
and the demo names the cut in one line, in the report's warnings and in its list of what the run
did not do.

A redirected run (a log file, a pipe) is never silent for long: :class:`Heartbeat` prints which step
is still running whenever nothing was printed for a few seconds.
"""

from __future__ import annotations

import argparse
import threading
import time

__all__ = ["SHARES", "Budget", "Heartbeat", "budget_split", "budget_seconds"]

#: (step, fraction of the budget), in the order the demo runs them
SHARES = (
    ("fit", 0.05),
    ("hankel", 0.03),
    ("evidence", 0.37),
    ("shunt", 0.10),
    ("robust_shunt", 0.22),
    ("diagnose", 0.15),
    ("report", 0.08),
)
#: seconds the robust shunt and the diagnosis get at least, even when the steps before overran
#: (below this neither returns anything useful)
MIN_STEP_S = 10.0


def budget_split(total: float | None = None) -> str:
    """``fit 5 %, hankel 3 %, ...`` (with ``total``: the seconds of each share)."""
    if total:
        return ", ".join(f"{name} {f * total:.0f} s" for name, f in SHARES)
    return ", ".join(f"{name} {100 * f:g} %" for name, f in SHARES)


def budget_seconds(text: str) -> float:
    """argparse type of ``--time-budget``: seconds >= 0 (0: no budget)."""
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"--time-budget {text}: give the wall-clock seconds as a number "
                                         ">= 0 (0: no budget)")
    return v


class Budget:
    """Deadlines (:func:`time.monotonic` instants) of the demo's steps; ``total`` None: no budget."""

    def __init__(self, total: float | None, start: float | None = None):
        self.total = float(total) if total else None
        self.start = time.monotonic() if start is None else start
        self._ends = {}
        acc = 0.0
        for name, f in SHARES:
            acc += f
            self._ends[name] = acc

    def share(self, step: str) -> float | None:
        """The seconds of ``step``'s own share (None without a budget)."""
        return None if self.total is None else dict(SHARES)[step] * self.total

    def deadline(self, step: str) -> float | None:
        """When ``step`` must be done (None without a budget)."""
        return None if self.total is None else self.start + self._ends[step] * self.total

    def left(self, step: str, floor: float = 0.0) -> float | None:
        """Seconds until ``step``'s deadline, at least ``floor`` (None without a budget)."""
        end = self.deadline(step)
        return None if end is None else max(floor, end - time.monotonic())

    def over(self, step: str) -> bool:
        """Whether ``step``'s deadline has passed."""
        end = self.deadline(step)
        return end is not None and time.monotonic() >= end


class Heartbeat:
    """A context: a thread that calls ``say("  ... STEP: still running (N s in this step)")`` whenever
    ``last_said()`` (a :func:`time.monotonic` instant) is ``every`` seconds old; ``stage()`` returns
    the step's name and start. Does nothing when ``on`` is False."""

    def __init__(self, last_said, stage, say, every: float, on: bool = True):
        self.last_said, self.stage, self.say, self.every, self.on = last_said, stage, say, every, on
        self._stop = threading.Event()
        self._thread = None

    def __enter__(self):
        if self.on:
            self._thread = threading.Thread(target=self._run, daemon=True, name="demo-heartbeat")
            self._thread.start()
        return self

    def _run(self):
        while not self._stop.wait(0.5):
            now = time.monotonic()
            if now - self.last_said() >= self.every:
                name, t0 = self.stage()
                self.say(f"  ... {name}: still running ({now - t0:.0f} s in this step)")

    def __exit__(self, *exc):
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
