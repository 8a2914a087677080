"""The log evidence of a least-squares fit: the Laplace screen, and an honest fallback when the
screen fails. One function, :func:`fit_log_evidence`, which the comparison's screen
(:func:`bayes_emt.evidence.compare.model_evidence` without a posterior) and the diagnosis's candidate
ranking (:mod:`bayes_emt.discovery`) share.

The Laplace screen (:func:`bayes_emt.evidence.laplace.laplace_evidence`) needs a positive definite
Hessian of the log posterior at its mode. It fails when the posterior is flat (or nearly so) along
some direction:

* a parameter the data do not determine against another (a lead resistance beside ``R0``: only
  their sum is seen), or one the data do not determine at all (a capacitance far below what the
  data can see, pressed against its prior bound);
* a noise scale whose likelihood is flat (the relative noise when the absolute noise explains the
  residuals, or the reverse): its posterior is the prior's down to the bound;
* a parameter the likelihood depends on only piecewise (a measurement step's frequency ``ωs``: the
  data change only when it crosses a measured frequency, so the curvature is zero between points).

Dropping such a candidate throws away fits that explain the data, and a flat direction does not
make the evidence undefined: ``Z = ∫ q`` is still a proper integral (the priors are proper). The
fallback here, :func:`subspace_laplace`, keeps the Laplace approximation where the posterior is
curved and integrates the flat directions numerically:

1. at the posterior mode ``ξ̂`` (climbed to from the screen's end point and from both noise
   regimes; every bounded coordinate logit-mapped, :mod:`bayes_emt.evidence.warp`), the Hessian
   ``H`` of ``−log q`` is computed by central differences in whitened coordinates, re-whitened by
   its curved eigen-directions until their curvature is about one;
2. eigen-directions with curvature ``λ > TAU`` (whitened units) are the *identifiable subspace*:
   Gaussian, ``½ log 2π − ½ log λ`` each, as Laplace does;
3. each remaining direction ``u`` (``|λ| ≤ TAU``: flat) is integrated along the line
   ``ξ̂ + t u`` by a trapezoid rule on a grid dense near ``t = 0`` and refined until it agrees with
   itself to 0.01 nats: ``log ∫ exp(log q(ξ̂ + t u) − log q(ξ̂)) dt``. The prior's support ends the
   line (``q = 0`` outside it), so a direction the data do not determine costs the prior mass it
   leaves, the Occam factor, not more and not less;
4. a direction of clearly negative curvature (``λ < −TAU``: a saddle, not a mode) fails the
   fallback: there is no honest number, the candidate stays out.

``log Z ≈ log q(ξ̂) + log |det L| + Σ_curved (½ log 2π − ½ log λ) + Σ_flat log I``. This
product assumes that the flat directions separate from the curved ones (exact for a Gaussian,
whose Hessian eigen-directions are independent, not along a curved ridge), so it is then checked
and corrected:

5. importance sampling from the approximation itself (Student-t, 5 degrees of freedom, along the
   curved directions; the line densities along the flat ones): ``Z = E_q̃[q/q̃]`` with
   :data:`N_IS` draws (seeded), the estimate and its standard error, which is the number used. It
   is consistent whatever the approximation's error, and low by Jensen's inequality when the
   weights are uneven; with an effective sample size below :data:`MIN_ESS` there is no honest
   number and the fallback fails.

Nothing here favours the candidate: a direction the data do not determine costs its prior mass,
a poorly matched approximation shows as uneven weights. The method used and the flat directions
(the parameters they mostly move) are recorded, so the diagnosis says when a ``Δ log Z`` came from
the fallback, and the directions feed the identifiability statement ("improves the fit" without
"is determined by the data").
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..inference.likelihood import Likelihood
from ..inference.sampling import noise_start
from ..inference.start import extra_noise_start, floor_noise_start, posterior_mode
from ..measurement import Measurement
from ..params import clip_inside
from .laplace import affine_map, hessian_fd, laplace_evidence
from .step_intervals import STEP_METHOD, step_interval_evidence, step_parameter
from .warp import Warp

__all__ = ["Evidence", "fit_log_evidence", "fit_start", "subspace_laplace", "slice_log_integral", "TAU"]

#: whitened curvature at or below which a direction counts as flat (posterior wider than ten times
#: the scale the Hessian was taken at); such directions are integrated numerically
TAU = 1e-2
#: log-density drop [nats] at which a line integral's range ends
DROP = 30.0
#: importance-sampling draws and the Student-t proposal's degrees of freedom
N_IS = 4000
IS_DOF = 5
#: importance-sampling effective sample size below which the fallback gives no number
MIN_ESS = 10
#: re-whitening passes of the Hessian at most
MAX_PASSES = 8
#: parameter sets per call of the log density: the importance sampling's 4000 draws and the line
#: grids evaluated in blocks of this many (the same values; a model without the likelihood's fast
#: path makes several (n, F) temporaries per call, and blocks that fit the cache halve its time on a
#: 2000-point recording)
BLOCK_ROWS = 64


@dataclass(frozen=True)
class Evidence:
    """A log evidence and how it was obtained.

    ``log_z`` [nats] (``nan``: no estimate); ``method`` ``"laplace"`` or ``"laplace_subspace"``
    (the fallback; ``"failed"`` when neither gave a number; ``"bounded"`` when the fallback was not
    run because the likelihood's maximum, ``upper`` [nats], is below what the caller needs:
    :func:`fit_log_evidence`'s ``below``); ``note`` why the screen failed and what the fallback did;
    ``flat`` for each flat direction the parameter names it mostly moves."""

    log_z: float
    method: str
    note: str = ""
    flat: tuple[tuple[str, ...], ...] = ()
    n_calls: int = 0
    upper: float = float("nan")

    @property
    def fallback(self) -> bool:
        """Whether the number is the subspace fallback's (or none), not a Laplace screen's (a step
        model's interval sum, :mod:`.step_intervals`, is Laplace in each interval)."""
        return self.method not in ("laplace", STEP_METHOD)

    def to_json_dict(self) -> dict:
        """The comparison's ``by_method["laplace"]`` record."""
        ok = math.isfinite(self.log_z)
        return {"method": "laplace", "log_evidence": self.log_z if ok else None, "err": None,
                "n_calls": self.n_calls, "ok": ok and not self.fallback, "message": self.note,
                "estimator": self.method}


def slice_log_integral(g, c: float = 0.1, t_max: float = 1e4, tol: float = 0.01) -> float:
    """``log ∫ exp(g(t)) dt`` (:func:`_slice`)."""
    return _slice(g, c, t_max, tol)[0]


def _slice(g, c: float = 0.1, t_max: float = 1e4, tol: float = 0.01):
    """``log ∫ exp(g(t)) dt`` of a vectorised ``g`` with ``g(0) = 0`` (a log density along a line,
    relative to its value at ``t = 0``; ``nan``/``−inf`` outside the support).

    The range is found by doubling ``|t|`` from ``c`` until ``g`` drops by :data:`DROP` nats or
    leaves the support (``nan`` if it does not by ``t_max``: an improper direction); the integral
    is the trapezoid rule in ``u = asinh(t/c)`` (points dense near ``t = 0``, sparse far out),
    doubled until two successive rules agree within ``tol`` nats (a doubled grid reuses the values
    at the points it shares with the last). Returns ``(log I, t, g(t))``
    on the last grid."""

    def gv(t):
        with np.errstate(all="ignore"):
            v = np.asarray(g(np.atleast_1d(np.asarray(t, float))), float)
        return np.where(np.isfinite(v), v, -np.inf)

    ends = []
    for sign in (1.0, -1.0):
        t = c
        while gv(sign * t)[0] > -DROP:
            t *= 2.0
            if t > t_max:
                return float("nan"), None, None
        ends.append(sign * t)
    u_hi, u_lo = math.asinh(ends[0] / c), math.asinh(ends[1] / c)
    prev = v = None
    for n in (201, 401, 801, 1601, 3201, 6401):
        u = np.linspace(u_lo, u_hi, n)
        t = c * np.sinh(u)
        if v is None:
            v = gv(t)
        else:  # each grid holds the last one's points (every other point): only the new ones evaluated
            v_new = np.empty(n)
            v_new[0::2] = v
            v_new[1::2] = gv(t[1::2])
            v = v_new
        m = float(np.max(v))
        if not math.isfinite(m):
            return float("nan"), None, None
        w = np.exp(v - m) * c * np.cosh(u)
        cur = m + math.log(float(np.trapezoid(w, u)))
        if prev is not None and abs(cur - prev) < tol:
            break
        prev = cur
    return cur, t, v


def _importance_check(log_q, xi, D, lam_curved, curved, grids, seed):
    """``(log Z, se, ESS)`` by importance sampling from the subspace approximation: Student-t
    (5 degrees of freedom, the curved directions' Laplace scales) times the flat directions'
    piecewise-constant line densities, mapped by ``ξ = ξ̂ + D t``."""
    rng = np.random.default_rng(seed)
    n, k = N_IS, xi.size
    T = np.zeros((n, k))
    logp = np.zeros(n)
    ic = np.flatnonzero(curved)
    if ic.size:
        sd = 1.0 / np.sqrt(lam_curved)
        x = rng.standard_t(IS_DOF, size=(n, ic.size))
        T[:, ic] = x * sd
        logp += np.sum(_t_logpdf(x, IS_DOF) - np.log(sd), axis=1)
    for i, (tg, vg) in zip(np.flatnonzero(~curved), grids, strict=True):
        edges = np.r_[tg[0], 0.5 * (tg[1:] + tg[:-1]), tg[-1]]
        width = np.diff(edges)
        lw = np.where(width > 0, vg + np.log(np.where(width > 0, width, 1.0)), -np.inf)
        lw -= np.logaddexp.reduce(lw)
        cell = rng.choice(tg.size, size=n, p=np.exp(lw))
        T[:, i] = edges[cell] + rng.random(n) * width[cell]
        logp += lw[cell] - np.log(width[cell])
    _sign, logdet = np.linalg.slogdet(D)
    with np.errstate(all="ignore"):
        lq = np.asarray(log_q(xi[None, :] + T @ D.T), float)
    lw = np.where(np.isfinite(lq), lq - logp + logdet, -np.inf)
    m = float(np.max(lw))
    if not math.isfinite(m):
        return float("nan"), float("nan"), 0.0
    w = np.exp(lw - m)
    mean = float(np.mean(w))
    se = float(np.std(w) / math.sqrt(n) / mean)
    ess = float(np.sum(w) ** 2 / np.sum(w**2))
    return m + math.log(mean), se, ess


def _t_logpdf(x, nu):
    return (math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2) - 0.5 * math.log(nu * math.pi)
            - (nu + 1) / 2 * np.log1p(x**2 / nu))


def subspace_laplace(log_density_z, names, z_mode, warp: Warp, seed: int = 0) -> tuple[float, str, tuple]:
    """``(log Z, note, flat)`` by Laplace on the curved subspace and line integrals along the flat
    directions, corrected by importance sampling from that approximation (module docstring), at
    ``z_mode`` (sampling space) of the vectorised ``log_density_z``; ``warp`` maps it to unbounded
    coordinates; ``names`` the coordinates' names (for the note); ``seed`` the draws'."""
    log_q = warp.log_density(log_density_z)
    z_mode = np.asarray(z_mode, float)
    xi = warp.to_xi(z_mode)
    if not np.all(np.isfinite(xi)):
        return float("nan"), "the mode lies on a prior bound", ()
    # whitening: first per coordinate (the step that lowers log q by 0.005 nats, a tenth of a
    # standard deviation where the posterior is Gaussian), since the fit's covariance can be decades
    # off (a ridge, a parameter at its bound); capped so that no point leaves the prior's support
    lo, hi = warp.lo.copy(), warp.hi.copy()
    b = warp.bounded
    lo[b], hi[b] = -np.inf, np.inf
    room = np.minimum(np.minimum(xi - lo, hi - xi), 10.0)
    h = np.minimum(1e-2, 0.5 * room)
    k = xi.size
    f0 = float(log_q(xi[None, :])[0])
    for _ in range(40):
        pts = np.vstack([xi + np.diag(h), xi - np.diag(h)])
        with np.errstate(all="ignore"):
            v = np.asarray(log_q(pts), float)
            drop = f0 - 0.5 * (v[:k] + v[k:])
        bad = ~np.isfinite(drop)
        grow = np.clip(np.sqrt(0.005 / np.maximum(np.abs(drop), 1e-300)), 0.1, 10.0)
        factor = np.where(bad, 0.1, np.where(drop > 1e-12, grow, 10.0))
        h_new = np.minimum(h * factor, 0.5 * room)
        if np.all(~bad & ((h_new >= 0.5 * room) | ((drop > 0.0025) & (drop < 0.01)))):
            break
        h = h_new
    L = np.diag(h / 0.1)

    def neg_hessian(L):
        # −∇² log q in the coordinates whitened by L; the whitening shrunk (tenfold, up to 10⁻⁴) while
        # a difference point gives a non-finite log density (a model evaluation out of range)
        for shrink in (1.0, 1e-1, 1e-2, 1e-3, 1e-4):
            Ls = L * shrink
            x_of = affine_map(xi, Ls)
            H, f0, _n = hessian_fd(lambda e, x_of=x_of: log_q(x_of(e)), np.zeros(xi.size))
            if math.isfinite(f0) and np.all(np.isfinite(H)):
                return -0.5 * (H + H.T), f0, Ls
        return None, f0, L

    # re-whiten until the curved directions' curvature is about one (the difference step a tenth
    # of the posterior's width in each; a start scale decades off needs several passes)
    for _ in range(MAX_PASSES):
        H, f0, L = neg_hessian(L)
        if H is None:
            return float("nan"), "the log posterior is not finite around the mode", ()
        lam, V = np.linalg.eigh(H)
        L = L @ V * np.where(lam > TAU, 1.0 / np.sqrt(np.clip(lam, TAU, None)), 1.0)
        if np.all((lam <= TAU) | ((lam > 0.5) & (lam < 2.0))):
            break
    # L now whitens the curved directions to unit curvature
    H, f0, L = neg_hessian(L)
    if H is None:
        return float("nan"), "the log posterior is not finite around the mode", ()
    lam, V = np.linalg.eigh(H)
    if np.any(lam < -TAU):
        return float("nan"), "the mode is a saddle (a direction of negative curvature)", ()
    curved = lam > TAU
    # directions in ξ; a flat one is walked at unit speed (t in ξ units), its volume factor moved
    # from the determinant to the line element
    D = L @ V
    norms = np.linalg.norm(D, axis=0)
    D[:, ~curved] /= norms[~curved]
    _sign, logdet = np.linalg.slogdet(D)
    log_z = f0 + float(logdet) + float(np.sum(0.5 * math.log(2 * math.pi) - 0.5 * np.log(lam[curved])))
    flat, grids = [], []
    for i in np.flatnonzero(~curved):
        u = D[:, i]
        c = float(np.clip(0.1 * norms[i], 1e-6, 0.1))
        li, tg, vg = _slice(lambda t, u=u: log_q(xi[None, :] + t[:, None] * u[None, :]) - f0, c=c)
        if not math.isfinite(li):
            return float("nan"), "a flat direction does not end inside the prior (improper)", ()
        log_z += li
        grids.append((tg, vg))
        # the parameters the direction mostly moves (in sampling-space units)
        dz = warp.from_xi(xi + 1e-3 * u) - z_mode
        a = np.abs(dz)
        flat.append(tuple(n for n, x in zip(names, a, strict=True) if x >= 0.3 * float(np.max(a))))
    product = log_z
    log_z, se, ess = _importance_check(log_q, xi, D, lam[curved], curved, grids, seed)
    if not math.isfinite(log_z) or ess < MIN_ESS:
        return float("nan"), (
            f"importance sampling from the subspace approximation ({product:.1f}) does not confirm it "
            f"(effective sample size {ess:.0f} of {N_IS})"), ()
    note = (
        f"Laplace on the {int(curved.sum())}-dimensional identifiable subspace; "
        + (
            "flat direction(s) integrated numerically along "
            + "; ".join(" / ".join(f) for f in flat)
            if flat
            else "no flat direction found on a second look"
        )
        + f"; that approximation ({product:.1f}) corrected by importance sampling from it: "
        f"{log_z:.1f} ± {se:.1f} (effective sample size {ess:.0f} of {N_IS})"
    )
    return float(log_z), note, tuple(flat)


def blocked(log_density_z, rows: int = BLOCK_ROWS):
    """``log_density_z`` evaluated in blocks of at most ``rows`` parameter sets (:data:`BLOCK_ROWS`):
    the same function of ``z (n, k) -> (n,)``, at a fraction of the memory traffic for large ``n``."""

    def f(z):
        z = np.asarray(z, float)
        if z.ndim < 2 or z.shape[0] <= rows:
            return log_density_z(z)
        return np.concatenate([np.asarray(log_density_z(z[i:i + rows]), float)
                               for i in range(0, z.shape[0], rows)])

    return f


def fit_start(lik: Likelihood, fit) -> tuple[np.ndarray, np.ndarray, Warp]:
    """The Laplace screen's start from a least-squares ``fit``: ``(z0, scale, warp)`` in ``lik``'s
    sampling space. ``z0`` is the fit's values with the noise scales started from its residual
    (:func:`~bayes_emt.inference.sampling.noise_start`); ``scale`` whitens by the fit's covariance (a
    0.1 % guess per coordinate when it has none) and the noise start's spread; ``warp`` logit-maps
    the noise coordinates, whose posterior may press against a prior bound, which a fit cannot
    tell."""
    k = lik.model.ndim
    centre, spread = noise_start(fit.rms_rel_residual, float(np.min(np.abs(lik.meas.Y))))
    extra, extra_spread = extra_noise_start(lik, fit.theta)
    z0 = np.r_[fit.z, centre, extra]
    cov_fit = fit.cov_z if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)) else \
        np.diag((1e-3 * np.maximum(np.abs(fit.z), 1.0)) ** 2)
    scale = np.zeros((lik.ndim, lik.ndim))
    scale[:k, :k] = cov_fit
    scale[k:, k:] = np.diag(np.square(list(spread) + extra_spread))
    return z0, scale, Warp.of(lik.params, mask=np.arange(lik.ndim) >= k)


