"""Where the walkers start: the least-squares fit, refined into the posterior mode.

The least-squares fit (:mod:`bayes_emt.estimation.fitting`) weighs relative residuals; the
posterior also weighs the noise model, whose absolute floor ``sigma_abs`` can explain a model's
misfit better than ``sigma_rel`` does, and then the posterior mode lies far from the fit (UD on
the bundled NL data: 2,560 nats higher, with ``L_g``, ``alpha`` and ``beta`` a few standard deviations
away). :func:`posterior_mode` climbs from several starts by quasi-Newton (BFGS) steps in coordinates
whitened by a given covariance, with central-difference gradients evaluated as one batch; the
walkers then start in a ball around the best point (:func:`start_ball`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from ..errors import FitError
from ..estimation.results import FitResult

__all__ = ["initial_walkers", "noise_start", "floor_noise_start", "extra_noise_start", "start_ball",
           "posterior_mode"]

_FD_STEP = 1e-5  # central-difference step in whitened coordinates
LOOSE_SD = 1.0  # sampling-space standard deviation beyond which a start coordinate is checked (start_ball)


def posterior_mode(target, starts, cov, *, max_iter: int = 200) -> np.ndarray:
    """The highest point found by BFGS on ``target.log_posterior_z`` from each of ``starts``.

    Parameters
    ----------
    target : anything with a vectorised ``log_posterior_z((n, k)) -> (n,)``.
    starts : sampling-space points ``(m, k)`` to climb from.
    cov : ``(k, k)`` covariance whose Cholesky factor whitens the coordinates (the scale of a
        step; it need not be the posterior's).
    max_iter : BFGS iterations per start.

    Returns
    -------
    The best sampling-space point among the starts and the optimisers' end points.
    """
    starts = np.atleast_2d(np.asarray(starts, float))
    k = starts.shape[1]
    L = np.linalg.cholesky(0.5 * (cov + cov.T) + 1e-12 * np.max(np.abs(np.diag(cov))) * np.eye(k))
    best_z, best_lp = None, -np.inf
    idx = np.arange(k)
    for z0 in starts:
        def f_and_grad(u, z0=z0):
            pts = np.repeat(u[None, :], 2 * k + 1, axis=0)
            pts[idx, idx] += _FD_STEP
            pts[k + idx, idx] -= _FD_STEP
            v = -target.log_posterior_z(z0 + pts @ L.T)
            if not np.isfinite(v[-1]):
                return np.inf, np.zeros(k)
            with np.errstate(invalid="ignore"):  # both neighbours outside the support: inf - inf
                g = (v[:k] - v[k : 2 * k]) / (2 * _FD_STEP)
            return v[-1], np.where(np.isfinite(g), g, 0.0)

        lp0 = -f_and_grad(np.zeros(k))[0]
        if lp0 > best_lp:
            best_z, best_lp = z0, lp0
        if not np.isfinite(lp0):
            continue
        with np.errstate(all="ignore"):
            res = optimize.minimize(f_and_grad, np.zeros(k), jac=True, method="BFGS",
                                    options={"maxiter": max_iter, "gtol": 1e-6})
        z = z0 + L @ res.x
        lp = float(target.log_posterior_z(z[None, :])[0])
        if lp > best_lp:
            best_z, best_lp = z, lp
    if best_z is None:
        raise FitError(f"{target.label}: could not start the walkers: the posterior is zero at every start "
                       "point of the mode search (check the priors against the fitted values)")
    return best_z


def noise_start(rms_rel: float, min_abs_Y: float) -> tuple[list[float], list[float]]:
    """Centre and spread, in sampling space, of ``(sigma_rel, sigma_abs)`` for walkers started
    from a fit with rms relative residual ``rms_rel`` of data whose smallest |Y| is ``min_abs_Y``."""
    sig0 = max(rms_rel / math.sqrt(2), 1e-5)
    return [math.log(sig0), math.log(1e-3 * sig0 * min_abs_Y)], [0.05, 1.0]


def extra_noise_start(lik, theta) -> tuple[list[float], list[float]]:
    """Centre and spread, in sampling space, of the noise parameters after the two scales: a
    sampled ``nu`` at 10 (spread 0.3), then a correlated
    likelihood's ``sigma_disc`` and ``ell`` from the relative residual of the model at ``theta``
    (:func:`~bayes_emt.inference.discrepancy.discrepancy_start`); empty for a white Gaussian
    likelihood."""
    from .discrepancy import discrepancy_start

    centre, spread = [], []
    if getattr(lik, "sample_nu", False):
        centre.append(math.log(10.0))
        spread.append(0.3)
    if getattr(lik, "correlated", False):
        with np.errstate(all="ignore"):
            th = np.asarray(theta, float)[: lik.model.ndim]
            r = (lik.model_admittance(th) - lik.meas.Y) / np.abs(lik.meas.Y)
        c, sp = discrepancy_start(lik._corr.x, np.where(np.isfinite(r), r, 0.0))
        centre += c
        spread += sp
    return centre, spread


def floor_noise_start(lik, theta, z_rel: float) -> tuple[list[float], float]:
    """The noise start with the absolute floor dominating, ``([log sigma_rel, log sigma_abs], rms_abs)``:
    ``sigma_abs`` at the rms absolute residual ``rms_abs`` [S] of the model at ``theta`` (per part),
    ``sigma_rel`` a thousand times below ``exp(z_rel)``, the relative-noise start's."""
    with np.errstate(all="ignore"):
        r = lik.model_admittance(theta) - lik.meas.Y
    rms_abs = float(np.sqrt(np.mean(r.real**2 + r.imag**2) / 2))
    return [z_rel - math.log(1e3), math.log(max(rms_abs, 1e-300))], rms_abs


def initial_walkers(lik, fit: FitResult, nwalkers: int, rng: np.random.Generator) -> np.ndarray:
    """Walkers in sampling space around the posterior mode found from the least-squares fit.

    The mode (:func:`posterior_mode`) is climbed to from the fit with two noise starts: the
    relative noise dominating (``sigma_rel`` at the fit's rms relative residual per part,
    ``sigma_abs`` a thousand times below it times the smallest |Y|) and the absolute floor
    dominating (``sigma_abs`` at the rms absolute residual, ``sigma_rel`` a thousand times below
    the first start's), a sampled ``nu`` at 10. Model parameters then start from
    ``N(z_mode, cov_z)`` (the fit's covariance: a ball of the posterior's size), the noise
    parameters from normals around the mode's (spread 0.05 for the dominant scale, one e-fold for
    the other); all clipped to the prior support with a finite posterior.
    """
    z0 = lik.model.params.to_z(fit.theta)
    cov = fit.cov_z if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)) else None
    if cov is None:
        cov = np.diag((1e-3 * np.maximum(np.abs(z0), 1.0)) ** 2)
    min_abs = float(np.min(np.abs(lik.meas.Y)))
    rel, spread = noise_start(fit.rms_rel_residual, min_abs)
    floor, rms_abs = floor_noise_start(lik, fit.theta, rel[0])
    _refuse_noise_priors_excluding(lik, rel[0], rms_abs)
    extra, extra_spread = extra_noise_start(lik, fit.theta)
    starts = np.array([np.r_[z0, rel, extra], np.r_[z0, floor, extra]])
    starts = lik.params.clip_inside(starts)
    lo = lik.params.bounds_z()[0]
    k = z0.size
    full = np.zeros((lik.ndim, lik.ndim))
    full[:k, :k] = cov
    full[k:, k:] = np.eye(lik.ndim - k)
    mode = posterior_mode(lik, starts, full)
    absolute = mode[k + 1] > math.log(min_abs) + mode[k]  # sigma_abs above sigma_rel |Y| somewhere
    noise_spread = [1.0, 0.05] if absolute else list(spread)
    noise_spread += extra_spread
    # the other noise scale is not identified below the level where it starts to matter: its
    # posterior is the prior there, a plateau reaching down to the prior's bound; start the walkers
    # spread over it (a ball around the mode's arbitrary point on it takes the warm-up long to widen)
    if absolute:
        i, edge = k, mode[k + 1] - math.log(float(np.max(np.abs(lik.meas.Y)))) - 1.0
    else:
        i, edge = k + 1, mode[k] + math.log(min_abs) - 1.0
    uniform = {i: (lo[i], edge)} if np.isfinite(lo[i]) and edge > lo[i] + 1.0 else None
    return start_ball(lik, mode[:k], cov, list(mode[k:]), noise_spread, nwalkers, rng, uniform=uniform)


