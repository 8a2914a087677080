"""User prior overrides from a TOML or JSON file.

Format (TOML shown; JSON is the same mapping ``{name: {"dist": ..., ...}}``)::

    [R0]                  # a datasheet value: log-normal around 2.6 ohm, 5 % spread
    dist = "lognormal"
    median = 2.6          # ohm
    sigma_log = 0.05

    [omega0]
    dist = "uniform"
    lower = 40.0          # rad/s
    upper = 60.0

    [sigma_rel]           # the instrument's stated accuracy
    dist = "loguniform"
    lower = 1e-4
    upper = 1e-2

Distributions and their fields (SI units of the parameter): ``loguniform`` (lower, upper),
``uniform`` (lower, upper), ``normal`` (mu, sigma), ``lognormal`` (median, sigma_log).
Any model parameter (``bayes-emt info`` lists them), the noise scales ``sigma_rel`` [1] and
``sigma_abs`` [S], and ``nu`` (Student-t with sampled ν) may be named; the others keep the
catalogue's priors (:mod:`bayes_emt.params`). A name the run does not have, an unknown
distribution or a bad field raises :class:`~bayes_emt.errors.DataFormatError` naming the file
and the parameter.

Changing priors changes what an evidence means: compare models only under the same priors for
the parameters they share.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from ..errors import DataFormatError

__all__ = ["read_prior_file"]


def read_prior_file(path: str | Path) -> dict[str, dict]:
    """The ``{name: {"dist": ..., field: value}}`` mapping of a ``.toml`` or ``.json`` file
    (the suffix decides; anything else is read as TOML)."""
    path = Path(path)
    if not path.exists():
        raise DataFormatError(f"{path}: no such prior file")
    if path.is_dir():
        raise DataFormatError(f"{path}: is a folder, not a prior file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise DataFormatError(f"{path}: not a text file (expected TOML or JSON)") from None
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFormatError(f"{path}: line {exc.lineno}: invalid JSON ({exc.msg})") from None
    except tomllib.TOMLDecodeError as exc:
        raise DataFormatError(f"{path}: invalid TOML ({exc})") from None
    if not isinstance(data, dict):
        raise DataFormatError(f"{path}: expected a table per parameter, e.g. [R0] dist = \"uniform\" ...")
    for name, spec in data.items():
        if not isinstance(spec, dict):
            raise DataFormatError(f"{path}: {name}: expected a table such as "
                                  f"{{dist = \"loguniform\", lower = ..., upper = ...}}, got {spec!r}")
    return data
