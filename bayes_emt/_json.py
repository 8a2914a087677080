"""Strict JSON values: what every result record passes through before it is written.

JSON has no NaN or infinity (Python's ``json`` writes them as the non-standard ``NaN``/``Infinity``
that other readers refuse) and no numpy scalars. :func:`strict_json` maps a nested structure of
dicts, lists and tuples to one ``json.dumps(..., allow_nan=False)`` accepts: non-finite floats
become ``null`` (a value that could not be computed), numpy scalars their Python values."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["strict_json"]


def strict_json(obj):
    """``obj`` with non-finite floats as ``None`` and numpy scalars as Python scalars (recursively
    through dicts, lists and tuples; tuples become lists)."""
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [strict_json(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer | np.bool_):
        return obj.item()
    return obj