def fit_log_evidence(meas: Measurement, fit, *, lik: Likelihood | None = None,
                     below: float | None = None) -> Evidence:
    """The Laplace log evidence [nats] of ``fit.model`` on ``meas`` from a least-squares ``fit``
    (default likelihood: Gaussian with sampled noise scales; ``lik`` for another), started by
    :func:`fit_start` (the fit's covariance to whiten, the noise coordinates warped); when the
    screen fails, :func:`subspace_laplace` at the screen's mode (module docstring), flagged by
    :attr:`Evidence.method`. A model holding one instrument step has its step frequency marginalised
    over the intervals between measured points (:mod:`.step_intervals`, method ``"laplace_step"``)
    first; the screen and its fallback only when that fails.

    ``below`` [nats]: where the screen fails and every prior is uniform in sampling space (the log
    posterior is then the log-likelihood plus a constant inside the support, so its mode is the
    likelihood's maximum), the fallback is not run when the log-likelihood at that mode is below
    ``below``: the evidence, never above the likelihood's maximum (``Z = ∫ L π ≤ max L``, the priors
    proper), is then below it too; method ``"bounded"``, ``log_z`` nan, ``upper`` that maximum (the
    largest of the mode search's local maxima, from the screen's mode and both noise regimes)."""
    lik = Likelihood(fit.model, meas) if lik is None else lik
    k = lik.model.ndim
    z0, scale, warp = fit_start(lik, fit)
    step = step_parameter(lik.model)
    if step is not None:
        got = step_interval_evidence(meas, lik, blocked(lik.log_posterior_z),
                                     float(fit.model.as_dict(fit.theta)[step]), z0, scale, warp, step)
        if got is not None:
            return Evidence(got[0], STEP_METHOD, got[1], ((step,),))
    ev, why, mode = laplace_screen(blocked(lik.log_posterior_z), lik.params, z0, scale, warp)
    if ev is not None:
        return ev
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # the mode again, from both noise regimes (the noise scales' posterior can have two
            # modes: relative noise dominating, or the absolute floor), as the sampler's start does
            z_abs = z0.copy()
            z_abs[k : k + 2] = floor_noise_start(lik, fit.theta, z0[k])[0]
            z_abs = clip_inside(z_abs, *lik.params.bounds_z())
            starts = np.array([mode, z0, z_abs])
            mode = posterior_mode(lik, starts, scale + 1e-12 * np.eye(lik.ndim))
            if below is not None and not lik._box_prior.other:
                ll_max = float(lik.log_prob_z(mode[None, :])[1][0])
                if math.isfinite(ll_max) and ll_max < below:
                    note = (f"{why}; the fallback was not run: the evidence is at most the likelihood's "
                            f"maximum, {ll_max:.1f} nats")
                    return Evidence(float("nan"), "bounded", note, upper=ll_max)
            # every bounded coordinate logit-mapped: a flat direction then ends inside the
            # prior's support by the map's Jacobian, and no difference point can leave it
            lz, note, flat = subspace_laplace(blocked(lik.log_posterior_z), list(lik.params.names), mode,
                                              Warp.of(lik.params))
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as e:
        return Evidence(float("nan"), "failed", f"{why}; fallback failed: {e}")
    return fallback_evidence(lz, note, flat, why)


