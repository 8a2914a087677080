"""The public verbs: read a measurement, fit a model, sample its posterior, design a shunt, and
read back any saved posterior. Each is a thin, documented entry to the layer that does the work::

    import bayes_emt as be
    meas = be.read("speaker.zma")
    fit = be.fit(meas, "UD")
    post = be.sample(meas, "UD", fit=fit, seed=1)
    design = be.design_shunt(fit)
"""

from __future__ import annotations

from pathlib import Path

from .estimation.fitting import fit_admittance
from .estimation.results import FitResult
from .inference.posterior import Posterior, posterior_from_datatree
from .inference.sampling import sample_posterior
from .io import read_measurement
from .measurement import Measurement
from .models import Model, build_model
from .shunt import ShuntDesign, design_rc_shunt

__all__ = ["read", "fit", "sample", "design_shunt", "read_posterior", "as_model"]


def as_model(model: Model | str, *, rings: int | None = None) -> Model:
    """A :class:`~bayes_emt.models.Model` from a model or its name (``rings`` for NL/UL)."""
    return model if isinstance(model, Model) else build_model(model, rings=rings)


def read(path: str | Path, **options) -> Measurement:
    """Read a measurement file (``.zma``, CSV/TSV with a header, Touchstone): see
    :func:`~bayes_emt.io.read_measurement` for ``freq_unit``, ``phase_unit`` and ``quantity``."""
    return read_measurement(path, **options)


def fit(meas: Measurement, model: Model | str, *, rings: int | None = None, **options) -> FitResult:
    """Automatic initial estimate + two-step least squares
    (:func:`~bayes_emt.estimation.fitting.fit_admittance`)."""
    return fit_admittance(meas, as_model(model, rings=rings), **options)


def sample(meas: Measurement, model: Model | str, *, rings: int | None = None, **options) -> Posterior:
    """The posterior by emcee (:func:`~bayes_emt.inference.sampling.sample_posterior`)."""
    return sample_posterior(meas, as_model(model, rings=rings), **options)


def design_shunt(fit_or_model: FitResult | Model, theta=None, **options) -> ShuntDesign:
    """The H∞-optimal RC shunt (:func:`~bayes_emt.shunt.design_rc_shunt`) for a fit, or for a model
    and its parameter vector."""
    if isinstance(fit_or_model, FitResult):
        return design_rc_shunt(fit_or_model.model, fit_or_model.theta, **options)
    return design_rc_shunt(fit_or_model, theta, **options)


def read_posterior(path: str | Path):
    """Any saved posterior (:meth:`Posterior.save`, the added-mass pair's too), by its ``kind``."""
    import arviz as az

    dt = az.from_netcdf(path)
    if dt.attrs.get("kind") == "added_mass":
        from .added_mass.posterior import read_added_mass_posterior

        return read_added_mass_posterior(dt)
    return posterior_from_datatree(dt, where=str(path))
