"""Automatic initial estimate (Levy 1959; Sanathanan & Koerner 1963): no user guess, from the data alone.

Two linear least-squares stages, then a check:

1. **Plant near the resonance (Levy / Sanathanan–Koerner).** Over a band around the resonance
   (found with :func:`bayes_emt.estimation.checks.locate_resonance`; the paper used 10–300 rad/s around
   ω0 ≈ 50 rad/s, i.e. 0.2–6 ω0) every coil looks like ``R0 + L s`` to first order (little eddy
   current, the paper's "small α"), and the admittance (47) is the rational function

       Y = (s² + a s + b) / (d3 s³ + d2 s² + d1 s + d0),   a = 2ζω0, b = ω0², c = φ̄²,
       d3 = L, d2 = R0 + L a, d1 = R0 a + L b + c, d0 = R0 b.

   ``num − den·Y = 0`` is linear in the redundant vector ``(a, b, d0..d3)``; weighted by
   ``W = 1/(jω)`` it is one real least-squares problem (columns scaled, real and imaginary parts
   stacked), then mapped back: ``ω0 = √b, ζ = a/(2ω0), R0 = d0/b, L = d3, φ̄² = d1 − R0 a − L b``.
   A few Sanathanan–Koerner re-weightings by ``1/|den|`` remove Levy's bias.

2. **Coil over the whole band (the high-frequency parameters).** With the motional term
   removed, the electrical impedance ``Ze = R0 + Zc(jω)`` is linear in ``R0`` and the coil's
   scale parameters once one nonlinear parameter is fixed: I in ``(R0, L0)``; II in
   ``(R0, L0)`` at fixed ``τ = L0/Rμ`` (and, the paper's way, ``1/Zc`` is linear in
   ``(1/L0, 1/Rμ)`` with the Levy ``R0``); III, UD, UL and NL in ``(R0, β, Lg)`` at fixed ``α``
   (the Bessel term and the UL rings both scale with ``β`` at fixed ``α``). ``R0`` is refitted
   here because on a lossy coil the Levy ``R0`` also carries the eddy-current resistance at the
   resonance. Values of ``α`` (or ``τ``) come from the paper's first-order rational Bessel
   approximation (:func:`~bayes_emt.models.terms.bessel_eddy_rational`, linear in
   ``(α, c2, c1, R0)``) and from a scan over decades whose distinct local minima all become
   candidates (non-negative linear least squares at every grid point). NL starts from the
   uniform-core (UL) estimate through the UL formulas.

Candidates: every band's plant, plus one from the resonance peak's height and width, each with
every coil estimate. Each is validated (finite, positive, moved strictly inside the prior
support) and scored by the rms relative residual ``sqrt(mean |Y_model − Y|²/|Y|²)`` over all
data. If the best is poor (above :data:`POOR_RMS`) or puts the resonance away from the located
peak, a cheap global stage runs: perturbations of the best candidates in sampling space, scored
in one vectorised model call. The path taken and the distinct runners-up (extra starts for
:func:`bayes_emt.estimation.fitting.fit_admittance`) are returned in :class:`InitialEstimate`.
"""

from __future__ import annotations

import contextlib
import contextvars
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize

from ..errors import FitError
from ..measurement import Measurement
from ..models import Model
from ..models import terms as T
from ..models.linearise import lstsq_real, stacked_real
from .augment import augmentation_starts, rms_rel_residual, validated
from .checks import locate_resonance

__all__ = ["InitialEstimate", "initial_estimate", "find_initial_estimate", "levy_plant",
           "coil_estimate", "resonance_bands", "POOR_RMS"]

#: rms relative residual above which the linearised estimate counts as poor (global stage runs)
POOR_RMS = 0.2
# plant-linearisation bands as multiples of the resonance: the paper's 10–300 rad/s around 50 rad/s
# first, then narrower ones where the coil is closer to R0 + L s
_BANDS = ((0.2, 6.0), (0.4, 2.5), (0.6, 1.6))
_N_STARTS = 3  # best estimate plus runners-up handed to the fit
_N_PERTURB = 48  # global stage: perturbations per base candidate
_PERTURB_SD = 0.4  # their spread in sampling space (log units for positive parameters)
_SCAN_POINTS = 400  # frequencies used by the coil stage's alpha scans


