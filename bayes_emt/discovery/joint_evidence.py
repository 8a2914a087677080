"""The joint evidence of a finding: is it one term the two recordings share?

For a finding of recording A's diagnosis (its final model ``M``; ``M0``: ``M`` with the finding taken
out) and a second recording B of the same transducer, three hypotheses about the pair are weighed,
each by one log evidence of both recordings together (:func:`bayes_emt.evidence.joint.joint_log_evidence`,
the Laplace approximation of ``∫ p(Y_A|θ_A) p(Y_B|θ_B) p(x) dx``) under
:class:`~bayes_emt.added_mass.pair.PairModel`: every parameter the two runs' models have in common is
shared (the coil, the finding's own parameters, the other terms), except each recording's mechanics
``ζ, ω0, φ̄`` (:data:`PER_RUN`: a mass on the cone, another mounting or session moves them; the
caller may add ``R0``, which the coil's temperature moves between sessions; with a known added mass
the joint added-mass fit is reported beside, not used here):

* **shared**: both recordings under ``M``, the finding's parameters one set of values;
* **neither**: both under ``M0``;
* **first only**: A under ``M``, B under ``M0`` (the finding is A's alone: a session effect, a
  fixture resonance of A's mounting).

``Δ log Z_joint = log Z(shared) − max(log Z(neither), log Z(first only))``; at or above
:data:`~bayes_emt.discovery.name.MIN_DELTA_LOG_Z` the finding is one physics the pair shares. The
third hypothesis is needed: against "neither" alone, a term only A has would pass, since one shared
set of values halfway between A's feature and B's flat curve fits the pair better than no term.
A term B needs with other values (another feature there) loses to "first only" or wins only by
values that fit neither recording well; that case is also caught by the separate fits' values
(:func:`bayes_emt.discovery.joint.value_disagreements`), which flag it whatever its joint evidence.
"""

from __future__ import annotations

import math

from ..added_mass.pair import PairLikelihood, PairModel, fit_pair
from ..errors import FitError
from ..estimation.results import FitResult
from ..evidence.joint import joint_log_evidence
from ..measurement import Measurement

__all__ = ["pair_log_evidence", "finding_joint_evidence", "PER_RUN", "JOINT_METHOD"]

#: each recording's own parameters in the joint evidence (all others shared)
PER_RUN = ("zeta", "omega0", "phi")
#: the record's name of the method
JOINT_METHOD = "laplace-joint"


def pair_log_evidence(meas: Measurement, other: Measurement, fit_a: FitResult, fit_b: FitResult,
                      per_run=PER_RUN) -> tuple[float, str]:
    """``(log Z [nats], estimator)`` of both recordings together, ``meas`` under ``fit_a.model`` and
    ``other`` under ``fit_b.model`` (:class:`~bayes_emt.added_mass.pair.PairModel`, ``per_run`` each
    recording's own), started at their joint least-squares fit from the two separate fits;
    ``(nan, "failed: why")`` when the joint fit or its evidence fails."""
    try:
        joint = PairModel(fit_a.model, fit_b.model, tuple(per_run))
        pf = fit_pair((meas, other), joint, (fit_a, fit_b))
        ev = joint_log_evidence(PairLikelihood(joint, (meas, other)), pf)
    except (FitError, ValueError) as exc:
        return math.nan, f"failed: {exc}"
    if not math.isfinite(ev.log_z):
        return math.nan, f"failed: {ev.note}"
    return float(ev.log_z), ev.method


def finding_joint_evidence(meas: Measurement, other: Measurement, final: tuple[FitResult, FitResult],
                           without: tuple[FitResult, FitResult], shared: tuple[float, str] | None = None,
                           per_run=PER_RUN) -> dict:
    """The three joint log evidences of one finding (module docstring) from the separate fits of
    ``meas`` and ``other`` with the final model (``final``) and without the finding (``without``);
    ``shared``: the first one when already computed (it is the same for every finding).
    ``{"shared", "neither", "first_only"}`` [nats, ``None`` when failed], ``"estimators"``,
    ``"delta_log_z_joint"`` [nats] (``None`` when ``shared`` or both alternatives failed),
    ``"best_alternative"``."""
    lz_s = shared if shared is not None else pair_log_evidence(meas, other, *final, per_run)
    lz_n = pair_log_evidence(meas, other, *without, per_run)
    lz_f = pair_log_evidence(meas, other, final[0], without[1], per_run)
    alts = {"neither": lz_n[0], "first_only": lz_f[0]}
    finite = {k: v for k, v in alts.items() if math.isfinite(v)}
    best = max(finite, key=finite.get) if finite else None
    d = lz_s[0] - finite[best] if best is not None and math.isfinite(lz_s[0]) else math.nan
    return {"shared": lz_s[0] if math.isfinite(lz_s[0]) else None,
            **{k: (v if math.isfinite(v) else None) for k, v in alts.items()},
            "estimators": {"shared": lz_s[1], "neither": lz_n[1], "first_only": lz_f[1]},
            "delta_log_z_joint": d if math.isfinite(d) else None, "best_alternative": best}

