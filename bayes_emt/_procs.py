"""Worker processes that die with their parent, and a process pool that never hangs.

A forked worker of :class:`ProcessPool`

* asks the kernel to kill it when its parent dies, whatever the cause (Linux
  ``prctl(PR_SET_PDEATHSIG, SIGKILL)``; elsewhere a thread that checks the parent's pid every
  :data:`WATCH_SECONDS` and ends the worker once it has changed), so a parent killed with SIGKILL
  (``timeout -k``, a job scheduler, the out-of-memory killer) leaves nothing running;
* ignores SIGINT (Ctrl-C reaches the whole foreground process group: the parent decides what
  happens and ends its workers) and takes the default action on SIGTERM (a forked worker would
  otherwise inherit the parent's Python handlers).

The parent's :meth:`ProcessPool.close` ends the workers on every exit path (normal return,
exception, SIGINT, SIGTERM): it cancels what has not started, sends SIGTERM to every worker, waits at
most :data:`JOIN_SECONDS` and sends SIGKILL to any still alive. A worker that dies while the pool is
in use (killed by a signal, the out-of-memory killer) makes the waiting call raise
:class:`WorkerLost`, a one-line error naming the step and the task, instead of waiting for a result
that never comes.

Why :class:`concurrent.futures.ProcessPoolExecutor` and not :class:`multiprocessing.Pool`: the
executor watches each worker's process sentinel and marks the pool broken (every pending future
raises ``BrokenProcessPool``) as soon as one dies; ``multiprocessing.Pool`` quietly starts a
replacement worker and the task the dead one held never returns, so ``result()`` waits forever.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from concurrent.futures import BrokenExecutor, ProcessPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout

from .errors import BayesEMTError

__all__ = ["ProcessPool", "WallClock", "WorkerLost", "die_with_parent", "parent_death_preexec", "process_age",
           "worker_start"]

#: seconds :meth:`ProcessPool.close` waits for its workers after SIGTERM before it sends SIGKILL
JOIN_SECONDS = 1.0
#: seconds between two checks of the parent's pid where the kernel cannot watch it
WATCH_SECONDS = 0.25
_PR_SET_PDEATHSIG = 1


class WorkerLost(BayesEMTError, RuntimeError):
    """A worker process died before returning its task's result (the message names the step)."""


class WallClock:
    """Wall-clock seconds (:func:`time.monotonic`) for a time budget that means what the user's
    watch says on a loaded machine. ``workers`` sums the CPU seconds the pool's workers reported
    (for the record; it does not move the clock)."""

    #: a wall clock: a call waiting for a worker may stop waiting at the deadline
    wall = True

    def __init__(self):
        self.workers = 0.0

    def __call__(self) -> float:
        return time.monotonic()


def process_age() -> float:
    """Wall-clock seconds since this process started (Linux ``/proc``; elsewhere 0): a command's
    time budget then counts the interpreter's start and the imports too."""
    try:
        with open("/proc/self/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: start time after boot [ticks]
        return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - started)
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def _prctl():
    """libc's ``prctl`` (Linux), or ``None``: looked up among the symbols already loaded (no search
    of the file system, so it is safe between ``fork`` and ``exec``)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _pdeathsig(sig: int, prctl=None) -> bool:
    """Ask the Linux kernel to send ``sig`` to this process when its parent dies; whether it took."""
    prctl = prctl or _prctl()
    return prctl is not None and prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(WATCH_SECONDS)
        if os.getppid() != parent:
            os._exit(1)


def die_with_parent(parent: int | None = None) -> str:
    """Make this process end when ``parent`` (default: the current parent) dies: the kernel's
    parent-death signal where there is one, else a daemon thread watching the parent's pid.
    Returns ``"prctl"`` or ``"watch"``. Ends the process at once if the parent is already gone."""
    parent = os.getppid() if parent is None else parent
    how = "prctl" if _pdeathsig(signal.SIGKILL) else "watch"
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(1)
    if how == "watch":
        threading.Thread(target=_watch_parent, args=(parent,), daemon=True, name="parent-watch").start()
    return how


def worker_start(parent: int) -> None:
    """A pool worker's first act: default SIGTERM, ignored SIGINT, and death with ``parent``."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent)


