"""Automatic initial estimate (SPEC §3.1): no user guess, from the data alone.

Two stages, both linear least squares:

1. **Plant near the resonance (Levy / Sanathanan–Koerner).** Over a band around the resonance
   (found with :func:`bayes_emt.checks.locate_resonance`; the paper used 10–300 rad/s around
   ω0 ≈ 50 rad/s), the coil looks like ``R0 + L s`` and the admittance (47) is the rational function

       Y = (s² + a s + b) / (d3 s³ + d2 s² + d1 s + d0),   a = 2ζω0, b = ω0², c = φ̄²,
       d3 = L, d2 = R0 + L a, d1 = R0 a + L b + c, d0 = R0 b.

   ``num − den·Y = 0`` is linear in the redundant vector ``(a, b, d0..d3)``; weighted by
   ``W = 1/(jω)`` it is solved as one real least-squares problem, then mapped back:
   ``ω0 = √b, ζ = a/(2ω0), R0 = d0/b, L = d3, φ̄² = d1 − R0 a − L b``.

2. **Coil over the whole band.** With the motional term and ``R0`` removed from the measured
   impedance, the blocked coil impedance ``Zc(jω)`` is fitted per model by *separable* linear
   least squares: II is linear in ``(1/L0, 1/Rμ)`` through ``1/Zc``; III and UD are linear in
   ``β`` (and ``Lg``) for a given ``α``, which is found by a 1-D scan over decades — more robust
   than the paper's first-order rational Bessel approximation, which is also computed (the
   candidate with the smaller residual wins). NL and UL start from the UD estimate through the UL
   formulas (SPEC §2).

Every candidate (one per band) is completed with its coil estimate and scored by the rms
relative residual over all data; the best wins. If no band gives a physical linearised plant,
the resonance peak's height and width, and a multi-start around them, are tried instead. The path
taken is returned in :class:`InitialEstimate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .checks import locate_resonance
from .data import Measurement
from .errors import FitError
from .models import Model
from .models import terms as T

__all__ = ["InitialEstimate", "initial_estimate", "levy_plant", "coil_estimate"]


@dataclass(frozen=True)
class InitialEstimate:
    """The automatic initial estimate: ``theta`` (physical, model order) and how it was found."""

    theta: np.ndarray
    band: tuple[float, float]
    rms_rel_residual: float
    path: str
    details: dict = field(default_factory=dict)


def _lstsq_real(A, b, w):
    """Solve ``min ||w (A x - b)||`` over real ``x`` for complex ``A, b`` (columns scaled)."""
    Aw = A * w[:, None]
    bw = b * w
    Ar = np.vstack([Aw.real, Aw.imag])
    br = np.concatenate([bw.real, bw.imag])
    scale = np.linalg.norm(Ar, axis=0)
    scale[scale == 0] = 1.0
    x, *_ = np.linalg.lstsq(Ar / scale, br, rcond=None)
    return x / scale


def levy_plant(omega, Y, *, sk_iterations: int = 3):
    """Levy linearisation of model I over a band: returns ``(zeta, omega0, phi, R0, L)``.

    The first solve uses the paper's weight ``W = 1/(jω)``; ``sk_iterations`` Sanathanan–Koerner
    re-weightings by ``1/|den(jω)|`` of the previous solve then remove Levy's bias towards
    frequencies where the denominator is large. Raises :class:`FitError` if the mapped values
    are not physical (negative or non-finite).
    """
    s = 1j * np.asarray(omega, float)
    Y = np.asarray(Y, complex)
    # unknowns x = (a, b, d0, d1, d2, d3):  a s + b - Y (d0 + d1 s + d2 s² + d3 s³) = -s²
    A = np.column_stack([s, np.ones_like(s), -Y, -Y * s, -Y * s**2, -Y * s**3])
    w = 1.0 / np.abs(s)
    for _ in range(1 + sk_iterations):
        x = _lstsq_real(A, -(s**2), w)
        den = x[2] + x[3] * s + x[4] * s**2 + x[5] * s**3
        if not np.all(np.isfinite(den)) or np.any(den == 0):
            break
        w = 1.0 / np.abs(den)
    a, b, d0, d1, d2, d3 = x
    if not (b > 0 and a > 0):
        raise FitError(f"Levy estimate not physical (a={a:.3g}, b={b:.3g})")
    omega0 = np.sqrt(b)
    zeta = a / (2 * omega0)
    R0 = d0 / b
    L = max(d3, 0.0)
    c = d1 - R0 * a - L * b
    if not (R0 > 0 and c > 0 and np.isfinite(c)):
        raise FitError(f"Levy estimate not physical (R0={R0:.3g}, phi²={c:.3g})")
    return np.array([zeta, omega0, np.sqrt(c), R0, L])


def _blocked_coil(meas: Measurement, plant):
    zeta, omega0, phi, R0, _ = plant
    s = 1j * meas.omega
    return meas.Z - T.motional_impedance(s, zeta, omega0, phi) - R0


def _scan_alpha(omega, Zc, basis, alphas):
    """For each ``alpha``, nonneg. linear LSQ of ``Zc`` on ``basis(alpha)``; best by relative rms."""
    best = (np.inf, None, None)
    w = 1.0 / np.maximum(np.abs(Zc), 1e-300)
    for al in alphas:
        cols = basis(al)
        coef = _lstsq_real(cols, Zc, w)
        if np.any(coef < 0):
            # drop negative columns (non-physical) and refit the rest
            keep = coef > 0
            if not keep.any():
                continue
            coef = np.zeros_like(coef)
            coef[keep] = _lstsq_real(cols[:, keep], Zc, w)
            if np.any(coef < 0):
                continue
        err = np.sqrt(np.mean(np.abs((cols @ coef - Zc) * w) ** 2))
        if err < best[0]:
            best = (err, al, coef)
    return best


def coil_estimate(meas: Measurement, model: Model, plant) -> dict[str, float]:
    """Coil parameters of ``model`` from the blocked impedance (stage 2 above)."""
    omega = meas.omega
    s = 1j * omega
    Zc = _blocked_coil(meas, plant)
    L_lf = max(plant[4], 1e-12)
    kind = model.name
    if kind == "I":
        x = _lstsq_real(s[:, None], Zc, 1 / np.abs(Zc))
        return {"L0": float(x[0]) if x[0] > 0 else L_lf}
    if kind == "II":
        # 1/Zc = (1/L0)/s + 1/Rmu  (linear); weight so relative errors in Zc count evenly
        Yc = 1.0 / Zc
        x = _lstsq_real(np.column_stack([1 / s, np.ones_like(s)]), Yc, 1 / np.abs(Yc))
        L0 = 1 / x[0] if x[0] > 0 else L_lf
        Rmu = 1 / x[1] if x[1] > 0 else 1e3 * L0 * omega[-1]
        return {"L0": float(L0), "Rmu": float(Rmu)}
    # Bessel family: scan alpha over decades so that alpha*omega spans 1e-4..1e4 over the data
    alphas = np.geomspace(1e-4 / omega[-1], 1e4 / omega[0], 161)
    with_gap = kind in ("UD", "NL", "UL")

    def basis(al):
        cols = [T.bessel_eddy(s, al, 1.0)]
        if with_gap:
            cols.append(s)
        return np.column_stack(cols)

    err, al, coef = _scan_alpha(omega, Zc, basis, alphas)
    if al is None:
        raise FitError("no physical eddy-current estimate (alpha scan found none)")
    # refine alpha on a finer local grid
    err, al, coef = _scan_alpha(omega, Zc, basis, al * np.geomspace(0.9, 1.1, 41))
    beta = coef[0]
    Lg = coef[1] if with_gap and coef.size > 1 and coef[1] > 0 else 1e-3 * L_lf
    paper = _rational_bessel_estimate(s, Zc, with_gap)
    if paper is not None:
        cols = basis(paper["alpha"])
        vec = np.array([paper["beta"]] + ([paper["Lg"]] if with_gap else []))
        if np.sqrt(np.mean(np.abs((cols @ vec - Zc) / Zc) ** 2)) < err:
            return paper
    out = {"alpha": float(al), "beta": float(beta)}
    if with_gap:
        out["Lg"] = float(Lg)
    return out


def _rational_bessel_estimate(s, Zc, with_gap: bool):
    """The paper's variant (SPEC §3.1): the Bessel ratio replaced by its first-order rational
    approximation ``Z_III ≈ k s (α s + 8)/(4 α s + 16)``, ``k = β sqrt(α)``, plus ``Lg s`` for UD:
    ``16 Zc = −4 α s Zc + c2 s² + c1 s`` is linear in ``(α, c2, c1)`` with ``c1 = 16 Lg + 8 k``,
    ``c2 = (4 Lg + k) α``. Returns None when the mapped values are not physical."""
    x = _lstsq_real(np.column_stack([-4 * s * Zc, s * s, s]), 16 * Zc, 1 / np.abs(Zc))
    alpha, c2, c1 = x
    if not alpha > 0:
        return None
    if with_gap:
        k = c1 / 4 - c2 / alpha
        Lg = c1 / 16 - k / 2
    else:  # Lg = 0: c1 = 8 k
        k, Lg = c1 / 8, 0.0
    if not (k > 0 and (Lg > 0 or not with_gap)):
        return None
    out = {"alpha": float(alpha), "beta": float(k / np.sqrt(alpha))}
    if with_gap:
        out["Lg"] = float(Lg)
    return out


def _coil_to_theta(model: Model, plant, coil: dict) -> np.ndarray:
    vals = {"zeta": plant[0], "omega0": plant[1], "phi": plant[2], "R0": plant[3]}
    if model.name == "NL":
        Pg, P, R = T.uniform_rings(coil["Lg"], coil["alpha"], coil["beta"], model.rings, model.n_turns)
        vals["Pg"] = float(Pg)
        for j in range(model.rings):
            vals[f"P{j + 1}"] = float(P[j])
            vals[f"R{j + 1}"] = float(R[j])
    else:
        vals.update({k: coil[k] for k in coil if k in model.names})
    theta = model.vector(vals)
    lo = np.array([s.prior.lower for s in model.params])
    hi = np.array([s.prior.upper for s in model.params])
    # keep the start strictly inside the prior support
    return np.clip(theta, lo * 1.0001, hi * 0.9999)


def _rms_rel(model, meas, theta):
    Ym = model.admittance(meas.omega, theta)
    return float(np.sqrt(np.mean(np.abs(Ym - meas.Y) ** 2 / np.abs(meas.Y) ** 2)))


# plant-linearisation bands around the resonance, as multiples of omega0: the paper's
# 10–300 rad/s (≈ 0.2–6 ω0) first, then narrower ones where the coil is closer to R0 + L s
_BANDS = ((0.2, 6.0), (0.4, 2.5), (0.6, 1.6))


def resonance_bands(meas: Measurement) -> list[tuple[float, float]]:
    """Candidate bands [rad/s] for the plant linearisation, clipped to the data."""
    res = locate_resonance(meas)
    if res is None:
        return [(float(meas.omega[0]), float(meas.omega[-1]))]
    out = []
    for lo_f, hi_f in _BANDS:
        lo = max(meas.omega[0], lo_f * res.omega)
        hi = min(meas.omega[-1], hi_f * res.omega)
        if np.count_nonzero((meas.omega >= lo) & (meas.omega <= hi)) >= 8:
            out.append((float(lo), float(hi)))
    return out or [(float(meas.omega[0]), float(meas.omega[-1]))]


def _resonance_plant(meas: Measurement, res, R0):
    """A plant guess from the peak alone: height R0 + φ̄²/(2ζω0), width ≈ 2ζω0."""
    w0 = res.omega
    zeta = max((res.omega_hi - res.omega_lo) / (3.0 * w0), 1e-4)
    Zpk = float(np.abs(meas.Z[res.index]))
    phi2 = max(Zpk - R0, 1e-3 * R0) * 2 * zeta * w0
    return np.array([zeta, w0, np.sqrt(phi2), R0, 1e-3 * R0 / w0])


def initial_estimate(meas: Measurement, model: Model, *, band: tuple[float, float] | None = None,
                     seed: int = 0) -> InitialEstimate:
    """Automatic initial estimate of ``model``'s parameters from ``meas`` (SPEC §3.1).

    Parameters
    ----------
    meas : the measurement (admittance, rad/s).
    model : one of the registry models (I, II, III, UD, NL, UL).
    band : (omega_min, omega_max) [rad/s] for the plant linearisation; default: candidate bands
        around the resonance (the best by the full-band residual wins).
    seed : seeds the multi-start fallback.
    """
    bands = [band] if band is not None else resonance_bands(meas)
    candidates, errors = [], []
    for b in bands:
        sub = meas.select(*b)
        try:
            candidates.append((f"levy {b[0]:.4g}-{b[1]:.4g} rad/s", b, levy_plant(sub.omega, sub.Y)))
        except FitError as exc:
            errors.append(f"{b[0]:.4g}-{b[1]:.4g} rad/s: {exc}")
    res = locate_resonance(meas)
    if not candidates and res is not None:
        # fallback: the peak's height and width, then a multi-start around it
        R0 = float(np.min(meas.Z.real[meas.Z.real > 0], initial=np.abs(meas.Z).min()))
        base = _resonance_plant(meas, res, R0)
        rng = np.random.default_rng(seed)
        candidates.append(("resonance peak", bands[0], base))
        for _ in range(6):
            candidates.append(("multi-start", bands[0], base * np.exp(0.3 * rng.standard_normal(5))))
    best = None
    for path, b, plant in candidates:
        try:
            theta = _coil_to_theta(model, plant, coil_estimate(meas, model, plant))
        except (FitError, KeyError, ValueError, FloatingPointError) as exc:
            errors.append(f"{path}: {exc}")
            continue
        err = _rms_rel(model, meas, theta)
        if np.isfinite(err) and (best is None or err < best[0]):
            best = (err, path, b, theta)
    if best is None:
        raise FitError(f"{meas.source}: no initial estimate for model {model.label} "
                       f"({'; '.join(errors) or 'no resonance found'})")
    err, path, b, theta = best
    return InitialEstimate(theta, b, err, path, {"rejected": errors, "candidates": len(candidates)})
