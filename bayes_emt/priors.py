"""User prior overrides from a TOML or JSON file.

Format (TOML shown; JSON is the same mapping)::

    [R0]
    dist = "lognormal"
    median = 2.6      # ohm
    sigma_log = 0.05

    [omega0]
    dist = "uniform"
    lower = 40.0
    upper = 60.0

Parameters not named keep the catalogue's priors (params.py); unknown names, unknown
distributions and bad fields raise, naming the file and the parameter.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from .errors import DataFormatError
from .models import Model

__all__ = ["read_prior_file", "apply_prior_file"]


def read_prior_file(path: str | Path) -> dict:
    path = Path(path)
    if not path.exists():
        raise DataFormatError(f"{path}: no such prior file")
    text = path.read_text(encoding="utf-8")
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFormatError(f"{path}: line {exc.lineno}: invalid JSON ({exc.msg})") from None
    except tomllib.TOMLDecodeError as exc:
        raise DataFormatError(f"{path}: invalid TOML ({exc})") from None
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise DataFormatError(f"{path}: expected a table per parameter, e.g. [R0] dist = \"uniform\" ...")
    return data


def apply_prior_file(model: Model, path: str | Path) -> Model:
    """``model`` with the priors of ``path`` (noise parameters are not overridable here)."""
    data = read_prior_file(path)
    try:
        return model.with_priors(data, where=str(path))
    except (KeyError, ValueError) as exc:
        msg = exc.args[0] if exc.args else str(exc)
        raise DataFormatError(str(msg)) from None