@dataclass(frozen=True)
class InitialEstimate:
    """The automatic initial estimate and how it was found.

    Attributes
    ----------
    theta : (k,) physical parameter values [SI], ``model.names`` order.
    band : (omega_min, omega_max) [rad/s] of the plant linearisation that won.
    rms_rel_residual : ``sqrt(mean |Y(theta) − Y|²/|Y|²)`` over all data.
    path : how it was found, e.g. ``"levy 10.2-305 rad/s + scan alpha"``.
    alternatives : runners-up (physical vectors), best first, for multi-start fits.
    details : rejected candidates and counts (JSON-serialisable).
    """

    theta: np.ndarray
    band: tuple[float, float]
    rms_rel_residual: float
    path: str
    alternatives: tuple = ()
    details: dict = field(default_factory=dict)


def levy_plant(omega, Y, *, sk_iterations: int = 3) -> np.ndarray:
    """Levy linearisation of model I over a band: ``(zeta, omega0, phi, R0, L)`` [SI].

    Solves ``min Σ |num(jω) − den(jω) Y(jω)|² |W|²`` (module docstring) with the paper's
    ``W = 1/(jω)`` first, then ``sk_iterations`` Sanathanan–Koerner re-weightings by
    ``1/|den(jω)|``. ``omega`` [rad/s], ``Y`` [S]. Raises :class:`FitError` if the mapped values
    are not physical (non-positive or non-finite).
    """
    s = 1j * np.asarray(omega, float)
    Y = np.asarray(Y, complex)
    # unknowns x = (a, b, d0, d1, d2, d3):  a s + b − Y (d0 + d1 s + d2 s² + d3 s³) = −s²
    A = np.column_stack([s, np.ones_like(s), -Y, -Y * s, -Y * s**2, -Y * s**3])
    w = 1.0 / np.abs(s)
    for _ in range(1 + sk_iterations):
        x = lstsq_real(A, -(s**2), w)
        den = x[2] + x[3] * s + x[4] * s**2 + x[5] * s**3
        if not np.all(np.isfinite(den)) or np.any(den == 0):
            break
        w = 1.0 / np.abs(den)
    a, b, d0, d1, d2, d3 = x
    if not (b > 0 and a > 0):
        raise FitError(f"Levy estimate not physical (a={a:.3g}, b={b:.3g})")
    omega0 = np.sqrt(b)
    R0 = d0 / b
    L = max(d3, 0.0)
    c = d1 - R0 * a - L * b
    if not (R0 > 0 and c > 0 and np.isfinite(c)):
        raise FitError(f"Levy estimate not physical (R0={R0:.3g}, phi²={c:.3g})")
    return np.array([a / (2 * omega0), omega0, np.sqrt(c), R0, L])


# ------------------------------------------------------------------------------------------------
# stage 2: the coil from the blocked impedance
# ------------------------------------------------------------------------------------------------


def _nonneg_fit(cols, target, w):
    """``min ||w (cols x − target)||`` over real ``x ≥ 0`` for complex ``cols (F, c)``, ``target
    (F,)`` (columns scaled, real and imaginary parts stacked). Returns ``(x, weighted rms)``."""
    As, br, scale = stacked_real(cols, target, w)
    x, _ = optimize.nnls(As, br)
    x = x / scale
    return x, float(np.sqrt(np.mean(np.abs((cols @ x - target) * w) ** 2)))


