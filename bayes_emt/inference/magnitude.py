"""The likelihood of a magnitude-only recording (|Z| without phase): a likelihood on log|Y|.

Benches such as Klippel's LPM export, digitised datasheet curves and some analysers give |Z| alone.
The measured quantity is then ``m_k = ln|Y_k|`` (= −ln|Z_k|), and the same two-part noise model as
the complex likelihood (:mod:`bayes_emt.inference.likelihood`) carries over to first order: a
complex error of standard deviation ``σ_rel|Y_k|`` per part changes ``ln|Y_k|`` by a relative
error of standard deviation ``σ_rel``, and an absolute floor ``σ_abs`` [S] by ``σ_abs/|Y_k|``, so

    s_k = sqrt(σ_rel² + (σ_abs / |Y_k|)²) / w_k,       r_k = ln|Y_model(jω_k)| − ln|Y_k|,

with Gaussian ``log p_k = −½ ln(2π s_k²) − r_k²/(2 s_k²)`` or a Student-t of scale ``s_k``. The
noise parameters, their priors and the model parameters are those of the complex likelihood, so
the samplers, evidence and checkpoints work unchanged.

What |Z| identifies: a moving-coil transducer's impedance is a minimum-phase one-port, so over an
infinite band its magnitude fixes its phase (Bode's gain-phase relation) and every parameter a
complex recording identifies. Over a finite band the resonance frequency and Qms are fixed by the
magnitude much as with phase; Re (and Qes, proportional to it) trades off against the coil-loss
terms, since a lossy inductance ``K (jω)^n`` with a small exponent adds to Re Z what Re adds, and
only the phase separates them (on the three DATS recordings with the UD+semi_inductance model,
|Z| alone moved Re by up to 11 %); Le and the coil-loss parameters rest on the band's edges; a pure
delay or other non-minimum-phase effect of the setup is invisible. An ohmmeter reading of Re
(``--re``) restores Re and Qes.

:class:`MagnitudeOnly` holds these densities as a mixin over the complex likelihood's attributes;
:class:`bayes_emt.inference.likelihood.MagnitudeLikelihood` (``MagnitudeOnly`` over ``Likelihood``)
is what ``Likelihood(model, meas)`` builds for a Measurement whose ``phase_absent`` is true.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = ["MagnitudeOnly"]



class MagnitudeOnly:
    """``log p(|Y| | θ)`` for a magnitude-only measurement (module docstring): placed before
    :class:`~bayes_emt.inference.likelihood.Likelihood` in a subclass, it replaces the complex
    residuals and densities by the real log-magnitude ones (same interface, same parameters)."""

    def __post_init__(self):
        if getattr(self, "noise", "white") != "white":
            raise ValueError(f"{self.meas.source}: the correlated-discrepancy noise is defined for complex "
                             "recordings; a magnitude-only recording takes the white noise (--noise white)")
        super().__post_init__()
        object.__setattr__(self, "_log_absY", np.log(self._absY))

    def describe(self) -> str:
        base = "gaussian" if self.kind == "gaussian" else \
            f"student-t (nu {'sampled' if self.sample_nu else f'{self.nu:g}'})"
        return f"{base} on ln|Y| (no phase), s^2 = sigma_rel^2 + (sigma_abs/|Y_meas|)^2"

    def sigma(self, sigma_rel, sigma_abs):
        """Per-frequency std (Student-t: scale) of ``ln|Y_k|`` [1], shape ``(..., F)``."""
        a = np.asarray(sigma_rel, float)[..., None]
        b = np.asarray(sigma_abs, float)[..., None] / self._absY
        return np.sqrt((a * a + b * b) / self._w2)

    def residuals(self, theta):
        """Real ``ln|Y_model| − ln|Y_meas|`` [1] (as a complex array, imaginary part 0), ``(..., F)``."""
        with np.errstate(all="ignore"):
            ym = self.model_admittance(self.split(theta)[0])
            return (np.log(np.abs(ym)) - self._log_absY).astype(complex)

    def scaled_squared_residuals(self, theta_model) -> np.ndarray:
        with np.errstate(all="ignore"):
            r = np.log(np.abs(self.model_admittance(np.asarray(theta_model, float)))) - self._log_absY
        return r * r * self._w2

    def normalised_residuals(self, theta):
        _, srel, sabs, _ = self.split(theta)
        with np.errstate(all="ignore"):
            return self.residuals(theta) / self.sigma(srel, sabs)

    def predictive(self, theta, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """``(Y_model, Y_replicated)``: the replicate's magnitude carries the log-normal noise of this
        likelihood, its phase the model's (the data say nothing of it)."""
        th, srel, sabs, nu = self.split(theta)
        Ym = self.model.admittance(self.meas.omega, th)
        sig = self.sigma(srel, sabs)
        if self.kind == "student":
            df = np.broadcast_to(np.asarray(nu, float)[..., None] if self.sample_nu else nu, Ym.shape)
            e = rng.standard_t(df)
        else:
            e = rng.standard_normal(Ym.shape)
        return Ym, Ym * np.exp(sig * e)

    def pointwise(self, theta) -> np.ndarray:
        _, srel, sabs, nu = self.split(theta)
        with np.errstate(all="ignore"):
            r = self.residuals(theta).real
            sig = self.sigma(srel, sabs)
            if self.kind == "gaussian":
                ll = -0.5 * np.log(2 * math.pi * sig * sig) - r * r / (2 * sig * sig)
            else:
                nu = np.asarray(nu, float)[..., None] if self.sample_nu else float(nu)
                c = special.gammaln((nu + 1) / 2) - special.gammaln(nu / 2) - 0.5 * np.log(nu * math.pi)
                ll = c - np.log(sig) - (nu + 1) / 2 * np.log1p((r / sig) ** 2 / nu)
        return np.where(np.isfinite(ll), ll, -np.inf)

    def __call__(self, theta) -> np.ndarray:
        return np.sum(self.pointwise(theta), axis=-1)

    def identity(self) -> dict:
        return {**super().identity(), "phase": "absent"}