def _refuse_noise_priors_excluding(lik, z_rel: float, rms_abs: float) -> None:
    """Raise ``ValueError``, naming both priors, when neither noise scale's prior reaches the level
    of the fit's residuals: ``sigma_rel`` excludes the relative level ``exp(z_rel)`` and
    ``sigma_abs`` the absolute level ``rms_abs`` [S] (walkers started far outside the posterior's
    mass never move, and the chain has no autocorrelation time). One prior reaching it is enough:
    the mode search starts from both (:func:`initial_walkers`)."""
    names = lik.noise_params.names
    if "sigma_rel" not in names or "sigma_abs" not in names:
        return
    lo, hi = lik.params.bounds_z()
    i_rel, i_abs = lik.params.index("sigma_rel"), lik.params.index("sigma_abs")
    if lo[i_rel] <= z_rel <= hi[i_rel]:
        return
    z_abs = math.log(rms_abs) if rms_abs > 0 else -math.inf
    if lo[i_abs] < z_abs < hi[i_abs]:
        return

    def show(i):
        d = dict(lik.params[i].prior.to_dict())
        return f"{d.pop('dist', '?')}(" + ", ".join(f"{k}={v:g}" for k, v in d.items()) + ")"

    raise ValueError(
        f"the noise priors exclude the data: the least-squares residuals are "
        f"{100 * math.exp(z_rel):.3g} % of |Y| per real/imaginary part ({rms_abs:.3g} S rms), but "
        f"sigma_rel is {show(i_rel)} [1] and sigma_abs {show(i_abs)} [S]: widen one of them (--priors)")