def _profile(basis, s, Ze, w, grid, R0_fixed, lin_cols):
    """For each ``p`` in ``grid`` (``basis`` its unit coil, ``(A, F)``): ``Ze ≈ R0 + c E(p) + Σ l_i
    col_i`` with ``R0, c, l ≥ 0`` (``R0`` a further unknown unless ``R0_fixed``). Returns ``errs
    (A,)`` and ``coefs (A, 2 + n_lin)`` as ``(R0, c, l...)``; ``c = 0`` scores ``inf``."""
    n_lin = 0 if lin_cols is None else lin_cols.shape[1]
    target = Ze if R0_fixed is None else Ze - R0_fixed
    errs = np.full(len(grid), np.inf)
    coefs = np.zeros((len(grid), 2 + n_lin))
    for i, e in enumerate(basis):
        cols = [e[:, None]] + ([lin_cols] if n_lin else [])
        cols = np.hstack(cols + ([np.ones((s.size, 1))] if R0_fixed is None else []))
        if not np.all(np.isfinite(cols)):
            continue
        x, err = _nonneg_fit(cols, target, w)
        if x[0] > 0:
            errs[i] = err
            coefs[i] = (x[-1] if R0_fixed is None else R0_fixed, x[0], *x[1 : 1 + n_lin])
    return errs, coefs


def _local_minima(errs, n: int):
    """Indices of the ``n`` lowest local minima of a profile (ends included), best first."""
    e = np.concatenate([[np.inf], errs, [np.inf]])
    idx = np.flatnonzero((e[1:-1] <= e[:-2]) & (e[1:-1] <= e[2:]) & np.isfinite(e[1:-1]))
    return idx[np.argsort(errs[idx], kind="stable")][:n]


def _coil_plan(model: Model):
    """``(scan, linear)`` from the model's coil terms (their :class:`CoilStart`): the one term
    with a nonlinear scan parameter (or ``None``) and ``[(name, column, fallback)]`` for every
    parameter that is itself a linear coefficient. Raises :class:`FitError` when the coil
    cannot be linearised (a coil term without a start, or two scan parameters)."""
    scan, linear = None, []
    for t in model.terms:
        if not t.coil or t.augmentation:
            continue
        cs = t.coil_start()
        if cs is None:
            raise FitError(f"model {model.label}: coil term {t.id} has no linear start; give a start")
        if cs.scan is not None:
            if scan is not None:
                raise FitError(f"model {model.label}: two coil terms with nonlinear parameters "
                               f"({scan.scan}, {cs.scan}); give a start")
            scan = cs
        fb = cs.fallback or {}
        for name, fn in {**(cs.linear or {}), **(cs.linear_with_basis or {})}.items():
            linear.append((name, fn, fb.get(name)))
    return scan, linear


def _coil_candidates(meas: Measurement, model: Model, plant, cache=None) -> list[tuple[str, dict]]:
    """Coil (and ``R0``) candidates ``[(method, {name: value})]`` from the electrical impedance
    ``Ze = Z − φ̄² s/(s² + 2ζω0 s + ω0²) = R0 + Zc`` with the plant's mechanics removed, driven by
    the coil terms' starts (:func:`_coil_plan`). ``cache`` (a dict) keeps the unit-coil scan basis
    between calls on the same data."""
    zeta, omega0, phi, R0_levy, L_lf = plant
    if meas.n_points > _SCAN_POINTS:
        # a log-even subset is plenty for a start and keeps the scans cheap
        idx = np.unique(np.searchsorted(meas.omega, np.geomspace(meas.omega[0], meas.omega[-1],
                                                                  _SCAN_POINTS)).clip(0, meas.n_points - 1))
        meas = replace(meas, omega=meas.omega[idx], Y=meas.Y[idx],
                       weights=None if meas.weights is None else meas.weights[idx])
    omega = meas.omega
    s = 1j * omega
    Ze = meas.Z - T.motional_impedance(s, zeta, omega0, phi)
    # errors in Ze count relative to the measured |Z|, as in the fit's objective
    w = 1.0 / np.abs(meas.Z)
    L_lf = max(L_lf, 1e-12)
    scan, linear = _coil_plan(model)
    lin_cols = np.column_stack([fn(s) for _, fn, _ in linear]) if linear else None

    def coil_values(R0, lin):
        coil = {"R0": R0 if R0 > 0 else R0_levy}
        for (name, _, fallback), c in zip(linear, lin, strict=True):
            coil[name] = c if c > 0 or fallback is None else fallback(L_lf)
        return coil

    if scan is None:
        cols = np.hstack(([lin_cols] if linear else []) + [np.ones((s.size, 1))])
        x, _ = _nonneg_fit(cols, Ze, w)
        return [("linear R0" + "".join(f", {n}" for n, _, _ in linear), coil_values(x[-1], x[:-1]))]
    out = []
    if scan.direct is not None:
        out += scan.direct(s, Ze, w, R0_levy, L_lf)
    p_lo, p_hi = scan.scan_range
    # p·ω spans 1e-4..1e4 over the data: the eddy current from negligible to fully developed
    grid = np.geomspace(max(1e-4 / omega[-1], p_lo), min(1e4 / omega[0], p_hi), 97)
    step = grid[1] / grid[0]
    found = []
    if scan.seeds is not None:
        for label, p0 in scan.seeds(s, Ze, w, bool(linear)):
            if p_lo < p0 < p_hi:
                found.append((label, p0, None))
    cache = {} if cache is None else cache
    if "basis" not in cache:  # independent of the plant: one evaluation serves every band
        cache["basis"] = scan.basis(s, grid)
    for R0_fixed, label in ((None, "R0 free"), (R0_levy, "Levy R0")):
        errs, _ = _profile(cache["basis"], s, Ze, w, grid, R0_fixed, lin_cols)
        # distinct basins of the profile become distinct candidates (real coils have several)
        for i in _local_minima(errs, 2 if R0_fixed is None else 1):
            found.append((f"scan {scan.scan} ({label})", grid[i], R0_fixed))
    for method, p0, R0_fixed in found:
        fine = p0 * np.geomspace(1 / step, step, 21) if method.startswith("scan") else np.array([p0])
        errs, coefs = _profile(scan.basis(s, fine), s, Ze, w, fine, R0_fixed, lin_cols)
        if not np.isfinite(errs).any():
            continue
        i = int(np.argmin(errs))
        coil = coil_values(coefs[i, 0], coefs[i, 2:])
        coil.update(scan.to_params(float(fine[i]), float(coefs[i, 1])))
        out.append((method, coil))
    return out