def parent_death_preexec():
    """A ``preexec_fn`` for :class:`subprocess.Popen` (``None`` where there is no ``prctl``): the
    child gets SIGKILL when the thread of this process that started it ends (Linux), so a child
    never outlives a killed parent."""
    prctl = _prctl()
    if prctl is None:
        return None
    return lambda: _pdeathsig(signal.SIGKILL, prctl)


def _label(fn, args) -> str:
    first = next((a for a in args if isinstance(a, str)), None)
    name = getattr(fn, "__name__", "a task").strip("_").replace("_", " ")
    return f"{name} {first}" if first else name


class Task:
    """A submitted call: :meth:`result` returns its value or raises its exception, and raises
    :class:`WorkerLost` when the worker running it died."""

    def __init__(self, pool: ProcessPool, future, label: str):
        self._pool, self._future, self.label = pool, future, label

    def result(self, timeout: float | None = None):
        """The call's value; ``timeout`` [s]: raise :class:`TimeoutError` when it is not done by
        then (the call keeps running)."""
        try:
            return self._future.result(timeout)
        except FutureTimeout:
            raise TimeoutError(f"{self.label}: not done within {timeout:g} s") from None
        except BrokenExecutor:
            raise WorkerLost(self._pool.lost_message(self.label)) from None

    def cancel(self) -> bool:
        return self._future.cancel()

    def done(self) -> bool:
        return self._future.done()


class ProcessPool:
    """``n`` forked worker processes that die with this process (module docstring); a context
    manager whose exit ends them. ``step`` names the work in errors ("the diagnosis")."""

    def __init__(self, n: int, *, step: str = "the computation", context=None):
        import multiprocessing

        if context is None:
            methods = multiprocessing.get_all_start_methods()
            context = multiprocessing.get_context("fork" if "fork" in methods else methods[0])
        self.n, self.step = int(n), step
        self._ex = ProcessPoolExecutor(max_workers=self.n, mp_context=context, initializer=worker_start,
                                       initargs=(os.getpid(),))
        self._closed = False

    def submit(self, fn, *args) -> Task:
        """Run ``fn(*args)`` in a worker; a :class:`Task`. Raises :class:`WorkerLost` when a worker
        has already died."""
        label = _label(fn, args)
        try:
            return Task(self, self._ex.submit(fn, *args), label)
        except BrokenExecutor:
            raise WorkerLost(self.lost_message(label)) from None
        except RuntimeError:  # after stop_workers or close: say so instead of the executor's words
            raise WorkerLost(f"{label}: the worker processes of {self.step} were already stopped") from None

    def lost_message(self, label: str) -> str:
        return (f"a worker process of {self.step} ended without its result ({label}; killed by a signal "
                "or out of memory): nothing was written; run it again, or with --workers 1 to use no "
                "worker processes")

    def pids(self) -> list[int]:
        """The pids of the worker processes started so far (for tests and diagnostics)."""
        return [p.pid for p in list((self._ex._processes or {}).values()) if p.pid is not None]

    def stop_workers(self) -> None:
        """End every worker now (SIGTERM, then SIGKILL after :data:`JOIN_SECONDS`) and the pool with
        them; pending tasks are cancelled. Bounded: never waits for a running task."""
        procs = list((self._ex._processes or {}).values())
        self._ex.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            with contextlib.suppress(OSError, ValueError, AttributeError):
                p.terminate()
        end = time.monotonic() + JOIN_SECONDS
        for p in procs:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                p.join(max(0.0, end - time.monotonic()))
        for p in procs:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                if p.is_alive():
                    p.kill()
                    p.join(JOIN_SECONDS)
        thread = getattr(self._ex, "_executor_manager_thread", None)
        if thread is not None and thread.is_alive():
            thread.join(JOIN_SECONDS)

    def close(self) -> None:
        """End the pool on any exit path; idempotent and bounded (:meth:`stop_workers`)."""
        if self._closed:
            return
        self._closed = True
        self.stop_workers()

    #: the name :class:`concurrent.futures.Executor` users know
    def shutdown(self, wait: bool = True, *, cancel_futures: bool = True) -> None:
        self.close()

    def __enter__(self) -> ProcessPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
