"""Showing ``P(unstable) ≤ ε`` for a fixed shunt from posterior draws it was not chosen on.

**Method**: a validation test of a fixed design on independent samples (the sample size of Tempo,
Bai & Dabbene, *Syst. Control Lett.* 30 (1997) 237–242; the same count bounds the a-posteriori check
of a scenario design, Campi & Garatti, *SIAM J. Optim.* 19 (2008) 1211–1230). The shunt is
chosen on the design half of the draws; every other kept draw of the posterior (the held-back half
and the draws the mixture did not pick) is independent of that choice. If ``k`` of ``N`` such
draws are unstable, the one-sided exact binomial (Clopper–Pearson) bound

    p̄ = Beta⁻¹(1 − β; k + 1, N − k)       (k = 0:  p̄ = 1 − β^{1/N})

holds with confidence ``1 − β``: ``P(unstable) ≤ p̄``. ``P(unstable) ≤ ε`` is *shown* when
``p̄ ≤ ε``; with none unstable that needs ``N ≥ ln β / ln(1 − ε)`` (≈ ``ln(1/β)/ε``: 2995 draws for
``ε = 1e-3`` at 95 %). MCMC draws are correlated: the counts are scaled by the posterior's effective
sample size per kept draw (≤ 1) before the bound is taken, and the number of draws needed is
divided by it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

__all__ = ["upper_bound", "draws_needed", "instability_bound", "auto_epsilon", "EPSILON_LADDER"]

#: the bounds ``epsilon="auto"`` chooses from (a 1-2-5 ladder)
EPSILON_LADDER = (1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1)


def upper_bound(k: float, n: float, confidence: float = 0.95) -> float:
    """One-sided exact binomial upper bound on ``P`` after ``k`` events in ``n`` trials (module
    docstring); ``k``, ``n`` may be effective (non-integer) counts."""
    if not (n > 0 and 0 <= k <= n):
        raise ValueError(f"need 0 <= k <= n and n > 0, got k={k!r}, n={n!r}")
    if k >= n:
        return 1.0
    return float(stats.beta.ppf(confidence, k + 1, n - k))


def draws_needed(epsilon: float, confidence: float = 0.95, ess_fraction: float = 1.0) -> int | None:
    """Draws, none unstable, that show ``P(unstable) ≤ epsilon`` at ``confidence``; None for
    ``epsilon = 0`` (no finite number does)."""
    if epsilon <= 0:
        return None
    n = math.log(1 - confidence) / math.log1p(-epsilon)
    return int(math.ceil(n / max(min(ess_fraction, 1.0), 1e-12) - 1e-9))


def instability_bound(stable_per_model: dict, epsilon: float, confidence: float = 0.95,
                      ess_fraction: float = 1.0, available: dict | None = None) -> dict:
    """The record of the test (module docstring) for one shunt: ``stable_per_model`` maps a model
    label to the ``(N,)`` stability of the draws the shunt was not chosen on; ``available`` the
    model's kept draws (for the message). Keys: ``method``, ``confidence``, ``epsilon``,
    ``draws_needed``, ``shown`` (every model's bound ≤ ε), ``per_model`` (``n_checked``,
    ``n_unstable``, ``upper_bound``, ``shown``)."""
    per, shown = {}, True
    need = draws_needed(epsilon, confidence, ess_fraction)
    for label, st in stable_per_model.items():
        st = np.asarray(st, bool)
        n, k = int(st.size), int(np.count_nonzero(~st))
        ub = upper_bound(k * ess_fraction, n * ess_fraction, confidence) if n else 1.0
        ok = bool(ub <= epsilon)
        shown &= ok
        per[label] = {"n_checked": n, "n_unstable": k, "upper_bound": ub, "shown": ok,
                      "draws_available": None if available is None else available.get(label)}
    return {"method": "fixed shunt tested on posterior draws it was not chosen on (held-back half and "
                      "unpicked kept draws); one-sided exact binomial (Clopper-Pearson) bound, counts "
                      "scaled by the ESS per draw",
            "confidence": confidence, "epsilon": epsilon, "ess_fraction": ess_fraction,
            "draws_needed": need, "shown": bool(shown and per), "per_model": per}


def auto_epsilon(unseen: dict, confidence: float = 0.95, ess_fraction: float = 1.0) -> tuple[float, dict]:
    """The smallest bound of :data:`EPSILON_LADDER` a run can show: ``unseen`` maps each model label
    to the number of its kept draws the robust choice will not see (the held-back half and the kept
    draws the mixture did not pick). Rule: the smallest ``ε`` with
    ``N_unseen · ess ≥ ln(1 − confidence) / ln(1 − ε)`` for every model, i.e. none unstable among
    them shows ``P(unstable) ≤ ε`` (module docstring); where no model has enough (or draws were
    repeated, ``N_unseen ≤ 0``) the ladder's first value, and the record says the bound cannot be
    shown. Returns ``(ε, record)``."""
    n = min(unseen.values()) if unseen else 0
    need = {e: draws_needed(e, confidence, ess_fraction) for e in EPSILON_LADDER}
    fit = [e for e in EPSILON_LADDER if n > 0 and need[e] <= n]
    eps = fit[0] if fit else EPSILON_LADDER[0]
    rule = (f"epsilon auto: the smallest of {', '.join(f'{e:g}' for e in EPSILON_LADDER)} that the draws "
            f"the choice never sees can show (none unstable among N_unseen x ESS fraction >= "
            f"ln(1 - confidence)/ln(1 - epsilon), one-sided exact binomial at {confidence:.0%})")
    rec = {"rule": rule, "epsilon": eps, "unseen_draws": {k: int(v) for k, v in unseen.items()},
           "ess_fraction": ess_fraction, "draws_needed": need[eps], "showable": bool(fit)}
    return eps, rec
