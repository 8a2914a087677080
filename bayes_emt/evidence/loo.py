"""PSIS-LOO beside the evidence: predictive accuracy, not evidence (STACK.md).

``az.loo`` (ArviZ 1.x, Pareto-smoothed importance sampling, Vehtari, Gelman & Gabry 2017) on the
posterior's per-frequency log-likelihood (``log_likelihood`` group ``Y`` of
:meth:`~bayes_emt.inference.posterior.Posterior.to_datatree`): each frequency point is one
observation. Reported beside log Z: it asks how well a model predicts a left-out point, which
for 2000 dense points favours any model that fits, while the evidence also charges for prior
volume. Pareto ``k > 0.7`` at some frequencies makes the estimate unreliable there (and points
at badly fitted frequencies).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["psis_loo"]


def psis_loo(posterior) -> tuple[float | None, float | None, list[str]]:
    """``(elpd_loo, se, warnings)`` [nats] of a :class:`~bayes_emt.inference.posterior.Posterior`."""
    import arviz as az

    notes: list[str] = []
    try:
        dt = posterior.to_datatree()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = az.loo(dt, pointwise=True, var_name="Y")
        k = np.asarray(getattr(res, "pareto_k", np.array([])), float).ravel()
        bad = int(np.sum(k > 0.7)) if k.size else 0
        if bad:
            notes.append(f"PSIS-LOO: Pareto k > 0.7 at {bad} of {k.size} frequencies "
                         "(elpd_loo unreliable there)")
        elif any("pareto" in str(w.message).lower() for w in caught):
            notes.append("PSIS-LOO: " + str(caught[0].message))
        elpd, se = float(res.elpd), float(res.se)
        if not (math.isfinite(elpd) and math.isfinite(se)):
            notes.append("PSIS-LOO gave a non-finite elpd")
            return None, None, notes
        return elpd, se, notes
    except Exception as exc:  # a failed predictive check must not sink the evidence
        notes.append(f"PSIS-LOO failed: {type(exc).__name__}: {exc}")
        return None, None, notes