def laplace_screen(log_q, params, z0, scale, warp) -> tuple[Evidence | None, str, np.ndarray]:
    """The Laplace screen (:func:`~.laplace.laplace_evidence`) of ``log_q`` from ``z0``:
    ``(evidence, "", z0)`` when it succeeds, else ``(None, why it failed, the mode to start the
    subspace fallback from)`` (the screen's own mode when it found a finite one, else ``z0``)."""
    mode = z0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = laplace_evidence(log_q, params, z0, scale, warp=warp)
        if res.ok and math.isfinite(res.log_z):
            return Evidence(float(res.log_z), "laplace", n_calls=int(res.n_calls)), "", mode
        why = res.message or "the Laplace screen failed"
        if np.all(np.isfinite(res.mode_z)):
            mode = res.mode_z
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as e:
        why = str(e)
    return None, why, mode


def fallback_evidence(lz: float, note: str, flat, why: str) -> Evidence:
    """The subspace fallback's result (:func:`subspace_laplace`'s ``lz, note, flat``) after the
    screen failed for ``why``: method ``"laplace_subspace"``, or ``"failed"`` when ``lz`` is not finite."""
    if not math.isfinite(lz):
        return Evidence(float("nan"), "failed", f"{why}; fallback failed: {note}")
    return Evidence(float(lz), "laplace_subspace", f"{why}: {note}", flat)
