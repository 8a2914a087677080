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
from collections.abc import Mapping
from pathlib import Path

from .errors import DataFormatError
from .likelihood import noise_param_set
from .models import Model
from .params import ParamSet, prior_from_dict

__all__ = ["read_prior_file", "apply_priors", "apply_prior_file"]


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


def apply_priors(model: Model, overrides: Mapping[str, Mapping], *, noise_params: ParamSet | None = None,
                 where: str = "priors") -> tuple[Model, ParamSet]:
    """``(model, noise_params)`` with the priors of ``overrides`` applied.

    Parameters
    ----------
    model : the model whose parameter priors may be overridden.
    overrides : ``{name: {"dist": ..., ...}}`` (see module docstring).
    noise_params : the run's noise parameters (default :func:`~bayes_emt.likelihood.noise_param_set`
        of a Gaussian likelihood; pass ``noise_param_set("student", None)`` when ``nu`` is sampled).
    where : the file name (or other origin) used in error messages.
    """
    noise_params = noise_param_set() if noise_params is None else noise_params
    known = set(model.names) | set(noise_params.names)
    unknown = [n for n in overrides if n not in known]
    if unknown:
        hint = ""
        if "nu" in unknown:
            hint = " ('nu' has a prior only with --likelihood student --nu sample)"
        raise DataFormatError(f"{where}: unknown parameter(s) {unknown}; this run has "
                              f"{list(model.names) + list(noise_params.names)}{hint}")
    priors = {}
    for name, spec in overrides.items():
        if not isinstance(spec, Mapping):
            raise DataFormatError(f"{where}: {name}: expected a table of prior fields, got {spec!r}")
        try:
            priors[name] = prior_from_dict(spec, where=f"{where}: {name}")
        except ValueError as exc:
            msg = str(exc)
            raise DataFormatError(msg if msg.startswith(f"{where}: {name}") else f"{where}: {name}: {msg}") \
                from None
    mod = {n: v for n, v in priors.items() if n in model.names}
    noi = {n: v for n, v in priors.items() if n in noise_params.names}
    if mod:
        model = model.with_priors(mod, where=where)
    if noi:
        noise_params = noise_params.with_priors(noi, where=where)
    return model, noise_params


def apply_prior_file(model: Model, path: str | Path, *,
                     noise_params: ParamSet | None = None) -> tuple[Model, ParamSet]:
    """:func:`apply_priors` with the overrides read from ``path`` (TOML or JSON)."""
    return apply_priors(model, read_prior_file(path), noise_params=noise_params, where=str(path))
