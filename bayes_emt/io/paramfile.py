"""Parameter files: ``{"model": "UD+winding_capacitance", "rings": null, "n_turns": 480, "terms": [...],
"parameters": {...}}`` (``terms``, written by ``fit --json``, rebuilds the model exactly; a spec alone
works too).

The same shape ``bayes-emt fit --json`` writes, so a fit's output feeds ``simulate`` and ``shunt``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_text
from .._json import strict_json
from ..errors import DataFormatError
from ..models import Model, model_from_dict

__all__ = ["read_param_file", "model_from_record", "param_record", "write_json"]


def model_from_record(rec: Mapping, *, where: str = "parameters") -> tuple[Model, np.ndarray]:
    """Model and parameter vector from a ``{"model", "rings"?, "n_turns"?, "parameters"}`` mapping."""
    if not isinstance(rec, Mapping):
        raise DataFormatError(f"{where}: expected a JSON object with 'model' and 'parameters'")
    for key in ("model", "parameters"):
        if key not in rec:
            raise DataFormatError(f"{where}: missing key {key!r}")
    params = rec["parameters"]
    if not isinstance(params, Mapping):
        raise DataFormatError(f"{where}: 'parameters' must be an object of name: value")
    rings = rec.get("rings")
    if rings is None and not rec.get("terms"):
        # an older record without the ring count: count the ring permeances it holds
        rings = sum(1 for k in params if k.startswith("P") and k[1:].isdigit()) or None
    try:
        model = model_from_dict({**rec, "rings": rings, "parameters": rec.get("priors")}, where=where)
    except ValueError as exc:
        if rings is not None and rec.get("rings") is None and "applies to NL and UL only" in str(exc):
            model = model_from_dict({**rec, "rings": None, "parameters": None}, where=where)
        else:
            raise DataFormatError(str(exc) if str(exc).startswith(where) else f"{where}: {exc}") from None
    values = {}
    for k, v in params.items():
        # JSON null, a string or a boolean is no number: name the parameter (float(None) would not)
        if v is None or isinstance(v, bool) or not isinstance(v, int | float):
            unit = next((s.unit for s in model.params if s.name == k), None)
            raise DataFormatError(f"{where}: parameter {k!r} is {json.dumps(v)}; give a number"
                                  + (f" [{unit}]" if unit else ""))
        values[k] = float(v)
    try:
        theta = model.vector(values)
    except (KeyError, TypeError, ValueError) as exc:
        raise DataFormatError(f"{where}: {exc}") from None
    bad = [n for n, v in zip(model.names, theta, strict=True) if not math.isfinite(v)]
    if bad:
        raise DataFormatError(f"{where}: non-finite value for {bad}")
    outside = [s.name for s, v in zip(model.params, theta, strict=True)
               if not np.isfinite(s.prior.logpdf(v))]
    if outside:
        raise DataFormatError(f"{where}: value outside the physical range for {outside}")
    return model, theta


def read_param_file(path: str | Path) -> tuple[Model, np.ndarray]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataFormatError(f"{path}: no such file") from None
    except UnicodeDecodeError:
        raise DataFormatError(f"{path}: not a text (JSON) file") from None
    try:
        rec = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFormatError(f"{path}: line {exc.lineno}: invalid JSON ({exc.msg})") from None
    return model_from_record(rec, where=str(path))


def param_record(model: Model, theta) -> dict:
    """The parameter-file record of ``model`` at ``theta``: ``{"model": spec, "rings", "n_turns",
    "terms", "priors", "parameters": {name: value}}`` [SI]; :func:`model_from_record` rebuilds the
    same model (terms, configuration and priors) and vector."""
    d = model.to_dict()
    return {"model": d["spec"], "rings": d["rings"], "n_turns": d["n_turns"], "terms": d["terms"],
            "priors": d["parameters"], "parameters": model.as_dict(theta)}


def write_json(path: str | Path, obj) -> None:
    """Write ``obj`` as indented strict JSON (a non-finite number is ``null``), atomically."""
    atomic_write_text(path, json.dumps(strict_json(obj), indent=2, sort_keys=False, allow_nan=False) + "\n")
