"""Proposal moves for emcee's ensemble sampler, chosen by effective samples per second.

The driver (:mod:`bayes_emt.inference.sampling`) runs two phases:

* **warm-up** (:func:`warmup_moves`): :class:`EnsembleTMove` 50 %, differential evolution 40 %,
  :class:`SnookerMove` 10 %. The ensemble-t move proposes, for each walker of one half, an
  independent draw from a multivariate Student-t with the mean and covariance of the other half:
  it pulls walkers stranded in a negligible local mode back to the bulk at once (a walker whose
  log posterior is thousands of nats below the others is accepted out of it with probability
  one), which differential evolution alone does not do;
* **production** (:func:`production_moves`): :class:`IndependenceTMove` 90 % — an independent
  multivariate Student-t (ν = 10) with the mean and covariance of the warm-up's second half,
  frozen for a production segment — and differential evolution 10 %. At later checkpoints the
  driver compares the chain with the sample the proposal was fitted to
  (:func:`proposal_mismatch`: a variance ratio beyond 2 along some direction, or the means half a
  standard deviation apart) and starts a new segment with a refitted proposal only if they differ.

Every move is an exact Metropolis–Hastings update: the ensemble-t proposal depends only on the
complementary half (emcee's red-blue scheme, as for its KDE move) and carries the factor
``log q(x) − log q(x')``; a frozen proposal depends on the chain's past only, fixed before the
steps it serves, so each production segment is a homogeneous Markov chain with the posterior as
its invariant law (tests/test_sampler_moves.py checks quantiles of a skewed target).

Measured on the bundled data (NL(5) simulated from Table 5, 4·ndim walkers, from a stationary
ensemble): integrated autocorrelation times of about 3 steps for UD (9 sampled dimensions) and
9–11 for NL(5) (17), against 28–45 and 40–64 for the earlier DE 0.8 + snooker 0.2 mix; acceptance
0.6 and 0.34 (a proposal fitted to an early warm-up: 30 for NL(5)). Linear correlations need no
reparameterisation: all these moves are affine invariant.
"""

from __future__ import annotations

import emcee
import numpy as np
from emcee.moves.mh import MHMove
from emcee.moves.red_blue import RedBlueMove

__all__ = ["SnookerMove", "EnsembleTMove", "IndependenceTMove", "warmup_moves", "production_moves",
           "proposal_mismatch", "MOVES_DESCRIPTION"]

#: What a checkpoint records about the moves (a resume with other moves is refused).
MOVES_DESCRIPTION = ("warm-up: ensemble-t 0.5 + DE 0.4 + snooker 0.1; "
                     "production: frozen independence-t(10) 0.9 + DE 0.1")
_DF = 10.0


class SnookerMove(RedBlueMove):
    """Differential-evolution snooker update (ter Braak & Vrugt 2008), as it should be.

    For a walker ``x``, three points ``a, z1, z2`` of the complementary walkers: with
    ``e = (x − a)/|x − a|``, propose ``x' = x + γ e·(z1 − z2) e``, ``γ ~ U(1.2, 2.2)``, and accept
    with ``min(1, π(x')/π(x) · (|x' − a|/|x − a|)^(d − 1))``.

    emcee 3.1.6's ``DESnookerMove`` (the latest release) projects on ``delta/sqrt(|delta|)`` and
    halves the ``(d − 1)`` exponent, so its target is not the posterior. Upstream fixed both in
    emcee PR #531 (commit 946e664, "Update de_snooker.py", merged 27 January 2025:
    ``u = delta / norm`` and ``(ndim - 1.0) * metropolis``), not in a release yet. This class does
    not depend on which emcee is installed; tests/test_sampling.py checks emcee's own move either way.
    """

    def __init__(self, gamma_range: tuple[float, float] = (1.2, 2.2), **kwargs):
        self.gamma_range = gamma_range
        kwargs.setdefault("nsplits", 4)  # a, z1, z2 from three different splits: always distinct
        super().__init__(**kwargs)

    def get_proposal(self, s, c, random):
        ns, ndim = s.shape
        pick = np.stack([c[j][random.randint(len(c[j]), size=ns)] for j in range(3)], axis=1)
        order = np.argsort(random.random_sample((ns, 3)), axis=1)
        pick = np.take_along_axis(pick, order[:, :, None], axis=1)
        anchor, z1, z2 = pick[:, 0], pick[:, 1], pick[:, 2]
        delta = s - anchor
        r = np.linalg.norm(delta, axis=1)
        e = delta / r[:, None]
        gamma = random.uniform(*self.gamma_range, size=ns)
        q = s + (gamma * np.einsum("ij,ij->i", e, z1 - z2))[:, None] * e
        with np.errstate(divide="ignore"):
            factor = (ndim - 1.0) * (np.log(np.linalg.norm(q - anchor, axis=1)) - np.log(r))
        return q, factor


