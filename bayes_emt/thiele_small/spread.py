"""The model spread of a T/S result: which candidate coil models count, and in what order.

A candidate counts when its rms relative residual is within :data:`ADEQUATE_RMS_FACTOR` of the
best, every parameter is determined (:func:`undetermined`) and its posterior model probability
(Laplace evidence, equal prior odds) is at least :data:`SPREAD_MIN_PROBABILITY`
(:func:`select_spread_models`); :func:`rank_key` orders candidates for the evidence-supported
default model.
"""

from __future__ import annotations

import math

import numpy as np

from ..models import Model, parse_model_spec

__all__ = ["ADEQUATE_RMS_FACTOR", "SPREAD_MIN_PROBABILITY", "MODEL_SPREAD_METHOD", "DEFAULT_SPREAD_BASES",
           "undetermined", "select_spread_models", "rank_key", "spread_models"]

ADEQUATE_RMS_FACTOR = 1.5
#: smallest posterior model probability (equal prior odds, Laplace evidence) that enters the spread
SPREAD_MIN_PROBABILITY = 0.01
MODEL_SPREAD_METHOD = (
    f"range of the least-squares values over the candidate models whose rms relative residual is within "
    f"{ADEQUATE_RMS_FACTOR}x the best, whose parameters are all determined (finite standard error below the "
    "value, none at a prior edge) and whose posterior model probability (Laplace evidence, equal prior "
    f"odds) is at least {SPREAD_MIN_PROBABILITY:g}; candidates whose evidence could not be computed are kept "
    "unweighted; a candidate other than the main model with an undetermined parameter carries no weight and "
    "its evidence is not computed; nor is that of a candidate whose largest likelihood is more than 25 nats "
    "below the best evidence (probability below 1e-10 whatever its evidence: the evidence is at most the "
    "largest likelihood), which has probability 0")
#: the coil models every T/S result is weighed against (the evidence-supported default ranks the same
#: ones): the lossy-inductance, the uniform-core eddy-current models and the ring ladder with two and
#: three rings (NL's ring count by evidence; with three, the gap inductance Pg often sits at its
#: prior's edge on real woofers, and that candidate then carries no weight, while NL(2) does)
DEFAULT_SPREAD_BASES = ("II", "III", "UD", "NL(2)", "NL(3)")


def undetermined(params, theta, cov_z) -> list[str]:
    """Parameters of a least-squares estimate the data do not determine: no covariance (all of
    them), a standard error above the value (log parameters: ``sd(log x) > 1``), or a value within
    :data:`~bayes_emt.estimation.adequacy.AT_BOUND_FRAC` of its prior support's width of an edge
    (sampling space). The rules of the fit's ``not_identifiable`` and ``parameter_at_bound``
    warnings, applied to any ParamSet (a joint added-mass vector too)."""
    from ..estimation.adequacy import edges_reached, relative_sd

    theta = np.asarray(theta, float).ravel()
    if cov_z is None or not np.all(np.isfinite(np.diag(cov_z))):
        return list(params.names)
    flagged = set(np.flatnonzero(relative_sd(params, theta, cov_z) > 1).tolist())
    flagged |= {i for i, _ in edges_reached(params, params.to_z(theta), *params.bounds_z())}
    return [params[i].name for i in sorted(flagged)]


def select_spread_models(records: list[dict]) -> list[dict]:
    """The spread rule (module docstring) on ``records`` ``{"model", "rms", "undetermined",
    "log_z"}`` (``log_z`` nan when not computed; with ``log_z_upper``, an upper bound far below the
    best evidence, the probability is 0): returns them with ``adequate``, ``determined``,
    ``probability`` (None without evidence) and ``included`` added; ``included`` marks the models
    whose values make the spread."""
    out = [dict(r) for r in records]
    best = min(r["rms"] for r in out)
    for r in out:
        r["adequate"] = bool(r["rms"] <= ADEQUATE_RMS_FACTOR * best)
        r["determined"] = not r["undetermined"]
        r["probability"] = None
    pool = [r for r in out if r["adequate"] and r["determined"]]
    with_z = [r for r in pool if math.isfinite(r["log_z"])]
    if with_z:
        lz = np.array([r["log_z"] for r in with_z])
        w = np.exp(lz - lz.max())
        for r, p in zip(with_z, w / w.sum(), strict=True):
            r["probability"] = float(p)
    for r in pool:  # evidence bounded far below the best (its largest likelihood): probability < 1e-10
        if r["probability"] is None and "log_z_upper" in r and with_z:
            r["probability"] = 0.0
    for r in out:
        probable = r["probability"] is None or r["probability"] >= SPREAD_MIN_PROBABILITY
        r["included"] = bool(any(r is q for q in pool) and probable)
    return out


def rank_key(rec: dict) -> tuple:
    """Order of candidates for the default model: determined first, then by log evidence."""
    lz = rec["log_z"]
    return (not rec["undetermined"], math.isfinite(lz), lz if math.isfinite(lz) else -math.inf)


def spread_models(main: Model, models_for_spread, model_of, terms=()) -> list[Model]:
    """The candidate models of the spread: ``models_for_spread`` (through ``model_of``), else
    :data:`DEFAULT_SPREAD_BASES` with the main model's physics terms, and the main model with each
    of ``terms`` it does not hold (the physics the evidence-supported default also tries, so that a
    requested model that leaves it out is weighed against it); the main model left out."""
    if models_for_spread is not None:
        cands = [model_of(m) for m in models_for_spread]
    else:
        suffix = "".join(f"+{t.id}" for t in main.augmentations)
        cands = [parse_model_spec(b + suffix) for b in DEFAULT_SPREAD_BASES]
        held = {t.id for t in main.augmentations}
        cands += [parse_model_spec(f"{main.label}+{t}") for t in terms if t not in held]
    out, seen = [], {main.label}
    for m in cands:
        if m.label not in seen:
            seen.add(m.label)
            out.append(m)
    return out
