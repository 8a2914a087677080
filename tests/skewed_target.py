"""A known-answer target for MCMC moves: a linear map of independent log-normals in 4-D (heavy right
tails, correlated); its quantiles are known from direct draws (``draw(10**6)``). Shared by the
sampler-move tests of ``test_sampling.py`` and ``test_sampler_moves.py``."""

import numpy as np


def skewed_target(seed: int = 5):
    """``(logp, draw)``: the vectorised log density (up to a constant) and a direct sampler
    ``draw(n) -> (n, 4)`` that continues one seeded random stream."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((4, 4))
    Ai = np.linalg.inv(A)

    def logp(y):
        x = y @ Ai.T
        with np.errstate(all="ignore"):
            lx = np.log(x)
            v = np.sum(-0.5 * (lx / 0.6) ** 2 - lx, axis=1)
        return np.where(np.all(x > 0, axis=1), v, -np.inf)

    def draw(n):
        return np.exp(0.6 * rng.standard_normal((n, 4))) @ A.T

    return logp, draw
