"""Starting an augmented model from its base fit: each catalogue term proposes its own starts.

An augmentation (a catalogue term) is started from the fit of the model without it and the term's own
:meth:`~bayes_emt.models.term.Term.start` (a multi-start over the frequency where it acts, from
the base fit's misfit; a start may also move base parameters, e.g. a vented box's driver
resonance). The candidates are validated inside the prior support and ranked by the rms relative
residual of the augmented model; :func:`~bayes_emt.estimation.fitting.fit_admittance` then runs
its usual steps from the best few.
"""

from __future__ import annotations

import numpy as np

from ..measurement import Measurement
from ..models import Model, StartContext, Term
from ..models.residual import rms_relative_residual
from .checks import locate_resonance

__all__ = ["augmentation_starts", "validated", "rms_rel_residual"]

#: the augmented fit's starts (best first) handed on to the least-squares steps
MAX_STARTS = 6


def validated(model: Model, theta) -> np.ndarray | None:
    """``theta`` moved strictly inside the prior support, or ``None`` if it is not finite or has
    a non-positive value where the parameter must be positive (log transform)."""
    with np.errstate(all="ignore"):
        z = model.params.to_z(theta)
    if not np.all(np.isfinite(z)):
        return None
    return model.params.from_z(model.params.clip_inside(z))


def rms_rel_residual(model: Model, meas: Measurement, thetas) -> np.ndarray:
    """rms relative residual ``sqrt(mean |Y(θ) − Y|²/|Y|²)`` of each row of ``thetas`` (non-finite → inf)."""
    with np.errstate(all="ignore"):
        err = rms_relative_residual(model, thetas, meas)
    return np.where(np.isfinite(err), err, np.inf)


def augmentation_starts(meas: Measurement, model: Model, theta, term: Term, *,
                        band: tuple[float, float] | None = None,
                        max_starts: int = MAX_STARTS) -> tuple[Model, list[np.ndarray]]:
    """``(model + term, starts)``: full parameter vectors of the augmented model, best first.

    Parameters
    ----------
    meas : the measurement; model, theta : the model without ``term`` and its fitted values [SI].
    term : the augmentation (its priors as given).
    band : ``(lo, hi)`` [rad/s] where a mismatch was located (the term's start looks there), or
        ``None`` for the whole band.

    Raises
    ------
    ValueError : the term proposes no start inside its prior support.
    """
    new = model.with_term(term.bind(meas.omega))
    theta = np.asarray(theta, float)
    res = locate_resonance(meas)
    ctx = StartContext(meas.omega, meas.Y, model.admittance(meas.omega, theta), model.as_dict(theta),
                       None if res is None else (res.omega, res.omega_lo, res.omega_hi), band)
    base = model.as_dict(theta)
    cands = []
    for c in new.terms[-1].start(ctx):
        vals = dict(base)
        vals.update({k: float(v) for k, v in c.items() if k in base})
        missing = [n for n in term.names if n not in c]
        if missing:
            raise ValueError(f"term {term.id}: its start gives no value for {missing}")
        vals.update({n: float(c[n]) for n in term.names})
        th = validated(new, new.vector(vals))
        if th is not None:
            cands.append(th)
    if not cands:
        raise ValueError(f"term {term.id}: no start inside its prior support on {meas.source}")
    cands = np.array(cands)
    err = rms_rel_residual(new, meas, cands)
    order = np.argsort(err, kind="stable")
    picked = []
    for i in order:
        z = new.params.to_z(cands[i])
        if all(np.max(np.abs(z - new.params.to_z(cands[j]))) > 1e-3 for j in picked):
            picked.append(int(i))
        if len(picked) == max_starts:
            break
    return new, [cands[i] for i in picked]
