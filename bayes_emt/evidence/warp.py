"""The unbounded coordinates the posterior-based estimators work in.

Sampling space ``z`` (:mod:`bayes_emt.params`: ``log x`` for log-uniform and log-normal priors,
``x`` otherwise) still has bounds: a log-uniform prior on ``[a, b]`` is uniform on
``[log a, log b]``. A Gaussian proposal (bridge sampling) or a quadratic expansion (Laplace) fits
badly where the posterior presses against such a bound, as the noise floor ``sigma_abs`` does
(its likelihood is flat below the relative noise, so its posterior is uniform down to the prior's
lower end). As in Gronau et al. (2017, "A tutorial on bridge sampling", J. Math. Psychol. 81,
§ "transformations"), every coordinate with finite bounds ``[lo, hi]`` is therefore mapped to the
real line by the logit,

    ξ = log((z − lo)/(hi − z)),      z = lo + (hi − lo) σ(ξ),
    log |dz/dξ| = log(hi − lo) + log σ(ξ) + log(1 − σ(ξ)),

and unbounded coordinates stay as they are. Only coordinates whose posterior comes near a bound
(within a few posterior standard deviations, :meth:`Warp.near_bounds`) are mapped: far from the
bounds the logit is nearly linear and buys nothing, and it would make an exactly Gaussian posterior
slightly non-Gaussian (Laplace's error). A density ``q_z(z)`` in sampling space becomes
``q_ξ(ξ) = q_z(z(ξ)) |dz/dξ|``, with the same integral: the evidence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import ParamSet

__all__ = ["Warp"]


@dataclass(frozen=True, eq=False)
class Warp:
    """The map between sampling space ``z`` and the unbounded ``ξ`` of one ParamSet.

    Attributes
    ----------
    lo, hi : (k,) sampling-space bounds (``±inf`` where unbounded).
    bounded : (k,) which coordinates are logit-mapped.
    """

    lo: np.ndarray
    hi: np.ndarray
    mask: np.ndarray | None = None

    @classmethod
    def of(cls, params: ParamSet, mask=None) -> Warp:
        """The warp of ``params``: every bounded coordinate, or those in ``mask`` only."""
        lo, hi = params.bounds_z()
        return cls(np.asarray(lo, float), np.asarray(hi, float),
                   None if mask is None else np.asarray(mask, bool))

    @classmethod
    def near_bounds(cls, params: ParamSet, z_min, z_max, sd, n_sd: float = 5.0) -> Warp:
        """Warp the bounded coordinates whose posterior range ``[z_min, z_max]`` (sampling space)
        comes within ``n_sd`` standard deviations ``sd`` of a bound."""
        lo, hi = (np.asarray(b, float) for b in params.bounds_z())
        sd = np.asarray(sd, float)
        near = ((np.asarray(z_min, float) - lo) < n_sd * sd) | ((hi - np.asarray(z_max, float)) < n_sd * sd)
        return cls(lo, hi, near)

    @property
    def bounded(self) -> np.ndarray:
        fin = np.isfinite(self.lo) & np.isfinite(self.hi)
        return fin if self.mask is None else fin & self.mask

    def to_xi(self, z) -> np.ndarray:
        """``ξ`` of sampling-space points ``z (..., k)`` (points on a bound map to ``±inf``)."""
        z = np.asarray(z, float)
        b = self.bounded
        xi = z.copy()
        with np.errstate(divide="ignore", invalid="ignore"):
            xi[..., b] = np.log(z[..., b] - self.lo[b]) - np.log(self.hi[b] - z[..., b])
        return xi

    def from_xi(self, xi) -> np.ndarray:
        """Sampling-space points of ``ξ (..., k)``."""
        xi = np.asarray(xi, float)
        b = self.bounded
        z = xi.copy()
        z[..., b] = self.lo[b] + (self.hi[b] - self.lo[b]) * _sigmoid(xi[..., b])
        return z

    def log_jacobian(self, xi) -> np.ndarray:
        """``log |dz/dξ|`` summed over coordinates, shape ``xi.shape[:-1]``."""
        xi = np.asarray(xi, float)
        b = self.bounded
        x = xi[..., b]
        # log σ(x) + log(1 − σ(x)) = −softplus(−x) − softplus(x)
        term = np.log(self.hi[b] - self.lo[b]) - np.logaddexp(0.0, -x) - np.logaddexp(0.0, x)
        return np.sum(term, axis=-1)

    def log_density(self, log_density_z):
        """``ξ (n, k) -> log q_ξ`` for a vectorised sampling-space log density ``log_density_z``."""

        def f(xi):
            xi = np.atleast_2d(np.asarray(xi, float))
            with np.errstate(invalid="ignore", over="ignore"):
                out = np.asarray(log_density_z(self.from_xi(xi)), float) + self.log_jacobian(xi)
            return np.where(np.isnan(out), -np.inf, out)

        return f


def _sigmoid(x):
    return np.where(x >= 0, 1.0 / (1.0 + np.exp(-np.abs(x))), np.exp(-np.abs(x)) / (1.0 + np.exp(-np.abs(x))))
