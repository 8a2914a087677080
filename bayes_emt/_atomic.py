"""Atomic file output: write to a temporary file beside the target, then rename over it, so a
crash never leaves a half-written result and never destroys the previous one.

A failure to write (a full disk, a folder without write permission, a read-only mount) is
re-raised as the same ``OSError`` subclass with a message naming the *target* (never the hidden
temporary, which is removed), e.g. ``out.json: cannot write: No space left on device (the previous
out.json is unchanged)``."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_text"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; on success rename it to ``path``."""
    path = Path(path)
    if path.parent and not path.parent.exists():
        raise FileNotFoundError(f"{path}: folder {path.parent} does not exist")
    if path.parent and not path.parent.is_dir():
        raise NotADirectoryError(f"{path}: {path.parent} is a file, not a folder")
    if path.is_dir():
        raise IsADirectoryError(f"{path}: is a folder, not a file")
    existed = path.exists()
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix or ".tmp",
                                   dir=path.parent if str(path.parent) else ".")
    except OSError as exc:
        raise _naming(exc, path, existed) from None
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        # mkstemp creates 0600; give the result the permissions a plain open() would
        umask = os.umask(0)
        os.umask(umask)
        if tmp.exists():
            os.chmod(tmp, path.stat().st_mode & 0o7777 if path.exists() else 0o666 & ~umask)
        os.replace(tmp, path)
    except OSError as exc:
        raise _naming(exc, path, existed) from None
    except RuntimeError as exc:  # h5py/netCDF report a failed write so ("NetCDF: HDF error")
        raise _library_error(exc, path, existed) from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _library_error(exc: RuntimeError, path: Path, existed: bool) -> OSError:
    """A file library's write failure (h5py, netCDF: often without the cause) as an ``OSError``
    naming the target; a device with less than 1 MiB free is said to be full."""
    try:
        free = shutil.disk_usage(path.parent if str(path.parent) else ".").free
    except OSError:
        free = None
    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    if "No space left" in first or (free is not None and free < (1 << 20)):
        why = os.strerror(errno.ENOSPC) + ("" if free is None else f" ({free / 1e6:.2f} MB free; {first})")
        return _naming(OSError(errno.ENOSPC, why), path, existed)
    return _naming(OSError(errno.EIO, first), path, existed)


_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.EROFS, errno.EFBIG, errno.EIO}


def _naming(exc: OSError, path: Path, existed: bool) -> OSError:
    """``exc`` re-raised naming the target ``path`` (not the temporary) when it is a write failure
    or names another file; other errors (already naming the target, or an unrelated file) pass."""
    names_tmp = exc.filename is not None and os.path.basename(str(exc.filename)).startswith(f".{path.name}.")
    if exc.errno not in _WRITE_ERRNOS and not names_tmp:
        return exc
    why = exc.strerror or str(exc)
    kept = f" (the previous {path.name} is unchanged)" if existed else ""
    new = type(exc)(f"{path}: cannot write: {why}{kept}")
    new.errno = exc.errno
    return new


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
