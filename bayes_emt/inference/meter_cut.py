"""A posterior under an ohmmeter reading's cut (:mod:`bayes_emt.estimation.meter`): sample with
``R0`` held at the reading, then move every draw to the cut posterior.

:func:`held_fit` gives the sampler its start (the fit's covariance given ``R0``, ``R0`` held
``sd·PIN`` wide, as the prior :meth:`~bayes_emt.estimation.meter.Meter.prior` holds it);
:func:`cut_posterior` draws ``R0`` from the reading (seeded) and moves each draw along the fit's
regression on ``R0``; the record then carries the reading itself as ``R0``'s prior, its log
posterior and log-likelihood are recomputed at the moved draws, and ``settings["re"]`` says what
was done.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..estimation.meter import Meter, cut_rng, held_covariance, move_draws
from ..estimation.results import FitResult
from .posterior import Posterior

__all__ = ["held_fit", "cut_posterior", "cut_regression", "sample_with_meter"]


def cut_regression(fit: FitResult, n_params: int) -> tuple[int, np.ndarray, float]:
    """``(i, g, sd_z)`` of a cut fit (``fit_admittance(..., re=Meter(..., mode="cut"))``): the index
    of ``R0``, each parameter's regression on it per ohm (zero for the ``n_params − k`` noise
    parameters after the model's ``k``) and the reading's sd in the fit's sampling space."""
    re = fit.info.get("re") or {}
    if re.get("mode") != "cut" or "sensitivity_per_ohm" not in re:
        raise ValueError("the fit was not made under an ohmmeter reading's cut (re=..., mode cut)")
    g = np.zeros(n_params)
    sens = np.asarray(re["sensitivity_per_ohm"], float)
    g[: sens.size] = sens
    return fit.model.names.index("R0"), g, float(re["sd_z"])


def held_fit(fit: FitResult, meter: Meter) -> FitResult:
    """The cut fit with its covariance given ``R0`` (``R0`` itself ``sd·PIN`` wide): the sampler's
    start when it samples with ``R0`` held."""
    i, g, sd_z = cut_regression(fit, fit.model.ndim)
    if fit.cov_z is None:
        return fit
    return replace(fit, cov_z=held_covariance(fit.cov_z, i, g, sd_z, meter))


def cut_posterior(post: Posterior, fit: FitResult, meter: Meter, seed: int) -> Posterior:
    """``post`` (sampled with ``R0`` held by ``meter.prior()``) moved to the cut posterior: ``R0``
    from ``N(value, sd)`` (its own stream from ``seed``) and every other parameter along the fit's
    regression on ``R0``."""
    lik = post.likelihood
    i, g, _ = cut_regression(fit, len(lik.params))
    for j, (a, b) in enumerate(zip(fit.model.params, lik.params, strict=False)):
        if j != i and (a.name != b.name or a.transform != b.transform):
            raise ValueError(f"cut_posterior: the fit's {a.name} and the posterior's {b.name} differ in "
                             "name or sampling space")
    moved = move_draws(post.draws, lik.params, i, g, meter, cut_rng(seed))
    new_lik = replace(lik, model=lik.model.with_priors({"R0": meter.reading_prior()}, where="--re"))
    shape = moved.shape[:-1]
    lp, ll = new_lik.log_prob_z(new_lik.params.to_z(moved.reshape(-1, moved.shape[-1])))
    settings = {**dict(post.settings),
                "re": {**meter.to_dict(), "how": "sampled with R0 held at the reading, then each draw moved "
                                                 "along the fit's regression on R0 by a draw of the reading"}}
    return replace(post, likelihood=new_lik, draws=moved, log_prob=lp.reshape(shape),
                   log_lik=ll.reshape(shape), settings=settings)


def sample_with_meter(meas, model, meter: Meter, *, fit: FitResult | None = None, seed: int = 0,
                      **options) -> Posterior:
    """The posterior of ``model`` given ``meas`` and an ohmmeter reading ``meter``: under the cut,
    sampled with ``R0`` held and moved (:func:`cut_posterior`); under ``"prior"``, with the reading as
    ``R0``'s Normal prior. ``fit``: a fit of ``model`` under the same reading (made here when not
    given, or when it was made without it); ``options`` go to
    :func:`~bayes_emt.inference.sampling.sample_posterior`."""
    from ..estimation.fitting import fit_admittance
    from .sampling import sample_posterior

    held = model.with_priors({"R0": meter.prior()}, where="re")
    made = (fit.info.get("re") or {}) if fit is not None else {}
    if fit is None or made.get("mode") != meter.mode or made.get("value") != meter.value \
            or made.get("sd") != meter.sd:
        fit = fit_admittance(meas, held, re=meter)
    if not meter.cut:
        return sample_posterior(meas, held, fit=fit, seed=seed, **options)
    post = sample_posterior(meas, held, fit=held_fit(fit, meter), seed=seed, **options)
    return cut_posterior(post, fit, meter, seed)