def start_ball(target, z0, cov, centre, spread, nwalkers: int, rng: np.random.Generator, *,
               uniform: dict[int, tuple[float, float]] | None = None) -> np.ndarray:
    """``nwalkers`` sampling-space points: the first ``len(z0)`` coordinates from ``N(z0, cov)``,
    the rest (noise) from independent normals (``centre``, ``spread``), except coordinates ``i`` of
    ``uniform`` (``{i: (low, high)}``), drawn uniformly; clipped to the prior support of
    ``target.params``, each with a finite posterior; the ball shrinks if too many fall outside.
    Correlations are shrunk to at most 0.99 in magnitude: a parameter the data do not separate
    from another (a lead resistance beside R0) makes the fit's covariance nearly singular, and
    walkers drawn from it would be linearly dependent (emcee refuses such a start). A standard
    deviation wider than a quarter of the coordinate's prior range is narrowed to it, keeping the
    correlations: a parameter the data do not determine (a spare ring of an over-sized NL fit) can
    have a least-squares standard error of 1e3 e-folds, which says only "anywhere in the prior";
    drawn as it is, half the walkers land clipped on each bound (several columns then repeat one
    pattern, and emcee refuses the start), and the covariance's 1e20 condition number spoils the
    draws of the well-determined coordinates.

    Coordinates whose standard deviation was narrowed, or exceeds ``LOOSE_SD`` (one e-fold of a
    log-transformed parameter: beyond it the fit's linearisation says little about the posterior)
    may cost a walker at most
    ``m/2 + 5 sqrt(m/2)`` nats of log posterior (``m`` of them: a Gaussian's draws exceed that with
    probability below 1e-6) against the same walker with them at the centre's values; beyond that
    they are pulled back towards the centre's, by bisection, to the farthest point within it. The
    cap leaves a spare ring's walkers spread over a quarter of its prior, which is flat only where
    the ring is inert; elsewhere they start thousands of nats below the mode (an NL(5) fit of
    NL(2) data: 5000 nats), never come back, and the unconverged chain inflates the noise scales
    to fit (its bridge log Z came out 6000 nats low). The fit of an NL(4) to NL(2) data gives its
    real rings and ``Pg`` standard errors of 3-5 e-folds, under the cap: walkers drawn with them
    started 1e7-3e8 nats down (bridge log Z 14660 nats against NL(2)'s 27518). Starts with no
    such coordinate are unchanged."""
    k = len(z0)
    lo, hi = (np.asarray(b, float) for b in target.params.bounds_z())
    cov = 0.5 * (cov + cov.T)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    cap = np.where(np.isfinite(hi[:k] - lo[:k]), (hi[:k] - lo[:k]) / 4.0, np.inf)
    if np.any(sd > cap):
        d = np.where(sd > cap, cap / np.where(sd > 0, sd, 1.0), 1.0)
        cov = cov * np.outer(d, d)
    loose = sd > np.minimum(cap, LOOSE_SD)
    cov = 0.99 * cov + 0.01 * np.diag(np.diag(cov))
    cov = cov + np.eye(k) * 1e-12 * np.max(np.abs(np.diag(cov)))
    out = np.empty((nwalkers, target.ndim))
    filled = 0
    for _ in range(50):
        n = nwalkers - filled
        zm = rng.multivariate_normal(z0, cov, size=n, method="eigh")
        zn = np.asarray(centre) + np.asarray(spread) * rng.standard_normal((n, len(centre)))
        cand = np.hstack([zm, zn])
        for i, (a, b) in (uniform or {}).items():
            cand[:, i] = rng.uniform(a, b, size=n)
        cand = target.params.clip_inside(cand)
        lp = target.log_posterior_z(cand)
        keep = np.flatnonzero(np.isfinite(lp))[:n]
        good = cand[keep]
        if np.any(loose):
            good = _pull_free_coordinates(target, np.r_[z0, centre], good, lp[keep],
                                          np.r_[loose, np.zeros(len(centre), bool)])
        out[filled : filled + good.shape[0]] = good
        filled += good.shape[0]
        if filled == nwalkers:
            return out
        cov = cov * 0.25
    raise FitError(f"{target.label}: could not start the walkers: the posterior is zero around "
                   "the least-squares fit (check the priors against the fitted values)")


