"""Known-answer evidence problems (analytic log Z) shared by the evidence tests.

Each problem has ``params`` (a ParamSet of proper priors), a vectorised log-likelihood
``__call__(x (n, k)) -> (n,)`` of physical values, ``log_posterior_z`` in sampling space, the
analytic ``truth`` and an exact posterior sampler ``posterior_draws(rng, n)``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special, stats

from bayes_emt.inference.likelihood import SamplingSpaceDensity
from bayes_emt.params import Normal, ParamSet, ParamSpec, Uniform


def _correlated_cov(d: int, rho: float, seed: int) -> np.ndarray:
    """A covariance with unit-ish scales and strong correlations (condition number ~ 1/(1-rho))."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((d, d)))
    eig = np.geomspace(1.0 - rho, 1.0 + (d - 1) * rho, d)
    cov = (q * eig) @ q.T
    s = np.sqrt(np.diag(cov))
    return cov / np.outer(s, s)


class GaussianInBox(SamplingSpaceDensity):
    """Correlated Gaussian likelihood (normalised density of x) inside a uniform box prior of
    width ``w`` per axis, far larger than the Gaussian: ``Z = Π 1/w_i`` (the Gaussian integrates to
    1), i.e. ``log Z = −Σ log w_i`` (STACK.md's known-answer list). The box is ±10 standard
    deviations of the widest axis, so the truncated mass is below 1e-20."""

    label = "gaussian-in-box"

    def __init__(self, d: int, rho: float = 0.9, seed: int = 0):
        self.cov = 0.1 * _correlated_cov(d, rho, seed)
        half = 10.0 * math.sqrt(float(np.max(np.linalg.eigvalsh(self.cov))))
        self.params = ParamSet([ParamSpec(f"x{i}", "1", f"x{i}", Uniform(-half, half)) for i in range(d)])
        self.ndim = d
        self._mvn = stats.multivariate_normal(np.zeros(d), self.cov)
        self.truth = -d * math.log(2 * half)

    def __call__(self, x):
        return np.atleast_1d(self._mvn.logpdf(np.asarray(x, float)))

    def posterior_draws(self, rng, n):
        return rng.multivariate_normal(np.zeros(self.ndim), self.cov, size=n)


class LinearGaussian(SamplingSpaceDensity):
    """Linear-Gaussian regression ``y = A θ + ε``, ``ε ~ N(0, σ² I)``, prior ``θ ~ N(0, τ² I)``
    (Normal priors, proper): ``y ~ N(0, σ² I + τ² A Aᵀ)`` exactly (Bishop 2006 eq. 3.86; the
    evidence of Bayesian linear regression). Columns of ``A`` are strongly correlated
    (``rho``), so the posterior is too."""

    label = "linear-gaussian"

    def __init__(self, d: int, n_obs: int = 40, rho: float = 0.95, sigma: float = 0.3, tau: float = 2.0,
                 seed: int = 0):
        rng = np.random.default_rng(seed)
        base = rng.standard_normal((n_obs, 1))
        self.A = math.sqrt(rho) * base + math.sqrt(1 - rho) * rng.standard_normal((n_obs, d))
        theta = rng.normal(0.0, 1.0, d)
        self.sigma, self.tau, self.ndim = sigma, tau, d
        self.y = self.A @ theta + sigma * rng.standard_normal(n_obs)
        self.params = ParamSet([ParamSpec(f"t{i}", "1", f"t{i}", Normal(0.0, tau)) for i in range(d)])
        cov_y = sigma**2 * np.eye(n_obs) + tau**2 * self.A @ self.A.T
        self.truth = float(stats.multivariate_normal(np.zeros(n_obs), cov_y).logpdf(self.y))
        prec = self.A.T @ self.A / sigma**2 + np.eye(d) / tau**2
        self.post_cov = np.linalg.inv(prec)
        self.post_mean = self.post_cov @ self.A.T @ self.y / sigma**2

    def __call__(self, x):
        x = np.atleast_2d(np.asarray(x, float))
        r = self.y[None, :] - x @ self.A.T
        n = self.y.size
        norm = n * math.log(self.sigma * math.sqrt(2 * math.pi))
        return -0.5 * np.sum(r * r, axis=1) / self.sigma**2 - norm

    def posterior_draws(self, rng, n):
        return rng.multivariate_normal(self.post_mean, self.post_cov, size=n)


class LogNormalUnderUniform(SamplingSpaceDensity):
    """Independent log-normal likelihood factors ``L(x) = Π LN(x_i; μ_i, s_i)`` (normalised
    densities of x) under uniform priors ``x_i ~ U(0, b)``: ``Z = Π F_i(b)/b`` with ``F_i`` the
    log-normal CDF, ``log Z = Σ [log Φ((log b − μ_i)/s_i) − log b]``; the posterior is the
    log-normal truncated at ``b`` (skewed, in the identity sampling space of a uniform prior)."""

    label = "lognormal-under-uniform"

    def __init__(self, d: int, s: float = 0.5, b: float = 20.0, seed: int = 0):
        rng = np.random.default_rng(seed)
        self.mu = rng.uniform(-0.5, 0.5, d)
        self.s, self.b, self.ndim = s, b, d
        self.params = ParamSet([ParamSpec(f"x{i}", "1", f"x{i}", Uniform(0.0, b)) for i in range(d)])
        self.truth = float(np.sum(special.log_ndtr((math.log(b) - self.mu) / s) - math.log(b)))

    def __call__(self, x):
        x = np.atleast_2d(np.asarray(x, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            lx = np.log(x)
            val = -0.5 * ((lx - self.mu) / self.s) ** 2 - lx - math.log(self.s * math.sqrt(2 * math.pi))
        return np.where(np.all(x > 0, axis=1), np.sum(val, axis=1), -np.inf)

    def posterior_draws(self, rng, n):
        out = np.empty((n, self.ndim))
        for i in range(self.ndim):
            # inverse-CDF draws of the log-normal truncated at b
            top = special.ndtr((math.log(self.b) - self.mu[i]) / self.s)
            u = rng.uniform(0, top, n)
            out[:, i] = np.exp(self.mu[i] + self.s * special.ndtri(u))
        return out


def chains_of(draws: np.ndarray, n_chains: int = 20) -> np.ndarray:
    """Independent exact draws arranged as (chains, draws, k) for the bridge estimator."""
    n = draws.shape[0] // n_chains * n_chains
    return draws[:n].reshape(n_chains, -1, draws.shape[1])