class _StudentT:
    """Multivariate Student-t with location ``mean``, scale matrix ``cov`` and ``df`` degrees of
    freedom: draws and the log density up to a constant."""

    def __init__(self, mean, cov, df: float = _DF):
        self.mean = np.asarray(mean, float)
        cov = np.asarray(cov, float)
        d = self.mean.size
        cov = 0.5 * (cov + cov.T) + np.eye(d) * 1e-12 * max(float(np.trace(cov)) / d, 1e-300)
        self.chol = np.linalg.cholesky(cov)  # LinAlgError for a degenerate sample
        self.df = float(df)

    def draw(self, n: int, random) -> np.ndarray:
        d = self.mean.size
        g = random.standard_normal((n, d))
        w = np.sqrt(self.df / random.chisquare(self.df, size=n))
        return self.mean + (g @ self.chol.T) * w[:, None]

    def log_density(self, x) -> np.ndarray:
        y = np.linalg.solve(self.chol, (np.asarray(x, float) - self.mean).T).T
        return -0.5 * (self.df + self.mean.size) * np.log1p(np.sum(y * y, axis=1) / self.df)


class EnsembleTMove(RedBlueMove):
    """Independence proposal from a Student-t fitted to the complementary half of the ensemble
    (mean, covariance times ``scale²``), accepted with the factor ``log q(x) − log q(x')``."""

    def __init__(self, scale: float = 1.2, df: float = _DF, **kwargs):
        self.scale = float(scale)
        self.df = float(df)
        super().__init__(**kwargs)

    def get_proposal(self, s, c, random):
        pts = np.concatenate(c, axis=0)
        try:
            t = _StudentT(pts.mean(axis=0), np.cov(pts, rowvar=False) * self.scale**2, self.df)
        except np.linalg.LinAlgError:  # collapsed complement: propose nothing new
            return s.copy(), np.full(s.shape[0], -np.inf)
        q = t.draw(s.shape[0], random)
        return q, t.log_density(s) - t.log_density(q)


class IndependenceTMove(MHMove):
    """Metropolis–Hastings with a fixed independent multivariate Student-t proposal."""

    def __init__(self, mean, cov, df: float = _DF):
        self.t = _StudentT(mean, cov, df)
        super().__init__(self._propose)

    @classmethod
    def from_sample(cls, points, df: float = _DF) -> IndependenceTMove:
        """The proposal with the mean and covariance of ``points (n, d)``."""
        points = np.asarray(points, float)
        return cls(points.mean(axis=0), np.cov(points, rowvar=False), df)

    def _propose(self, x, random):
        q = self.t.draw(x.shape[0], random)
        return q, self.t.log_density(x) - self.t.log_density(q)


def warmup_moves() -> list:
    """The warm-up mix (module docstring)."""
    return [(EnsembleTMove(), 0.5), (emcee.moves.DEMove(), 0.4), (SnookerMove(), 0.1)]


def production_moves(warmup_points) -> list | None:
    """The production mix with the proposal fitted to ``warmup_points (n, d)``; ``None`` when
    those points are degenerate (the warm-up mix then simply continues)."""
    pts = np.asarray(warmup_points, float)
    if pts.shape[0] <= pts.shape[1] or not np.all(np.isfinite(pts)):
        return None
    try:
        move = IndependenceTMove.from_sample(pts)
    except np.linalg.LinAlgError:
        return None
    return [(move, 0.9), (emcee.moves.DEMove(), 0.1)]


def proposal_mismatch(fitted_points, new_points, *, scale: float = 2.0, shift: float = 0.5) -> bool:
    """Whether ``new_points`` (a later stretch of the chain, ``(n, d)``) disagree with the sample
    ``fitted_points`` a proposal was fitted to: a variance ratio along some direction outside
    ``[1/scale, scale]`` (generalised eigenvalues of the two covariances) or the means apart by
    more than ``shift`` standard deviations (Mahalanobis). Degenerate samples count as a mismatch."""
    a, b = np.asarray(fitted_points, float), np.asarray(new_points, float)
    d = a.shape[1]
    if a.shape[0] <= d or b.shape[0] <= d or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return True
    try:
        L = np.linalg.cholesky(np.cov(a, rowvar=False))
    except np.linalg.LinAlgError:
        return True
    Li = np.linalg.inv(L)
    lam = np.linalg.eigvalsh(Li @ np.cov(b, rowvar=False) @ Li.T)
    m = Li @ (b.mean(axis=0) - a.mean(axis=0))
    return bool(lam.min() < 1.0 / scale or lam.max() > scale or float(m @ m) > shift**2)
