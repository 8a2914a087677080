"""Foster (modal) form of the blocked impedance, for poles, state-space and Hankel analyses.

    Ze(s) = Zc(s) + R0 = R0 + G s + Σ_k L_k s / (1 + τ_k s)

(``G`` [H] series inductance, sections ``L_k`` [H] in parallel with ``R_k = L_k/τ_k`` [Ω]), summed
from the terms' own shares (:meth:`~bayes_emt.models.term.Term.foster`):

* I, II, NL, UL, LR-2 sections, leads: exact (NL/UL through the ring ladder's modal decomposition);
* III, UD: the Bessel ratio's Mittag-Leffler expansion ``I1(w)/I0(w) = Σ_k 2w/(w² + j_k²)``
  truncated at ``sections`` eddy-current modes, the rest lumped as an inductance, with the stated
  bound ``|e(s)| ≤ E |s|²`` for ``Re s ≥ 0``
  (:func:`~bayes_emt.models.catalogue.bessel_sections`).

A model with a device term that has no finite RL form (another mode, a capacitance across the
terminals, a semi-inductance, creep or a port) has none: :func:`foster_form` returns ``None`` and
the stability analysis uses the argument principle on the exact model instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import polynomial as P

from .model import Model
from .term import Term

__all__ = ["Foster", "foster_form", "rational_form", "has_foster_form", "BESSEL_SECTIONS"]

#: eddy-current modes kept for the Bessel models (the rest lumped as an inductance)
BESSEL_SECTIONS = 40


@dataclass(frozen=True)
class Foster:
    """``Ze(s) = R0 + G s + Σ_k L_k s/(1 + τ_k s)`` with its approximation error.

    Attributes
    ----------
    R0 : series resistance [Ω]. G : series inductance [H]. L, tau : section inductances [H] and
    time constants [s]. exact : whether the form is exact. error_coeff : ``E`` [Ω s²] with
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


def foster_form(model: Model, theta, *, sections: int = BESSEL_SECTIONS) -> Foster | None:
    """The Foster form of the blocked impedance for one parameter vector ``(k,)``, or ``None`` when
    a device term has no finite RL form (module docstring)."""
    theta = np.asarray(theta, float)
    if theta.ndim != 1:
        raise ValueError(f"a Foster form takes one parameter vector, got shape {theta.shape}")
    if not model.plain_mechanics:
        return None
    R, G, E = 0.0, 0.0, 0.0
    Ls, taus, notes = [], [], []
    for t in model.terms:
        if not t.device or t.stage == "motional":
            continue
        part = t.foster(theta[model.term_slice(t)], sections)
        if part is None:
            return None
        R += part.R
        G += part.G
        E += part.error_coeff
        Ls.append(np.asarray(part.L, float))
        taus.append(np.asarray(part.tau, float))
        if part.note:
            notes.append(part.note)
    exact = E == 0.0 and not notes
    desc = (f"exact Foster form of {model.label}" if exact
            else f"{model.label}: " + "; ".join(notes) + f", |error| <= {E:.3g} |s|^2 ohm")
    return Foster(float(R), float(G), np.concatenate(Ls) if Ls else np.zeros(0),
                  np.concatenate(taus) if taus else np.zeros(0), exact, float(E), desc)


def rational_form(model: Model, theta):
    """``Ze = Zc + R0`` as (numerator, denominator) coefficient arrays, lowest power first (exact
    Foster forms only)."""
    f = foster_form(model, theta)
    if f is None or not f.exact:
        raise ValueError(f"model {model.label} has no exact rational form")
    den = np.array([1.0])
    for t in f.tau:
        den = P.polymul(den, [1.0, t])
    num = P.polymul([f.R0, f.G], den)
    for k in range(f.tau.size):
        others = np.array([1.0])
        for j in range(f.tau.size):
            if j != k:
                others = P.polymul(others, [1.0, f.tau[j]])
        num = P.polyadd(num, P.polymul([0.0, f.L[k]], others))
    return num, den


def has_foster_form(model: Model) -> bool:
    """Whether :func:`foster_form` gives a form for ``model``: plain mechanics, nothing across the
    terminals, and every device series term with a finite RL form."""
    return model.plain_mechanics and all(
        type(t).foster is not Term.foster for t in model.terms if t.device and t.stage == "series")