#: the coil candidates computed within :func:`shared_coil_candidates`, by data, model and plant
_SHARED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("shared_coil_candidates", default=None)


@contextlib.contextmanager
def shared_coil_candidates():
    """Within the block, :func:`_coil_candidates` of the same data, model and plant is computed once
    (it is a function of those alone): NL's start estimates its UL surrogate's coil from the same
    plants as the UL fit's own start did just before (:func:`~.fitting.fit_admittance`)."""
    token = _SHARED.set({} if _SHARED.get() is None else _SHARED.get())
    try:
        yield
    finally:
        _SHARED.reset(token)


def _coil_candidates_shared(meas: Measurement, model: Model, plant, cache) -> list[tuple[str, dict]]:
    """:func:`_coil_candidates`, taken from :func:`shared_coil_candidates`' record when it holds it."""
    memo = _SHARED.get()
    if memo is None:
        return _coil_candidates(meas, model, plant, cache)
    key = (model.label, repr(model.params.to_dict()), np.asarray(plant, float).tobytes(),
           np.asarray(meas.omega, float).tobytes(), np.asarray(meas.Y, complex).tobytes(),
           None if meas.weights is None else np.asarray(meas.weights, float).tobytes())
    if key not in memo:
        memo[key] = _coil_candidates(meas, model, plant, cache)
    return [(method, dict(coil)) for method, coil in memo[key]]


def _surrogate_model(model: Model):
    """``(model to estimate, convert)``: terms with a coarser surrogate replaced by it (NL's ring
    ladder by uniform rings), and ``convert(theta_est) -> theta`` mapping back."""
    est, conv = model, []
    for t in model.terms:
        sur = t.surrogate()
        if sur is not None:
            est = est.replace_term(next(x for x in est.terms if x is t), sur[0])
            conv.append((t, sur[0], sur[1]))
    if not conv:
        return model, lambda theta: theta

    def convert(theta):
        vals = est.as_dict(theta)
        for _, s, fn in conv:
            for n in s.names:
                del vals[n]
            vals.update(fn(est.as_dict(theta)))
        return model.vector(vals)

    return est, convert


