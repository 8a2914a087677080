"""The likelihood of a measured admittance, vectorised over parameter sets.

Noise model (what a metrologist specifies for an LCR meter or analyser): the real and imaginary
parts of each ``Y_k`` carry independent errors with standard deviation

    σ_k = sqrt((σ_rel |Y_k|)² + (σ_floor · Ỹ)²)

a *relative* part (the instrument's accuracy is stated relative to the reading) plus an absolute
*floor* (noise, cabling), expressed relative to the median |Y| of the recording, ``Ỹ``, so its
prior is dimensionless. ``|Y_k|`` is the *measured* magnitude: the noise scale is then a property
of the measurement, not of the candidate parameters (with a model-dependent scale a poor model
could buy likelihood by inflating |Y|); at 0.2 % noise the difference from the true |Y| is
second order. Both scales are sampled, in log space, with proper log-uniform priors.

``gaussian``: ``log p_k = −log(2π σ_k²) − |r_k|²/(2σ_k²)``; ``student``: each part Student-t with
``ν`` degrees of freedom (default 4) and scale ``σ_k``, for recordings with outliers.
The pointwise ``log p_k`` per frequency feeds LOO and the discrepancy analysis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import special

from .data import Measurement
from .models import Model
from .params import LogUniform, ParamSet, ParamSpec

__all__ = ["NOISE_PARAMS", "Likelihood"]

#: Noise parameters appended to every model's parameter vector (identical across models).
NOISE_PARAMS = ParamSet([
    ParamSpec("sigma_rel", "1", r"$\sigma_\mathrm{rel}$", LogUniform(1e-6, 1.0),
              "relative noise std of the real and imaginary parts"),
    ParamSpec("sigma_floor", "1", r"$\sigma_\mathrm{floor}$", LogUniform(1e-7, 1.0),
              "absolute noise floor, relative to the median |Y| of the recording"),
])


@dataclass(frozen=True)
class Likelihood:
    """``log p(Y | θ)`` for one measurement and one model.

    ``params`` is the model's ParamSet followed by :data:`NOISE_PARAMS`; every method takes
    physical values of shape ``(..., k)``.
    """

    model: Model
    meas: Measurement
    kind: Literal["gaussian", "student"] = "gaussian"
    nu: float = 4.0

    def __post_init__(self):
        if self.kind not in ("gaussian", "student"):
            raise ValueError(f"unknown likelihood {self.kind!r}; choose gaussian or student")
        if not self.nu > 0:
            raise ValueError(f"Student-t degrees of freedom must be positive, got {self.nu}")
        object.__setattr__(self, "params", self.model.params + NOISE_PARAMS)
        object.__setattr__(self, "_absY", np.abs(self.meas.Y))
        object.__setattr__(self, "_scale", float(np.median(np.abs(self.meas.Y))))

    @property
    def ndim(self) -> int:
        return len(self.params)

    def split(self, theta):
        theta = np.asarray(theta, float)
        k = self.model.ndim
        return theta[..., :k], theta[..., k], theta[..., k + 1]

    def sigma(self, sigma_rel, sigma_floor):
        """Per-frequency std of each part [S], shape ``(..., F)``."""
        a = np.asarray(sigma_rel, float)[..., None] * self._absY
        b = np.asarray(sigma_floor, float)[..., None] * self._scale
        return np.sqrt(a * a + b * b)

    def pointwise(self, theta) -> np.ndarray:
        """Log-likelihood per frequency, shape ``(..., F)``; NaN-free (``-inf`` if not finite)."""
        th, srel, sfl = self.split(theta)
        with np.errstate(all="ignore"):
            r = self.model.admittance(self.meas.omega, th) - self.meas.Y
            sig = self.sigma(srel, sfl)
            if self.kind == "gaussian":
                ll = -np.log(2 * math.pi * sig * sig) - (r.real**2 + r.imag**2) / (2 * sig * sig)
            else:
                nu = self.nu
                c = special.gammaln((nu + 1) / 2) - special.gammaln(nu / 2) - 0.5 * math.log(nu * math.pi)
                t2 = np.log1p((r.real / sig) ** 2 / nu) + np.log1p((r.imag / sig) ** 2 / nu)
                ll = 2 * c - 2 * np.log(sig) - (nu + 1) / 2 * t2
        return np.where(np.isfinite(ll), ll, -np.inf)

    def __call__(self, theta) -> np.ndarray:
        """Total log-likelihood, shape ``theta.shape[:-1]``."""
        return np.sum(self.pointwise(theta), axis=-1)

    def log_posterior_z(self, z) -> np.ndarray:
        """Unnormalised log posterior in sampling space (prior incl. log-Jacobian + likelihood),
        ``z`` of shape ``(W, k)`` → ``(W,)``; ``-inf`` outside the prior support, never NaN."""
        z = np.atleast_2d(np.asarray(z, float))
        lp = self.params.log_prior_z(z)
        out = np.full(z.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if np.any(ok):
            ll = self(self.params.from_z(z[ok]))
            out[ok] = np.where(np.isfinite(ll), lp[ok] + ll, -np.inf)
        return out
