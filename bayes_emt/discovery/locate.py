"""Where a fitted model and a recording differ: bands of significant, structured mismatch.

The residuals are normalised by the noise model of :class:`~bayes_emt.inference.likelihood.Likelihood`
(each part of ``Y_model − Y_meas`` has standard deviation ``σ |Y_meas|``) and read in frequency
order, real and imaginary parts separately. ``σ`` is estimated from the residuals' second
differences (median absolute deviation), which a smooth misfit hardly touches, so a mismatch does
not hide itself by inflating the noise estimate.

**Scan.** For window lengths ``L = 8, 16, 32, …`` points (stride ``L/4``) and each part, the
statistic of a window is the energy of the residual's projection on the orthonormal polynomials of
degree 0, 1, 2 over the window (``χ²₃`` for white residuals): a smooth, signed structure of any
width, an S-shape included, raises it. The largest statistic over every window and both parts is
compared with its distribution under the fitted model, simulated by a linearised parametric
bootstrap: replicate residuals are white noise with the model's Jacobian projected out (what a
refit would absorb), normalised by their own second-difference noise estimate, scanned the same
way. The threshold is the ``1 − α`` quantile of the replicates' maxima, so the probability of
*any* false band on data the model explains is ``α`` (family-wise, over all bands and both parts).

Significant windows that overlap are merged into bands; each band states which parts mismatch.
Ljung–Box and runs tests on the normalised residuals are reported beside the scan as supporting
evidence (they say *whether*, not *where*).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..measurement import Measurement
from ..models import Model
from ..models.residual import relative_residual

__all__ = [
    "Band",
    "Location",
    "locate_mismatch",
    "noise_scale",
    "scan_statistics",
    "ljung_box",
    "runs_test",
    "projected_jacobian",
]

#: family-wise false-alarm probability of the scan (any false band anywhere)
ALPHA = 0.01
#: linearised bootstrap replicates calibrating the threshold
REPLICATES = 400
_MIN_WINDOW = 8
_DEGREE = 2


@dataclass(frozen=True)
class Band:
    """One band of significant mismatch.

    ``lo``, ``hi`` [rad/s] its ends (the outermost significant windows' first and last points);
    ``i_lo``, ``i_hi`` the point indices (inclusive); ``parts`` which of ``"real"``, ``"imag"``
    mismatch there; ``peak_statistic`` the largest window statistic inside (``χ²₃``-scale) and
    ``threshold`` the calibrated family-wise threshold; ``peak_omega`` [rad/s] the centre of
    the window with the largest statistic."""

    lo: float
    hi: float
    i_lo: int
    i_hi: int
    parts: tuple[str, ...]
    peak_statistic: float
    threshold: float
    peak_omega: float

    def to_json_dict(self) -> dict:
        return {
            "band_rad_s": [self.lo, self.hi],
            "band_hz": [self.lo / (2 * np.pi), self.hi / (2 * np.pi)],
            "parts": list(self.parts),
            "peak_statistic": self.peak_statistic,
            "threshold": self.threshold,
            "peak_omega_rad_s": self.peak_omega,
        }


@dataclass(frozen=True)
class Location:
    """The result of :func:`locate_mismatch`: bands (strongest first), the noise estimate
    ``sigma_rel`` (relative std of each part), the threshold and the whole-record maximum
    statistic with its bootstrap p-value, and the whiteness tests (``{"real": {...}, "imag": {...}}``)."""

    bands: tuple[Band, ...]
    sigma_rel: float
    threshold: float
    max_statistic: float
    p_value: float
    whiteness: dict = field(default_factory=dict)
    normalised: np.ndarray | None = None

    @property
    def significant(self) -> bool:
        return bool(self.bands)

    def to_json_dict(self) -> dict:
        return {
            "bands": [b.to_json_dict() for b in self.bands],
            "sigma_rel": self.sigma_rel,
            "threshold": self.threshold,
            "max_statistic": self.max_statistic,
            "p_value": self.p_value,
            "alpha": ALPHA,
            "whiteness": self.whiteness,
        }


def noise_scale(x: np.ndarray) -> np.ndarray:
    """Robust noise std of ``x`` along its last axis from second differences: for white noise of
    std σ, ``Δ²x`` has std ``σ √6``; the median absolute deviation (×1.4826) resists structure."""
    d2 = np.diff(x, n=2, axis=-1)
    mad = np.median(np.abs(d2 - np.median(d2, axis=-1, keepdims=True)), axis=-1)
    return 1.4826 * mad / np.sqrt(6.0)


def _windows(n: int) -> list[tuple[int, int, np.ndarray]]:
    """``(length, stride, Q)`` per scale: ``Q`` (L, 3) orthonormal polynomial basis on L points."""
    out = []
    L = _MIN_WINDOW
    while L <= n:
        x = np.linspace(-1.0, 1.0, L)
        V = np.vander(x, _DEGREE + 1, increasing=True)
        Q, _ = np.linalg.qr(V)
        out.append((L, max(1, L // 4), Q))
        if L == n:
            break
        L = min(2 * L, n)
    return out


def scan_statistics(r: np.ndarray) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """Window statistics of normalised residuals ``r (..., n)``: per scale ``(L, starts, T)`` with
    ``T (..., n_windows)`` the energy of the projection on degree ≤ 2 polynomials (χ²₃ if white)."""
    n = r.shape[-1]
    out = []
    for L, step, Q in _windows(n):
        starts = np.arange(0, n - L + 1, step)
        if starts[-1] != n - L:
            starts = np.r_[starts, n - L]
        win = np.lib.stride_tricks.sliding_window_view(r, L, axis=-1)[..., starts, :]
        proj = win @ Q
        out.append((L, starts, np.sum(proj * proj, axis=-1)))
    return out


def _max_stat(r: np.ndarray) -> np.ndarray:
    return np.max(np.stack([np.max(T, axis=-1) for _, _, T in scan_statistics(r)], axis=-1), axis=-1)


def projected_jacobian(model: Model, meas: Measurement, theta, h: float = 1e-6) -> np.ndarray:
    """Orthonormal basis (2F, r) of the columns of the Jacobian of the relative residuals
    ``[Re; Im] (Y(θ) − Y)/|Y|`` with respect to the sampling-space parameters (central
    differences): the directions a refit absorbs."""
    z = model.params.to_z(np.asarray(theta, float))
    k = z.size
    Z = np.repeat(z[None], 2 * k, axis=0)
    for i in range(k):
        step = h * max(1.0, abs(z[i]))
        Z[2 * i, i] += step
        Z[2 * i + 1, i] -= step
    with np.errstate(all="ignore"):
        Yp = model.admittance(meas.omega, model.params.from_z(Z)) / np.abs(meas.Y)
    d = Yp[0::2] - Yp[1::2]
    J = np.concatenate([d.real, d.imag], axis=1).T
    J = J[:, np.all(np.isfinite(J), axis=0)]
    J = J / np.maximum(np.linalg.norm(J, axis=0), 1e-300)
    U, sv, _ = np.linalg.svd(J, full_matrices=False)
    return U[:, sv > 1e-8 * sv[0]] if sv.size else U[:, :0]


def ljung_box(x: np.ndarray, lags: int = 20) -> dict:
    """Ljung–Box ``Q = n(n+2) Σ_{k≤h} ρ_k²/(n−k)`` of a series and its χ²_h p-value."""
    x = np.asarray(x, float) - np.mean(x)
    n = x.size
    h = min(lags, n // 4)
    denom = float(x @ x)
    rho = np.array([float(x[:-k] @ x[k:]) / denom for k in range(1, h + 1)])
    Q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, h + 1))))
    return {"Q": Q, "lags": h, "p_value": float(stats.chi2.sf(Q, h))}


def runs_test(x: np.ndarray) -> dict:
    """Wald–Wolfowitz runs test on the signs of ``x``: z-score and two-sided p-value (too few runs
    means residuals of one sign cluster in frequency: structure)."""
    s = np.asarray(x) > 0
    n1, n2 = int(s.sum()), int((~s).sum())
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    n = n1 + n2
    if n1 == 0 or n2 == 0:
        return {"runs": runs, "z": float("-inf"), "p_value": 0.0}
    mu = 2.0 * n1 * n2 / n + 1.0
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1.0))
    z = (runs - mu) / np.sqrt(var)
    return {"runs": runs, "z": float(z), "p_value": float(2 * stats.norm.sf(abs(z)))}


def locate_mismatch(
    meas: Measurement,
    model: Model,
    theta,
    *,
    alpha: float = ALPHA,
    replicates: int = REPLICATES,
    seed: int = 0,
) -> Location:
    """Bands where ``model`` at ``theta`` misfits ``meas`` beyond its noise (module docstring).

    Parameters
    ----------
    meas : the measurement; model, theta : the fitted model and its values [SI].
    alpha : family-wise false-alarm probability (any false band anywhere).
    replicates : linearised parametric-bootstrap replicates calibrating the threshold.
    seed : seed of the replicates.
    """
    model = model.bind(meas.omega)
    if meas.n_points < 4 * _MIN_WINDOW:
        raise ValueError(
            f"{meas.source}: {meas.n_points} points are too few to locate a mismatch (need {4 * _MIN_WINDOW})"
        )
    with np.errstate(all="ignore"):
        rel = relative_residual(model, theta, meas)
    parts = np.stack([rel.real, rel.imag])
    sig = float(np.sqrt(np.mean(noise_scale(parts) ** 2)))
    sig = max(sig, 1e-12)
    r = parts / sig
    n = meas.n_points
    # the scan's null distribution: white residuals after a linearised refit
    U = projected_jacobian(model, meas, theta)
    rng = np.random.default_rng(seed)
    maxima = np.empty(replicates)
    for b0 in range(0, replicates, 50):
        e = rng.standard_normal((min(50, replicates - b0), 2 * n))
        e = e - (e @ U) @ U.T
        e = e.reshape(-1, 2, n)
        s = np.sqrt(np.mean(noise_scale(e) ** 2, axis=-1))
        maxima[b0 : b0 + e.shape[0]] = _max_stat(e / s[:, None, None]).max(axis=-1)
    thr = float(np.quantile(maxima, 1.0 - alpha))
    scales = scan_statistics(r)
    obs_max = float(max(np.max(T) for _, _, T in scales))
    p = float((1 + np.count_nonzero(maxima >= obs_max)) / (1 + replicates))
    # significant windows per part, merged into bands
    flagged = []  # (i_lo, i_hi, part, T)
    for L, starts, T in scales:
        for j, part in enumerate(("real", "imag")):
            for k in np.flatnonzero(T[j] > thr):
                flagged.append((int(starts[k]), int(starts[k] + L - 1), part, float(T[j, k])))
    bands = _merge(flagged, meas.omega, thr)
    white = {
        part: {"ljung_box": ljung_box(r[j]), "runs": runs_test(r[j])}
        for j, part in enumerate(("real", "imag"))
    }
    return Location(tuple(bands), sig, thr, obs_max, p, white, r[0] + 1j * r[1])


def _merge(flagged, omega, thr) -> list[Band]:
    """Overlapping significant windows → bands (strongest first). A band's extent is that of its
    narrowest significant windows (up to 4x the shortest significant length in the group): a wide
    window that is significant only because it contains a narrower mismatch does not widen the
    band."""
    if not flagged:
        return []
    flagged.sort()
    groups, cur, end = [], [flagged[0]], flagged[0][1]
    for f in flagged[1:]:
        if f[0] <= end:
            cur.append(f)
            end = max(end, f[1])
        else:
            groups.append(cur)
            cur, end = [f], f[1]
    groups.append(cur)
    bands = []
    for g in groups:
        best = max(g, key=lambda f: f[3])
        ref = min(f[1] - f[0] + 1 for f in g)
        core = [f for f in g if f[1] - f[0] + 1 <= 4 * ref]
        lo, hi = min(f[0] for f in core), max(f[1] for f in core)
        parts = tuple(p for p in ("real", "imag") if any(f[2] == p for f in g))
        bands.append(
            Band(
                float(omega[lo]),
                float(omega[hi]),
                lo,
                hi,
                parts,
                best[3],
                thr,
                float(np.sqrt(omega[best[0]] * omega[best[1]])),
            )
        )
    bands.sort(key=lambda b: -b.peak_statistic)
    return bands
