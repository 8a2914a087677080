"""Output paths, checked before any work: an output never replaces an input, and a path that
cannot be written fails at once, in one line naming the option, not after a long run.

Every sub-command calls :func:`check_outputs` first thing, with the files it will write (``--json``,
``--out``, ``--checkpoint``, simulate's ``--out``), the folders it will fill (``--plot``, the demo's
``--out``) with the names it will write there, and the files it reads. Rules:

* an output equal to an input (same path, or the same file through a link) is refused;
* two outputs naming the same file are refused;
* a file output that is an existing folder is refused; a folder output that is an existing file
  is refused;
* the folder a file goes into must exist, be a folder and be writable; a folder output may be
  created (with its parents) if its nearest existing ancestor is a writable folder.

Writability is probed by creating and removing a temporary file in the folder (permission bits
do not tell the whole story: a read-only mount, or root, for whom ``os.access`` always says yes).
Every failure raises :class:`OutputPathError` (a ``ValueError``): ``bayes-emt`` prints it as one
line and exits with status 2.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path

from ..errors import BayesEMTError

__all__ = ["OutputPathError", "check_outputs", "same_file"]

PathLike = str | os.PathLike


class OutputPathError(BayesEMTError, ValueError):
    """An output path that cannot or must not be written (the message names the option)."""


def same_file(a: PathLike, b: PathLike) -> bool:
    """True when ``a`` and ``b`` name the same file: the same resolved path, or (both existing)
    the same inode through a link."""
    pa, pb = Path(a), Path(b)
    if pa.exists() and pb.exists():
        try:
            return os.path.samefile(pa, pb)
        except OSError:
            pass
    return pa.resolve() == pb.resolve()


def _probe(folder: Path) -> str | None:
    """``None`` if a file can be created in ``folder``, else why not."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".bayes_emt_probe.", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(tmp)
    return None


def _check_folder_for_file(option: str, path: Path) -> None:
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise OutputPathError(f"{option} {path}: folder {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"{option} {path}: {parent} is a file, not a folder")
    why = _probe(parent)
    if why is not None:
        raise OutputPathError(f"{option} {path}: cannot write in folder {parent} ({why})")


def _check_folder(option: str, folder: Path) -> None:
    if folder.exists():
        if not folder.is_dir():
            raise OutputPathError(f"{option} {folder}: is a file, not a folder")
        why = _probe(folder)
        if why is not None:
            raise OutputPathError(f"{option} {folder}: cannot write in this folder ({why})")
        return
    anc = folder.parent
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise OutputPathError(f"{option} {folder}: cannot create this folder: {anc} is a file")
    why = _probe(anc)
    if why is not None:
        raise OutputPathError(f"{option} {folder}: cannot create this folder in {anc} ({why})")


def check_outputs(files: Iterable[tuple[str, PathLike | None]] = (),
                  inputs: Iterable[tuple[str, PathLike | None]] = (), *,
                  folders: Iterable[tuple[str, PathLike | None, Sequence[str]]] = ()) -> None:
    """Refuse outputs that would replace an input, collide, or cannot be written (module docstring).

    Parameters
    ----------
    files : ``(option, path)`` of each file to be written (``None`` paths are skipped).
    inputs : ``(what, path)`` of each file read (``DATA``, ``--params``, ...).
    folders : ``(option, folder, names)``: a folder to be created or filled, and the names of the
        files that will be written into it.

    Raises
    ------
    OutputPathError
        One line naming the option, the path and what is wrong.
    """
    inputs = [(what, Path(p)) for what, p in inputs if p is not None]
    outs: list[tuple[str, Path]] = []
    for option, folder, names in folders:
        if folder is None:
            continue
        folder = Path(folder)
        for what, p in inputs:
            if same_file(p, folder):
                raise OutputPathError(f"{option} {folder}: is the input {what}, not a folder")
        _check_folder(option, folder)
        outs += [(f"{option} (file {name})", folder / name) for name in names]
    for option, p in files:
        if p is None:
            continue
        p = Path(p)
        if p.is_dir():
            raise OutputPathError(f"{option} {p}: is a folder; give a file name")
        _check_folder_for_file(option, p)
        outs.append((option, p))
    for i, (option, p) in enumerate(outs):
        for what, q in inputs:
            if same_file(p, q):
                raise OutputPathError(f"{option} {p}: is the input {what}; an output never replaces an "
                                      "input: choose another name")
        for other, q in outs[:i]:
            if same_file(p, q):
                raise OutputPathError(f"{option} and {other} name the same file {p}")
