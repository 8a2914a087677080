"""Prior overrides applied to a run: a model's parameters and the likelihood's noise parameters.

The override mapping ``{name: {"dist": ..., field: value}}`` is what
:func:`~bayes_emt.io.priorfile.read_prior_file` reads from a TOML or JSON file (format in that
module). A name the run does not have, an unknown distribution or a bad field raises
:class:`~bayes_emt.errors.DataFormatError` naming the file and the parameter.

Changing priors changes what an evidence means: compare models only under the same priors for
the parameters they share.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..errors import DataFormatError
from ..io.priorfile import read_prior_file
from ..models import Model
from ..params import ParamSet, noise_param_set, prior_from_dict

__all__ = ["apply_priors", "apply_prior_file"]


def apply_priors(model: Model, overrides: Mapping[str, Mapping], *, noise_params: ParamSet | None = None,
                 where: str = "priors") -> tuple[Model, ParamSet]:
    """``(model, noise_params)`` with the priors of ``overrides`` applied.

    Parameters
    ----------
    model : the model whose parameter priors may be overridden.
    overrides : ``{name: {"dist": ..., ...}}`` (see module docstring).
    noise_params : the run's noise parameters (default :func:`~bayes_emt.inference.likelihood.noise_param_set`
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