def coil_estimate(meas: Measurement, model: Model, plant) -> dict[str, float]:
    """Coil parameters (and a refitted ``R0`` [ohm]) of ``model`` given ``plant`` =
    ``(zeta, omega0, phi, R0, L)`` [SI] (stage 2 of the module docstring): the candidate with the
    smallest rms relative residual of the full model. For a model with a surrogate (NL) the values
    are the surrogate's (NL: ``{"R0", "Lg", "alpha", "beta"}`` of the uniform-ring start). Raises
    :class:`FitError` if there is none."""
    est, _ = _surrogate_model(model.base_model())
    cands = _coil_candidates(meas, est, plant)
    if not cands:
        raise FitError(f"no physical coil estimate for model {model.label}")
    thetas = [_to_theta(est, plant, c) for _, c in cands]
    errs = [rms_rel_residual(est, meas, t[None, :])[0] for t in thetas]
    return cands[int(np.nanargmin(errs))][1]


def _to_theta(model: Model, plant, coil: dict) -> np.ndarray:
    vals = {"zeta": plant[0], "omega0": plant[1], "phi": plant[2], "R0": coil.get("R0", plant[3])}
    vals.update({k: v for k, v in coil.items() if k in model.names})
    return model.vector(vals)


# ------------------------------------------------------------------------------------------------
# candidates, global stage, entry points
# ------------------------------------------------------------------------------------------------


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


def _peak_plant(meas: Measurement):
    """A plant from the impedance peak alone: height ``R0 + φ̄²/(2ζω0)``, half-height width
    ≈ ``2ζω0``; with no peak, a weak resonance just below the band (the fit decides)."""
    R0 = float(np.min(meas.Z.real[meas.Z.real > 0], initial=np.abs(meas.Z).min()))
    res = locate_resonance(meas)
    if res is None:
        w0, zeta = 0.5 * meas.omega[0], 0.1
        phi2 = 0.01 * R0 * w0
    else:
        w0 = res.omega
        zeta = max((res.omega_hi - res.omega_lo) / (3.0 * w0), 1e-4)
        phi2 = max(float(np.abs(meas.Z[res.index])) - R0, 1e-3 * R0) * 2 * zeta * w0
    return np.array([zeta, w0, np.sqrt(phi2), R0, 1e-3 * R0 / w0])


def _candidates(meas, model, plants, errors, cache):
    est, convert = _surrogate_model(model)
    out = []
    for path, band, plant in plants:
        try:
            coils = _coil_candidates_shared(meas, est, plant, cache)
        except (FitError, FloatingPointError, np.linalg.LinAlgError) as exc:
            errors.append(f"{path}: {exc}")
            continue
        for method, coil in coils:
            with np.errstate(all="ignore"):
                theta = validated(model, convert(_to_theta(est, plant, coil)))
            if theta is None:
                errors.append(f"{path} + {method}: not finite or not positive")
            else:
                out.append((f"{path} + {method}", band, theta))
    return out


def _consistent(meas: Measurement, model: Model, theta) -> bool:
    """Whether ``theta`` puts an under-damped resonance within a factor 1.5 of the located peak
    (True when there is no peak to compare with)."""
    res = locate_resonance(meas)
    if res is None:
        return True
    zeta, omega0, _ = model.mechanics(theta)
    return bool(zeta < 1 and res.omega / 1.5 < omega0 < 1.5 * res.omega)


def _global_stage(meas, model, bases, rng):
    """Perturb each base in sampling space and score all in one vectorised call."""
    out = []
    zs = []
    for path, band, theta in bases:
        z0 = model.params.to_z(theta)
        z = z0 + _PERTURB_SD * rng.standard_normal((_N_PERTURB, z0.size))
        zs.append(model.params.clip_inside(z))
        out += [(f"global stage around ({path})", band)] * _N_PERTURB
    thetas = model.params.from_z(np.concatenate(zs))
    return [(p, b, t) for (p, b), t in zip(out, thetas, strict=True)]


