"""What the bench readers share: turning checked columns (Hz, ohm, degrees) into a Measurement.

Each bench format (DATS, Klippel, LIMP, ...) has its own module with a cheap ``looks_like_*`` test
on the first lines or bytes and a ``read_*`` function; all of them end here, so every format gets
the same checks (point count, positive frequencies and magnitudes, duplicates, passivity, scale)
and the same resolution-artefact rule (:mod:`.resolution`).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..measurement import Measurement
from ._rows import check_rows, check_scale, finish
from .minphase import minimum_phase_deg
from .resolution import drop_note, low_band_rows, resolution_band
from .table import _check_passive

__all__ = ["bench_measurement", "BENCH_UNITS"]

#: how the bench formats' units were decided, for ``meta["units_from"]``
BENCH_UNITS = "format"


def bench_measurement(path: Path, arr: np.ndarray, linenos: list[int], *, fmt: str, notices: list[str],
                      meta: dict, magnitude_only: bool = False) -> Measurement:
    """A Measurement from rows ``(f [Hz], |Z| [ohm], phase [deg])`` (or ``(f, |Z|)`` when
    ``magnitude_only``), with the file's line numbers for the messages.

    A magnitude-only curve gets a minimum-phase estimate of its phase (:mod:`.minphase`) so that
    the Measurement stays complex, and ``meta["phase"] = "absent"``: the likelihood then uses
    log|Z| alone (:mod:`bayes_emt.inference.magnitude`), never that estimate.
    """
    arr, linenos = check_rows(arr, linenos, path, notices=notices, magnitude_col=1)
    order = np.argsort(arr[:, 0], kind="stable")
    s = arr[order]
    phase_col = s[:, 1] if magnitude_only else s[:, 2]
    k = resolution_band(s[:, 0], s[:, 1], phase_col)
    if k:
        note = drop_note(path, s[:, 0], k, s.shape[0])
        notices.append(note)
        meta = {**meta, "dropped_band_hz": [float(s[0, 0]), float(s[k - 1, 0])],
                "low_band": low_band_rows(s[:k, 0], s[:k, 1], None if magnitude_only else s[:k, 2])}
        keep = np.sort(order[k:])
        arr, linenos = arr[keep], [linenos[i] for i in keep]
        warnings.warn(note, UserWarning, stacklevel=4)
    f_hz, mag = arr[:, 0], arr[:, 1]
    omega = 2 * math.pi * f_hz
    with np.errstate(over="ignore", invalid="ignore"):
        check_scale(f_hz, mag, linenos, path)
    if magnitude_only:
        o = np.argsort(f_hz, kind="stable")
        ph = np.empty_like(mag)
        ph[o] = minimum_phase_deg(f_hz[o], mag[o])
        meta = {**meta, "phase": "absent", "phase_unit": None}
    else:
        ph = arr[:, 2]
        peak = int(np.argmax(np.abs(ph)))
        if abs(ph[peak]) > 180.0:
            raise DataFormatError(f"{path}:{linenos[peak]}: phase {ph[peak]:g} deg is beyond +-180 deg; "
                                  "this format's phase is in degrees")
        meta = {**meta, "phase_unit": "deg"}
    Z = mag * np.exp(1j * np.deg2rad(ph))
    Y = 1.0 / Z
    if not magnitude_only:
        _check_passive(Y, linenos, path, notices)
    meta = {"source": str(path), "format": fmt, "freq_unit": "hz", "quantity": "Z",
            "representation": "magnitude" if magnitude_only else "magphase",
            "units_from": {"freq_unit": BENCH_UNITS, "quantity": BENCH_UNITS,
                           **({} if magnitude_only else {"phase_unit": BENCH_UNITS})}, **meta}
    return finish(omega, Y, linenos, path, meta, notices)
