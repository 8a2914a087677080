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

Faults. A run holds :class:`CheckpointLock` (``flock`` on a hidden ``.NAME.lock`` beside
the checkpoint, removed at the end; the kernel drops it if the process dies) for its whole
duration, so a second run on the same checkpoint is refused in one line instead of racing the
first one's writes (HDF5's own locking is off, see above). Every HDF5 failure (a corrupted or
truncated file, a failed write) is caught where the file is touched and raised as
:class:`~bayes_emt.errors.CheckpointError` naming the file; after a failed write the store never
touches the file again (h5py crashed reusing a handle whose write had failed). Before each flush
the free space is checked against the block's uncompressed size, so a full disk is usually
refused before HDF5 starts a write it cannot finish; the steps stored before stay readable.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import shutil
import time
from pathlib import Path

import emcee
import h5py
import numpy as np

from ..errors import CheckpointError

__all__ = ["ChainStore", "GROUP", "read_identity", "h5_open", "checkpoint_steps", "check_checkpoint",
           "CheckpointLock"]

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


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


@contextlib.contextmanager
def _h5_errors(path: Path, doing: str):
    """Turn any failure of h5py/HDF5 while ``doing`` something to ``path`` into one
    :class:`CheckpointError` naming the file (a full disk said so; anything else: corrupted or
    truncated)."""
    try:
        yield
    except CheckpointError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
        if isinstance(exc, OSError) and exc.errno == errno.ENOSPC or "No space left" in str(exc):
            raise CheckpointError(f"{path}: no space left on the device while {doing} "
                                  "the sampler checkpoint", errno.ENOSPC) from None
        if isinstance(exc, PermissionError):
            raise CheckpointError(f"{path}: permission denied while {doing} the sampler "
                                  "checkpoint", errno.EACCES) from None
        raise CheckpointError(f"{path}: cannot use the sampler checkpoint while {doing} it: corrupted or "
                              f"truncated file? (HDF5: {_first_line(exc)})") from None


class CheckpointLock:
    """Exclusive lock on a checkpoint for one run: ``flock`` on ``.NAME.lock`` beside it.

    :meth:`acquire` raises :class:`CheckpointError` at once (no waiting) when another process holds
    it, naming the checkpoint and, when written yet, that process's id. The lock file is removed on
    :meth:`release`; a process that finds its locked file removed or replaced meanwhile locks again,
    so removal cannot let two runs in. Where the file system has no ``flock``, no lock is taken.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.lock_path = self.path.with_name(f".{self.path.name}.lock")
        self._fd: int | None = None

    def acquire(self) -> CheckpointLock:
        while True:
            try:
                fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                raise CheckpointError(f"{self.path}: cannot create the checkpoint's lock file "
                                      f"{self.lock_path}: {exc.strerror}", exc.errno) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                try:
                    pid = os.read(fd, 32).decode("ascii", "replace").strip()
                except OSError:
                    pid = ""
                os.close(fd)
                who = f" (process {pid})" if pid.isdigit() else ""
                raise CheckpointError(f"{self.path}: checkpoint in use by another run{who}; wait for it "
                                      "to end, or give another --checkpoint", errno.EBUSY) from None
            except OSError:  # no flock on this file system: run unlocked, as before
                os.close(fd)
                return self
            try:
                same = os.stat(self.lock_path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if not same:  # a previous holder removed it between our open and our lock: again
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            self._fd = fd
            return self

    def release(self) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.lock_path)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> CheckpointLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


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
    if path.exists() and not path.is_file():
        raise ValueError(f"{path}: cannot resume: not a regular file")
    try:
        with h5_open(path, "r") as f:
            return json.loads(f[GROUP].attrs["bayes_emt"])
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: cannot resume: not a bayes_emt sampler checkpoint, or a corrupted one "
                         f"({_first_line(exc)})") from None


class ChainStore(emcee.backends.Backend):
    """In-memory emcee backend with optional block-wise HDF5 persistence (module docstring)."""

    def __init__(self, path: str | Path | None = None, block: int = 100):
        super().__init__()
        self.path = None if path is None else Path(path)
        self.block = int(block)
        self._flushed = 0
        self._broken = False  # a write failed: never touch the file again

    # ---- files -----------------------------------------------------------------------------------
    def create(self, nwalkers: int, ndim: int, identity: dict) -> None:
        """Start a new run: empty chain, and a new file (when a path is attached)."""
        self.reset(nwalkers, ndim)
        if self.path is None:
            return
        try:
            with _h5_errors(self.path, "creating"):
                self._create_file(nwalkers, ndim, identity)
        except BaseException:
            self._broken = True
            with contextlib.suppress(OSError):
                self.path.unlink()
            raise

    def _create_file(self, nwalkers: int, ndim: int, identity: dict) -> None:
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
        with _h5_errors(self.path, "reading"), h5_open(self.path, "r") as f:
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
        if self._broken:
            raise CheckpointError(f"{self.path}: an earlier write to the checkpoint failed; not writing "
                                  "again")
        a = self._flushed
        self._check_space(n - a)
        try:
            with _h5_errors(self.path, "writing"):
                self._append(a, n)
        except BaseException:
            self._broken = True
            raise
        self._flushed = n

    def _check_space(self, steps: int) -> None:
        """Refuse a flush the disk cannot hold, before HDF5 starts it: twice the new steps'
        uncompressed size plus 1 MiB must be free, and that much is reserved for the file with
        ``posix_fallocate`` (HDF5 then writes into blocks it owns; it truncates the file back to
        what it uses when it closes). h5py crashed (SIGSEGV) closing a file whose write had failed
        for want of space, so the write must not start at all."""
        width = self.nwalkers * (self.ndim + 1 + (1 if self.blobs is not None else 0))
        need = 2 * 8 * steps * width + (1 << 20)
        try:
            free = shutil.disk_usage(self.path.parent if str(self.path.parent) else ".").free
        except OSError:
            free = None
        stored = f"the {self._flushed} steps stored before are intact"
        if free is not None and free < need:
            self._broken = True
            raise CheckpointError(f"{self.path}: no space left on the device for the next {steps} steps "
                                  f"({need / 1e6:.1f} MB needed, {free / 1e6:.1f} MB free); {stored}",
                                  errno.ENOSPC)
        try:
            fd = os.open(self.path, os.O_RDWR)
        except OSError:
            return  # h5py's open will say what is wrong
        try:
            os.posix_fallocate(fd, 0, os.fstat(fd).st_size + need)
        except OSError as exc:
            if exc.errno in (errno.ENOSPC, errno.EDQUOT):
                self._broken = True
                raise CheckpointError(f"{self.path}: no space left on the device for the next {steps} steps "
                                      f"({need / 1e6:.1f} MB to reserve); {stored}", errno.ENOSPC) from None
        finally:
            os.close(fd)

    def _append(self, a: int, n: int) -> None:
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
