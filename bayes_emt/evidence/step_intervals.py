"""The log evidence of a model holding an instrument step, its step frequency marginalised exactly.

A step term (:attr:`~bayes_emt.models.term.Term.step_at`, e.g. ``measurement_artifact``'s ``ωs``)
multiplies the measured admittance above ``ωs``. The likelihood depends on ``ωs`` only through which
two measured frequencies it lies between: it is constant inside each interval ``(ω_{j−1}, ω_j)``
and jumps at the points. Neither the Laplace screen nor its subspace fallback suits that: the
screen takes a finite-difference curvature across a jump (a width that is not there; on simulated
steps its log Z came out 5-6 nats above the sum below), and the fallback's importance sampling from
a box times Gaussians can leave too few effective draws to give any number (4 of 4000 on a UD plant
with a phase step 25 times the noise, so the step was not a candidate at all in that round).

Since the other parameters' priors do not involve ``ωs``, the evidence is a sum over the intervals::

    Z = Σ_j  Π_j · Z_j,    Π_j = ∫_{interval j} p(ωs) dωs,

``Z_j`` the evidence of the model with ``ωs`` held anywhere inside interval ``j`` (the likelihood
is the same there), by the Laplace screen over the other parameters, which are smooth. The prior
mass ``Π_j`` is integrated numerically in the sampling space of ``ωs`` (33 points). The sum starts at
the fit's interval and walks outward on each side until an interval's term falls
:data:`DROP_INTERVAL` nats below the largest (it then adds less than 5e-5 of it) or after
:data:`MAX_INTERVALS`; the intervals left out only add to ``Z``, so the number is a lower bound of
the step model's evidence, tight for a step the data place (each further interval's term falls
by hundreds of nats). Intervals outside the measured range (a step below the first or above the
last point) are not summed: there the step is an overall gain, not a step.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..measurement import Measurement
from .laplace import laplace_evidence
from .warp import Warp

__all__ = ["STEP_METHOD", "DROP_INTERVAL", "MAX_INTERVALS", "step_parameter", "step_interval_evidence"]

#: the :class:`~bayes_emt.evidence.fit_evidence.Evidence` method of this estimate
STEP_METHOD = "laplace_step"
#: nats below the largest interval's term at which the walk outward stops
DROP_INTERVAL = 10.0
#: intervals summed at most on each side of the fit's own
MAX_INTERVALS = 4
_PRIOR_POINTS = 33


def step_parameter(model) -> str | None:
    """The name of ``model``'s step frequency when it holds exactly one step term, else ``None``."""
    steps = [t.step_at for t in getattr(model, "augmentations", ()) if getattr(t, "step_at", "")]
    return steps[0] if len(steps) == 1 else None


def step_interval_evidence(meas: Measurement, lik, log_density_z, step_value: float, z0, scale, warp: Warp,
                           name: str) -> tuple[float, str] | None:
    """``(log Z, note)`` by the interval sum of the module docstring, or ``None`` when the Laplace
    screen fails in the fit's own interval. ``lik`` the likelihood (its ``params``), ``log_density_z``
    its vectorised log posterior in sampling space, ``step_value`` the fitted step frequency [rad/s],
    ``z0``/``scale``/``warp`` the screen's start (:func:`~bayes_emt.evidence.fit_evidence.fit_start`),
    ``name`` the step parameter's."""
    names = list(lik.params.names)
    s = names.index(name)
    keep = np.arange(len(names)) != s
    warp_r = Warp(warp.lo[keep], warp.hi[keep], None if warp.mask is None else warp.mask[keep])
    spec = lik.params[s]
    lo_z, hi_z = spec.bounds_z()
    om = meas.omega
    z0 = np.asarray(z0, float)
    scale = np.asarray(scale, float)

    def term(j):
        if j < 1 or j > om.size - 1:
            return None
        za, zb = max(float(spec.to_z(om[j - 1])), lo_z), min(float(spec.to_z(om[j])), hi_z)
        if not zb > za:
            return None
        zm = 0.5 * (za + zb)
        g = np.linspace(za, zb, _PRIOR_POINTS)
        with np.errstate(all="ignore"):
            lp = np.asarray(spec.log_prior_z(g), float)
            lp = lp - float(np.asarray(spec.log_prior_z(np.array([zm])))[0])
        mass = float(np.trapezoid(np.exp(np.where(np.isfinite(lp), lp, -np.inf)), g))
        if not mass > 0:
            return None

        def f(zr, zm=zm):
            zr = np.atleast_2d(np.asarray(zr, float))
            return log_density_z(np.insert(zr, s, zm, axis=1))

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = laplace_evidence(f, lik.params, z0[keep], scale[np.ix_(keep, keep)], warp=warp_r)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None
        if not (res.ok and math.isfinite(res.log_z)):
            return None
        # log Z_j with ωs's density at the midpoint replaced by its mass over the interval
        return float(res.log_z) + math.log(mass)

    k = int(np.searchsorted(om, step_value))
    best = term(k)
    if best is None:
        return None
    terms = [best]
    for side in (-1, 1):
        for i in range(1, MAX_INTERVALS + 1):
            v = term(k + side * i)
            if v is None:
                break
            terms.append(v)
            if v < max(terms) - DROP_INTERVAL:
                break
    log_z = float(np.logaddexp.reduce(terms))
    note = (f"the step frequency {name} marginalised over the {len(terms)} intervals between measured "
            f"points nearest its fit (the likelihood is constant inside each), Laplace over the other "
            f"parameters in each: {log_z:.1f} (a lower bound: the intervals further out add to it)")
    return log_z, note
