"""LIMP (ARTA suite) ``.lim`` binary impedance files.

Little-endian layout, as read by the public parser of SanderPaulus/crossover-studio
(``src/lib/parsers/lim.ts``) and checked there against real files:

======  =======  ==========================================================================
byte    type     content
======  =======  ==========================================================================
0-3     char[4]  ``LIM\\0``
12      int32    N, the number of points
16      int32    0 or N-1 (meaning not known)
20      int32    32768 in the files seen (meaning not known)
24      float32  sample rate [Hz]
28      float32  N triplets: frequency [Hz], |Z| [ohm], phase [deg]
28+12N  int32    L, then L bytes of an ASCII note (L may be 0)
======  =======  ==========================================================================

Recognised by its first four bytes. Bytes 4-11 and the two unknown integers are not checked. A
binary file has no lines: ``file:N`` in a message about a point names point N.
"""

from __future__ import annotations

import os
import stat
import struct
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement
from ._bench import bench_measurement

__all__ = ["LIM_MAGIC", "looks_like_lim", "read_lim", "lim_bytes"]

LIM_MAGIC = b"LIM\x00"
_HEADER = 28


def looks_like_lim(path: Path) -> bool:
    """True when ``path`` is a regular file starting with ``LIM\\0``."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False
        with open(path, "rb") as fh:
            return fh.read(4) == LIM_MAGIC
    except OSError:
        return False


def read_lim(path: Path) -> Measurement:
    """Read a ``.lim`` file (see the module docstring); every problem names the byte offset."""
    raw = Path(path).read_bytes()
    if len(raw) < _HEADER:
        raise DataFormatError(f"{path}: a LIMP .lim file of {len(raw)} bytes, shorter than its "
                              f"{_HEADER}-byte header")
    n = struct.unpack_from("<i", raw, 12)[0]
    if n < 1:
        raise DataFormatError(f"{path}: byte 12: point count {n} is not positive (a LIMP .lim file)")
    end = _HEADER + 12 * n
    if len(raw) < end:
        raise DataFormatError(f"{path}: byte {len(raw)}: the file ends inside its {n} points (needs "
                              f"{end} bytes); truncated .lim file")
    rate = struct.unpack_from("<f", raw, 24)[0]
    arr = np.frombuffer(raw, dtype="<f4", count=3 * n, offset=_HEADER).astype(float).reshape(n, 3)
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        raise DataFormatError(f"{path}: byte {_HEADER + 12 * bad[0]}: point {bad[0] + 1} is not finite")
    note = ""
    if len(raw) >= end + 4:
        length = struct.unpack_from("<i", raw, end)[0]
        if 0 <= length <= len(raw) - end - 4:
            note = raw[end + 4:end + 4 + length].decode("latin-1").strip("\x00 \r\n")
    # a binary file has no lines: a message's "file:N" names point N
    meta = {"header": note or None, "n_header_lines": 0, "sample_rate_hz": float(rate),
            "lim_note": note}
    return bench_measurement(Path(path), arr, list(range(1, n + 1)), fmt="lim", notices=[],
                             meta=meta)


def lim_bytes(f_hz, abs_z_ohm, phase_deg, *, sample_rate_hz: float = 48000.0, note: str = "") -> bytes:
    """The bytes of a ``.lim`` file with these points (the layout above; for tests and fixtures)."""
    f_hz, abs_z_ohm, phase_deg = (np.asarray(x, "<f4") for x in (f_hz, abs_z_ohm, phase_deg))
    n = f_hz.size
    head = LIM_MAGIC + b"\x00" * 8 + struct.pack("<iiif", n, n - 1, 32768, sample_rate_hz)
    body = np.column_stack([f_hz, abs_z_ohm, phase_deg]).astype("<f4").tobytes()
    text = note.encode("ascii")
    return head + body + struct.pack("<i", len(text)) + text
