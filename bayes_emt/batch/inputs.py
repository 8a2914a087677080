"""Which recordings a batch covers, and the result folder each one gets.

A batch is given a folder (every measurement file directly inside it) or a glob pattern
(``data/*.zma``, ``runs/**/*.txt``). Each input file gets its own result folder under the output
folder, named after the file's stem; two inputs with the same stem (from different folders) get
the stem plus the first 8 hex digits of the SHA-256 of their absolute path, so names never clash
and stay the same from one run to the next (which is what resuming needs).
"""

from __future__ import annotations

import glob
import hashlib
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

__all__ = ["MEASUREMENT_SUFFIXES", "BatchInput", "find_inputs", "file_sha256"]

#: File name endings a folder scan picks up (a glob takes whatever it matches).
MEASUREMENT_SUFFIXES = (".zma", ".csv", ".tsv", ".txt", ".dat", ".s1p")


@dataclass(frozen=True)
class BatchInput:
    """One recording of a batch.

    Attributes
    ----------
    path : the measurement file (absolute).
    name : its result folder's name under the batch output folder.
    """

    path: Path
    name: str


def _safe(stem: str) -> str:
    return re.sub(r"[^A-Za-z0-9._+-]", "_", stem) or "recording"


def find_inputs(source: str | Path, *, out: str | Path | None = None) -> list[BatchInput]:
    """The recordings named by ``source``: a folder, or a glob pattern.

    Parameters
    ----------
    source : a folder (its measurement files, by :data:`MEASUREMENT_SUFFIXES`, not recursive) or a
        glob pattern (``**`` recurses).
    out : the batch output folder; files inside it are never taken as inputs.

    Returns
    -------
    list of BatchInput
        Sorted by path.

    Raises
    ------
    FileNotFoundError
        Nothing matched (the message says what was looked for).
    """
    text = str(source)
    folder = Path(text)
    if folder.is_dir():
        paths = [p for p in folder.iterdir()
                 if p.is_file() and p.suffix.lower() in MEASUREMENT_SUFFIXES and not p.name.startswith(".")]
        if not paths:
            raise FileNotFoundError(f"{folder}: no measurement files ({', '.join(MEASUREMENT_SUFFIXES)}) "
                                    "in this folder")
    elif glob.has_magic(text):
        paths = [Path(p) for p in glob.glob(text, recursive=True) if Path(p).is_file()]
        if not paths:
            raise FileNotFoundError(f"{text}: the pattern matches no file")
    elif folder.is_file():
        paths = [folder]
    else:
        raise FileNotFoundError(f"{text}: no such folder or file, and not a glob pattern")
    paths = sorted({p.resolve() for p in paths})
    if out is not None:
        out_abs = Path(out).resolve()
        paths = [p for p in paths if out_abs not in p.parents]
        if not paths:
            raise FileNotFoundError(f"{text}: every match lies inside the output folder {out}")
    stems = Counter(_safe(p.stem) for p in paths)
    inputs = []
    for p in paths:
        stem = _safe(p.stem)
        if stems[stem] > 1:
            stem = f"{stem}-{hashlib.sha256(str(p).encode()).hexdigest()[:8]}"
        inputs.append(BatchInput(path=p, name=stem))
    return inputs


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex): a result is reused only for the same input bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
