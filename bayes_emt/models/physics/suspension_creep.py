"""Viscoelastic suspension creep: the LOG creep model of Knudsen & Jensen (1993)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import ParamSpec, Uniform
from ..term import Term, col

__all__ = ["SuspensionCreep"]


@dataclass(frozen=True)
class SuspensionCreep(Term):
    """LOG creep (Knudsen & Jensen 1993): compliance ``C(s) = C0 [1 + λ ln(ω0/s)]``, so the
    stiffness ``ω0² → ω0²/(1 + λ ln(ω0/s))`` (``s = jω``: the compliance grows by λ per e-fold of
    falling frequency with a constant loss angle, the Kramers–Kronig-consistent form). The reference
    frequency is ``ω0`` itself, so ``ω0`` keeps meaning the stiffness at the resonance and no
    parameter is added besides ``λ``."""

    id = "suspension_creep"
    stage = "stiffness"
    augmentation = True
    band = "mechanical"
    physics = "suspension_creep"
    needs = ("omega0",)
    description = "viscoelastic suspension: stiffness falls toward low frequency (LOG creep)"
    signature = ("a low-frequency residual trend below the resonance; the resonance shape (Qms) off in "
                 "both parts")
    parameters = (ParamSpec("lambda_creep", "1", r"$\lambda_c$", Uniform(0.0, 0.5),
                            "suspension creep: compliance grows by lambda per e-fold of falling frequency"),)

    def evaluate(self, s, v, other):
        lam, w0 = col(v, 0), other["omega0"]
        s = np.asarray(s)
        if s.ndim == 1 and np.all(s.real == 0) and np.all(s.imag > 0):
            # on s = jω: ln(ω0/s) = ln(ω0/ω) − jπ/2, so 1/(x − jy) = (x + jy)/(x² + y²) with real
            # x = 1 + λ ln(ω0/ω), y = λπ/2: no complex logarithm or division per parameter set and
            # frequency (this term was 8 % of a diagnosis's CPU on seas_E0018; 1.6x faster per call)
            with np.errstate(divide="ignore", invalid="ignore"):
                x = 1.0 + lam * (np.log(w0) - np.log(s.imag))
                y = np.broadcast_to(lam * (0.5 * np.pi), x.shape)
                d = x * x + y * y
                out = np.empty(x.shape, complex)
                out.real, out.imag = x / d, y / d
            return out
        return 1.0 / (1.0 + lam * np.log(w0 / s))

    def start(self, ctx):
        return [{"lambda_creep": lam} for lam in (0.03, 0.08, 0.2)]
