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
"""

from __future__ import annotations

import json
from pathlib import Path

import emcee
import h5py
import numpy as np

__all__ = ["ChainStore", "GROUP", "read_identity"]

GROUP = "mcmc"
_COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


def read_identity(path: Path) -> dict:
    """The ``bayes_emt`` identity stored in a checkpoint (``ValueError`` if it is not one)."""
    try:
        with h5py.File(path, "r") as f:
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
        with h5py.File(self.path, "w") as f:
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
        with h5py.File(self.path, "r") as f:
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
        with h5py.File(self.path, "a") as f:
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