def _pull_free_coordinates(target, centre: np.ndarray, z: np.ndarray, lp_z: np.ndarray, free: np.ndarray,
                           *, steps: int = 40) -> np.ndarray:
    """``z (n, d)``, whose log posteriors are ``lp_z``, with the coordinates of the boolean mask
    ``free`` (``m`` of them) pulled towards ``centre``'s wherever they cost the walker more than
    ``m/2 + 5 sqrt(m/2)`` nats of log posterior against the same walker with them at the centre's
    values: by bisection on the fraction of the way, to the farthest point within that allowance
    (all walkers in one call per step)."""
    free = np.asarray(free, bool)
    m = int(free.sum())
    if z.shape[0] == 0 or m == 0:
        return z
    base = np.where(free, centre, z)  # the fraction 0 of the way
    floor = target.log_posterior_z(base) - (0.5 * m + 5.0 * math.sqrt(0.5 * m))
    bad = np.flatnonzero(np.isfinite(floor) & ~(lp_z >= floor))
    if bad.size == 0:
        return z
    dz = z[bad] - base[bad]
    lo_t, hi_t = np.zeros(bad.size), np.ones(bad.size)  # lp(lo_t) >= floor > lp(hi_t)
    for _ in range(steps):
        mid = 0.5 * (lo_t + hi_t)
        ok = target.log_posterior_z(base[bad] + mid[:, None] * dz) >= floor[bad]
        lo_t, hi_t = np.where(ok, mid, lo_t), np.where(ok, hi_t, mid)
    out = z.copy()
    out[bad] = base[bad] + lo_t[:, None] * dz
    return out
