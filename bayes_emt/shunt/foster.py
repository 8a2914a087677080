"""Foster (modal) realisation of the blocked coil impedance, for closed-loop poles and sampled-data plants.

Every one of the paper's six models has the form

    Ze(s) = Zc(s) + R0 = R0 + G s + Σ_k L_k s / (1 + τ_k s)

(``G`` [H] series inductance, sections ``L_k`` [H] in parallel with ``R_k = L_k/τ_k`` [Ω]).

* I, II, NL, UL: a finite Foster form, exact (:func:`bayes_emt.models.rational.foster_form`; NL/UL
  through the ring ladder's modal decomposition).
* III, UD: the Bessel ratio has the Mittag-Leffler expansion ``I1(w)/I0(w) = Σ_k 2w/(w² + j_k²)``
  (``j_k`` the zeros of ``J0``), so with ``w = sqrt(α s)``

      Z_III(s) = β sqrt(s) I1(w)/I0(w) = Σ_{k≥1} L_k s/(1 + τ_k s),  L_k = 2β sqrt(α)/j_k²,  τ_k = α/j_k²

  (the eddy-current modes of the core, an *infinite* Foster form). The first ``K`` sections are kept
  and the rest lumped as an inductance ``Σ_{k>K} L_k = β sqrt(α)/2 − Σ_{k≤K} L_k`` (since
  ``Σ 1/j_k² = 1/4``), so the low-frequency limit stays exact. The error
  ``e(s) = −Σ_{k>K} L_k τ_k s²/(1 + τ_k s)`` obeys, anywhere in the closed right half-plane
  (``|1 + τ s| ≥ 1``),

      |e(s)| ≤ E |s|²,   E = 2 β α^{3/2} Σ_{k>K} j_k⁻⁴ = 2 β α^{3/2} (1/32 − Σ_{k≤K} j_k⁻⁴)  [Ω s²]

  (Rayleigh's sum ``Σ j_k⁻⁴ = 1/32``). With the paper's Table 3 values and ``K = 40``,
  ``E ≈ 3e-14 Ω s²``: ``|e| < 1e-9 Ω`` at the resonance (≈ 50 rad/s) and < 1e-3 Ω at 1e5 rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from ..models import Model
from ..models.rational import foster_form

__all__ = ["Foster", "foster_realisation", "BESSEL_SECTIONS", "has_foster_form"]

#: eddy-current modes kept for the Bessel models (the rest lumped as an inductance)
BESSEL_SECTIONS = 40
_EXACT = ("I", "II", "NL", "UL")
_BESSEL = ("III", "UD")


def has_foster_form(model: Model) -> bool:
    """Whether :func:`foster_realisation` handles ``model`` (the paper's six; not augmented models)."""
    return model.name in _EXACT + _BESSEL


@dataclass(frozen=True)
class Foster:
    """``Ze(s) = R0 + G s + Σ_k L_k s/(1 + τ_k s)`` with its approximation error.

    Attributes
    ----------
    R0 : DC resistance [Ω]. G : series inductance [H]. L, tau : section inductances [H] and time
    constants [s]. exact : whether the form is exact. error_coeff : ``E`` [Ω s²] with
    ``|Ze_exact(s) − Ze(s)| ≤ E |s|²`` for ``Re s ≥ 0`` (0 when exact). description : one line.
    """

    R0: float
    G: float
    L: np.ndarray
    tau: np.ndarray
    exact: bool
    error_coeff: float
    description: str

    @property
    def R(self) -> np.ndarray:
        """Section resistances ``L_k/τ_k`` [Ω]."""
        return self.L / self.tau

    def impedance(self, s):
        """``Ze(s)`` [Ω] of this realisation at complex ``s`` (any shape)."""
        s = np.asarray(s, complex)
        ss = s[..., None]
        return self.R0 + self.G * s + np.sum(self.L * ss / (1.0 + self.tau * ss), axis=-1)

    def error_bound(self, s):
        """Upper bound [Ω] on ``|Ze_exact(s) − Ze(s)|`` for ``Re s ≥ 0``."""
        return self.error_coeff * np.abs(np.asarray(s, complex)) ** 2


def _bessel_sections(alpha: float, beta: float, sections: int):
    j = special.jn_zeros(0, sections)
    L = 2.0 * beta * np.sqrt(alpha) / j**2
    tau = alpha / j**2
    tail_L = max(beta * np.sqrt(alpha) * (0.25 - np.sum(1.0 / j**2)) * 2.0, 0.0)
    E = 2.0 * beta * alpha**1.5 * max(1.0 / 32.0 - float(np.sum(j**-4.0)), 0.0)
    return L, tau, tail_L, E


def foster_realisation(model: Model, theta, *, sections: int = BESSEL_SECTIONS) -> Foster:
    """The Foster form of ``Zc + R0`` for one parameter vector (module docstring).

    Parameters
    ----------
    model, theta : one of the paper's six models and its physical parameter vector ``(k,)``.
    sections : eddy-current modes kept for III and UD.

    Raises
    ------
    ValueError
        For a model without a known Foster form (e.g. an augmented model): use the
        argument-principle test of :mod:`bayes_emt.shunt.stability` instead.
    """
    theta = np.asarray(theta, float)
    if theta.ndim != 1:
        raise ValueError(f"foster_realisation takes one parameter vector, got shape {theta.shape}")
    if model.name in _EXACT:
        R0, G, L, tau = foster_form(model, theta)
        return Foster(float(R0), float(G), np.asarray(L, float), np.asarray(tau, float), True, 0.0,
                      f"exact Foster form of {model.label}")
    if model.name in _BESSEL:
        if int(sections) != sections or sections < 1:
            raise ValueError(f"sections must be a positive integer, got {sections!r}")
        p = model.as_dict(theta)
        L, tau, tail, E = _bessel_sections(p["alpha"], p["beta"], int(sections))
        return Foster(p["R0"], p.get("Lg", 0.0) + tail, L, tau, False, E,
                      f"{model.label}: {int(sections)} eddy-current modes (Mittag-Leffler) + lumped tail, "
                      f"|error| <= {E:.3g} |s|^2 ohm")
    raise ValueError(f"model {model.label} has no known Foster form (the paper's six models only)")
