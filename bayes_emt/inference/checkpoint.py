"""The sampler's HDF5 checkpoint file: opened so that a reader never kills the run, and never left
empty to block the next one.

A reader that holds the file open while the run writes it (``h5py.File(path, "r")`` with HDF5
file locking, as some h5py builds do by default, HDFView, ``h5ls``) made the writer's next open
fail with ``BlockingIOError`` and killed the run. The writer (:class:`CheckpointBackend`, emcee's
``HDFBackend``) therefore opens the file without locking, and retries an open that still finds it
busy for up to 5 s. The run is the file's only writer; a reader may see a step half written,
never the reverse. Read a checkpoint during a run with :func:`checkpoint_steps` (read-only, no
locking).

:func:`check_checkpoint` says, before any work, whether a checkpoint can be used as asked; one
that holds no step (a run stopped before its first: a bad option, an interrupt) is replaced
without ``overwrite``, and :func:`~bayes_emt.inference.sampling.run_ensemble` removes a
checkpoint it created when it fails before storing a step.
"""

from __future__ import annotations

import time
from pathlib import Path

import emcee
import h5py

__all__ = ["GROUP", "CheckpointBackend", "h5_open", "checkpoint_steps", "check_checkpoint"]

GROUP = "mcmc"  #: the HDF5 group emcee's backend writes
_OPEN_TRIES = 100  # a busy checkpoint is retried for up to 100 x 0.05 s


def h5_open(path, mode: str) -> h5py.File:
    """``h5py.File(path, mode)`` without file locking, retried for ~5 s while the file is busy."""
    for attempt in range(_OPEN_TRIES):
        try:
            return h5py.File(path, mode, locking=False)
        except BlockingIOError:
            if attempt == _OPEN_TRIES - 1:
                raise
            time.sleep(0.05)
    raise AssertionError("unreachable")


class CheckpointBackend(emcee.backends.HDFBackend):
    """emcee's HDF5 backend, opened by :func:`h5_open` (no locking, retried while busy)."""

    def open(self, mode="r"):
        if self.read_only and mode != "r":
            raise RuntimeError("the checkpoint was opened read-only")
        f = h5_open(self.filename, mode)
        if not self.dtype_set and self.name in f:
            g = f[self.name]
            if "chain" in g:
                self.dtype = g["chain"].dtype
                self.dtype_set = True
        return f


def checkpoint_steps(path: str | Path) -> int | None:
    """Steps stored in a sampler checkpoint (read-only, no file locking: safe while a run writes
    it), or ``None`` when ``path`` is not a bayes_emt checkpoint."""
    try:
        with h5_open(path, "r") as f:
            g = f[GROUP]
            if "bayes_emt" not in g.attrs:
                return None
            return int(g.attrs["iteration"])
    except (OSError, KeyError, ValueError):
        return None


def check_checkpoint(path: str | Path | None, *, resume: bool, overwrite: bool) -> None:
    """Refuse, before any work, a checkpoint that cannot be used as asked: ``resume`` without the
    file, or a file holding steps (or not a checkpoint at all) without ``resume`` or ``overwrite``.
    A checkpoint holding no step passes (it is replaced)."""
    if path is None:
        return
    path = Path(path)
    if resume:
        if not path.exists():
            raise FileNotFoundError(f"{path}: no checkpoint to resume")
        return
    if path.exists() and not overwrite and checkpoint_steps(path) != 0:
        raise FileExistsError(f"{path}: a checkpoint exists; continue it with --resume, or start "
                              "afresh with --overwrite (or another --checkpoint)")