def find_initial_estimate(meas: Measurement, model: Model, *, band: tuple[float, float] | None = None,
                          seed: int = 0) -> InitialEstimate:
    """Automatic initial estimate of ``model``'s parameters from ``meas``, with its
    provenance.

    Parameters
    ----------
    meas : the measurement (angular frequency [rad/s], admittance [S]).
    model : any model; an augmented one gets its base estimate plus each augmentation's own best
        start (:func:`~bayes_emt.estimation.augment.augmentation_starts`).
    band : (omega_min, omega_max) [rad/s] for the plant linearisation; default: bands of
        0.2–6, 0.4–2.5 and 0.6–1.6 times the resonance, clipped to the data.
    seed : seeds the global stage (only used when the linearised estimate is poor).

    Raises
    ------
    FitError : no physical estimate at all.
    """
    model = model.bind(meas.omega)
    ie = _base_estimate(meas, model.base_model(), band, seed)
    if not model.augmentations:
        return ie
    current, theta, path = model.base_model(), ie.theta, ie.path
    for term in model.augmentations:
        current, starts = augmentation_starts(meas, current, theta, term)
        theta = starts[0]
        path += f" + {term.id} start"
    theta = model.vector(current.as_dict(theta))
    rms = float(rms_rel_residual(model, meas, theta[None, :])[0])
    return replace(ie, theta=theta, path=path, rms_rel_residual=rms, alternatives=())


def _base_estimate(meas: Measurement, model: Model, band, seed) -> InitialEstimate:
    """:func:`find_initial_estimate` of a model without augmentations."""
    bands = [tuple(map(float, band))] if band is not None else resonance_bands(meas)
    full = (float(meas.omega[0]), float(meas.omega[-1]))
    plants, errors = [], []
    for b in bands:
        sub = meas.select(*b)
        try:
            plants.append((f"levy {b[0]:.4g}-{b[1]:.4g} rad/s", b, levy_plant(sub.omega, sub.Y)))
        except (FitError, np.linalg.LinAlgError) as exc:
            errors.append(f"{b[0]:.4g}-{b[1]:.4g} rad/s: {exc}")
    # the peak's height and width always compete: cheap, and right when a band misses the peak
    plants.append(("resonance peak", full, _peak_plant(meas)))
    cache: dict = {}
    cands = _candidates(meas, model, plants, errors, cache)
    errs = rms_rel_residual(model, meas, np.array([c[2] for c in cands])) if cands else np.zeros(0)
    n_linear = len(cands)
    if not cands or np.min(errs) > POOR_RMS or not _consistent(meas, model, cands[int(np.argmin(errs))][2]):
        order = np.argsort(errs, kind="stable")[:_N_STARTS]
        cands += _global_stage(meas, model, [cands[i] for i in order], np.random.default_rng(seed))
        errs = rms_rel_residual(model, meas, np.array([c[2] for c in cands])) if cands else np.zeros(0)
    if not cands or not np.isfinite(np.min(errs)):
        raise FitError(f"{meas.source}: no initial estimate for model {model.label} "
                       f"({'; '.join(errors) or 'no finite candidate'})")
    order = np.argsort(errs, kind="stable")
    picked = []
    for i in order:
        if not np.isfinite(errs[i]) or len(picked) == _N_STARTS:
            break
        z = model.params.to_z(cands[i][2])
        # distinct starts only: candidates that differ by less than 1e-3 in z lead to one fit
        if all(np.max(np.abs(z - model.params.to_z(cands[j][2]))) > 1e-3 for j in picked):
            picked.append(int(i))
    best = picked[0]
    path, b, theta = cands[best]
    return InitialEstimate(
        theta=np.array(theta, float), band=b, rms_rel_residual=float(errs[best]), path=path,
        alternatives=tuple(np.array(cands[j][2], float) for j in picked[1:]),
        details={"rejected": errors, "linearised_candidates": n_linear, "candidates": len(cands),
                 "global_stage": len(cands) > n_linear})


def initial_estimate(meas: Measurement, model: Model, *, band: tuple[float, float] | None = None,
                     seed: int = 0) -> np.ndarray:
    """Automatic initial estimate: physical ``theta`` [SI] in ``model.names`` order.

    See :func:`find_initial_estimate` for the parameters and for the provenance record.
    """
    return find_initial_estimate(meas, model, band=band, seed=seed).theta
