"""The sampler's chain store: in memory while running, flushed to HDF5 in whole blocks.

:class:`ChainStore` is an emcee backend (emcee's ``Backend`` API) that keeps the chain in memory
(grown geometrically, so long runs do not copy it at every call) and, with a file attached,
appends the steps made since the last :meth:`~ChainStore.flush` to it. The driver flushes at the
end of every block of ``reseed_every`` steps, the unit a resume restarts from anyway
(:mod:`bayes_emt.inference.sampling`), so a kill loses at most the block in progress.

File layout (group ``mcmc``, readable by ``emcee.backends.HDFBackend(path, read_only=True)``):
datasets ``chain (steps, walkers, ndim)``, ``log_prob (steps, walkers)``, ``blobs (steps,
walkers)``, ``accepted (walkers,)``; attributes ``iteration`` (written last, after the data),
``nwalkers``, ``ndim``, ``has_blobs``, ``version`` and ``bayes_emt`` (the run's identity, JSON).
Datasets are chunked one block of steps at a time and compressed (gzip, level 4): h5py's
automatic chunks padded the chain by 1.26×, and emcee's ``HDFBackend`` rewrote its random-state
attributes at every step, leaving dead space in the file (the demo's NL(5) checkpoint was 143 MB).
No random state is stored: the driver derives every block's from the seed.

The file is opened without HDF5 file locking (:func:`h5_open`): a reader that held it open with
locking (``h5py.File(path, "r")`` in some h5py builds, HDFView, ``h5ls``) made the writer's next
open fail with ``BlockingIOError`` and killed the run. An open that still finds the file busy is
retried for up to 5 s. The run is the file's only writer; a reader may see a block half written
(``iteration`` is written after the data, so never the reverse). Read a checkpoint during a run
with :func:`checkpoint_steps` (read-only, no locking).

:func:`check_checkpoint` says, before any work, whether a checkpoint can be used as asked; one
that holds no step (a run stopped before its first block: a bad option, an interrupt) is replaced
without ``overwrite``, and :func:`~bayes_emt.inference.sampling.run_ensemble` removes a
checkpoint it created when it fails before storing a step.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import emcee
import h5py
import numpy as np

__all__ = ["ChainStore", "GROUP", "read_identity", "h5_open", "checkpoint_steps", "check_checkpoint"]

GROUP = "mcmc"  #: the HDF5 group of the chain (emcee's ``HDFBackend`` layout)
_OPEN_TRIES = 100  # a busy checkpoint is retried for up to 100 x 0.05 s
_COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


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


def read_identity(path: Path) -> dict:
    """The ``bayes_emt`` identity stored in a checkpoint (``ValueError`` if it is not one)."""
    try:
        with h5_open(path, "r") as f:
            return json.loads(f[GROUP].attrs["bayes_emt"])
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: cannot resume: not a bayes_emt sampler checkpoint ({exc})") from None


class ChainStore(emcee.backends.Backend):
    """In-memory emcee backend with optional block-wise HDF5 persistence (module docstring)."""

    def __init__(self, path: str | Path | None = None, block: int = 100):
        super().__init__()
        self.path = None if path is None else Path(path)
        self.block = int(block)
        self._flushed = 0

    # ---- files -----------------------------------------------------------------------------------
    def create(self, nwalkers: int, ndim: int, identity: dict) -> None:
        """Start a new run: empty chain, and a new file (when a path is attached)."""
        self.reset(nwalkers, ndim)
        if self.path is None:
            return
        with h5_open(self.path, "w") as f:
            g = f.create_group(GROUP)
            g.attrs.update({"version": emcee.__version__, "nwalkers": int(nwalkers), "ndim": int(ndim),
                            "has_blobs": False, "iteration": 0, "bayes_emt": json.dumps(identity)})
            g.create_dataset("accepted", data=np.zeros(nwalkers))
            g.create_dataset("chain", (0, nwalkers, ndim), maxshape=(None, nwalkers, ndim), dtype="f8",
                             chunks=(self.block, nwalkers, ndim), **_COMPRESSION)
            g.create_dataset("log_prob", (0, nwalkers), maxshape=(None, nwalkers), dtype="f8",
                             chunks=(self.block, nwalkers), **_COMPRESSION)

    def load(self) -> None:
        """Read the stored steps up to the last whole block into memory (a partly written block
        is recomputed; the next flush overwrites it)."""
        with h5_open(self.path, "r") as f:
            g = f[GROUP]
            n = (int(g.attrs["iteration"]) // self.block) * self.block
            self.reset(int(g.attrs["nwalkers"]), int(g.attrs["ndim"]))
            self.chain = g["chain"][:n]
            self.log_prob = g["log_prob"][:n]
            self.blobs = g["blobs"][:n] if g.attrs["has_blobs"] else None
            self.accepted = g["accepted"][...]
        self.iteration = n
        self._flushed = n

    def flush(self) -> None:
        """Append the unsaved steps to the file, data first, ``iteration`` last."""
        n = self.iteration
        if self.path is None or n == self._flushed:
            return
        a = self._flushed
        with h5_open(self.path, "a") as f:
            g = f[GROUP]
            if self.blobs is not None and "blobs" not in g:
                g.create_dataset("blobs", (0, self.nwalkers), maxshape=(None, self.nwalkers),
                                 dtype=self.blobs.dtype, chunks=(self.block, self.nwalkers), **_COMPRESSION)
                g.attrs["has_blobs"] = True
            names = ("chain", "log_prob") + (("blobs",) if self.blobs is not None else ())
            for name in names:
                ds = g[name]
                ds.resize(n, axis=0)
                ds[a:n] = getattr(self, name)[a:n]
            g["accepted"][...] = self.accepted
            f.flush()
            g.attrs["iteration"] = n
        self._flushed = n

    # ---- emcee's Backend API ---------------------------------------------------------------------
    def grow(self, ngrow, blobs):
        """Make room for ``ngrow`` more steps (capacity at least doubles when it grows)."""
        self._check_blobs(blobs)
        need = self.iteration + int(ngrow)
        cap = self.chain.shape[0]
        if blobs is not None and self.blobs is None:
            self.blobs = np.empty((cap, self.nwalkers), dtype=np.dtype((blobs.dtype, blobs.shape[1:])))
        if need <= cap:
            return
        new = max(need, 2 * cap)

        def grown(a):
            out = np.empty((new,) + a.shape[1:], dtype=a.dtype)
            out[: self.iteration] = a[: self.iteration]
            return out

        self.chain = grown(self.chain)
        self.log_prob = grown(self.log_prob)
        if self.blobs is not None:
            self.blobs = grown(self.blobs)
