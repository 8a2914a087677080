"""Foster (modal) realisation of the blocked impedance, for closed-loop poles and sampled-data plants.

    Ze(s) = R0 + G s + Σ_k L_k s / (1 + τ_k s)

built from the model's terms (:func:`bayes_emt.models.rational.foster_form`): exact for I, II, NL,
UL (and with lead or LR-2 terms); for III and UD the eddy-current modes of the Bessel ratio's
Mittag-Leffler expansion, the first ``sections`` kept and the rest lumped as an inductance, with
``|Ze_exact(s) − Ze(s)| ≤ E |s|²`` in the closed right half-plane (with the paper's Table 3 values
and ``K = 40``, ``E ≈ 3e-14 Ω s²``: ``|e| < 1e-9 Ω`` at the resonance and < 1e-3 Ω at 1e5 rad/s).
A model with a term that has no finite RL form (a capacitance across the terminals, another mode,
creep, a port, a semi-inductance) has none: stability then goes by the argument principle.
"""

from __future__ import annotations

import numpy as np

from ..models import Model
from ..models.rational import BESSEL_SECTIONS, Foster, foster_form, has_foster_form

__all__ = ["Foster", "foster_realisation", "BESSEL_SECTIONS", "has_foster_form"]


def foster_realisation(model: Model, theta, *, sections: int = BESSEL_SECTIONS) -> Foster:
    """The Foster form of ``Zc + R0`` for one parameter vector ``(k,)`` (module docstring).

    Raises
    ------
    ValueError
        For a model without a finite Foster form: use the argument-principle test of
        :mod:`bayes_emt.shunt.stability` instead.
    """
    theta = np.asarray(theta, float)
    if theta.ndim != 1:
        raise ValueError(f"foster_realisation takes one parameter vector, got shape {theta.shape}")
    f = foster_form(model, theta, sections=sections)
    if f is None:
        raise ValueError(f"model {model.label} has no finite Foster form (a term without an RL form)")
    return f
