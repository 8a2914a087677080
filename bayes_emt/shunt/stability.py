"""Closed-loop stability of an RC-shunted transducer: threshold in Rs, poles, pole count.

With the shunt ``Zs = Rs + 1/(Cs s)`` closing the terminals, the closed-loop poles are the zeros of

    H(s) = Cs s · [ mech(s) (Ze(s) + Zs(s)) + φ̄² s ] = mech(s) (Cs s (Ze(s) + Rs) + 1) + φ̄² Cs s²

(``mech = s² + 2ζω0 s + ω0²``, ``Ze = Zc + R0``): the denominator of (50) cleared of ``1/(Cs s)``.
``H`` is analytic in the closed right half-plane for every model (a passive coil's ``Ze`` has its
poles at ``Re s < 0``; the Bessel models' are on the negative real axis). For a model with device
terms beyond the paper's (a capacitance across the terminals, another mode, creep, a port),
``Z`` below is the device's terminal impedance ``Z_t = 1/Y_device`` (:meth:`Model.impedance_s`) and
``H = mech (Cs s (Z_t + Rs) + 1)`` (:func:`characteristic_function`); ``Z_t`` is positive-real, so
the same arguments hold.

**Threshold in Rs (any model).** A pole lies on the imaginary axis at ``jω`` exactly when the total
loop impedance vanishes, ``Z(jω) + Rs + 1/(jω Cs) = 0`` with ``Z = Ze + φ̄² s/mech`` the terminal
impedance: where the loop reactance ``X(ω) = Im Z(jω) − 1/(ω Cs)`` is zero and ``Rs = −Re Z(jω)``.
A pole can also arrive from infinity, when ``Ze`` stays bounded (no series inductance: model II) and
``Rs = −Ze(j∞)``. The loop is stable for ``Rs → +∞`` (passive coil, ζ > 0) and its poles move
continuously with Rs, so coming down from +∞ stability is first lost at the largest of these
values: ``Rs_instability`` [Ω]. No rational approximation is involved, so it is exact for the
Bessel models too. (A pole that only touches the axis would make this conservative.)

**Poles.** For the paper's six models, the eigenvalues of a descriptor realisation built from the
Foster form (:mod:`bayes_emt.shunt.foster`; exact for I, II, NL, UL, within a stated bound for III,
UD), states: mass-normalised displacement and velocity, capacitor voltage, series current and
each section's inductor current. They give the margins ``max Re p`` [1/s] and the smallest damping
ratio ``min(−Re p/|p|)``.

**Pole count (any model).** The argument principle on the exact ``H(jω)``: with ``H ~ c sⁿ`` on the
large semicircle, the number of right-half-plane zeros is ``n/2 − Δarg_{0→∞} H(jω)/π``; the phase is
tracked on a log grid refined wherever it turns by more than π/4 between points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize

from ..models import Model
from .foster import BESSEL_SECTIONS, foster_realisation, has_foster_form

__all__ = ["instability_threshold", "threshold_grid", "closed_loop_poles", "count_unstable_poles",
           "StabilityReport", "assess_stability", "characteristic_function"]


def _one(theta) -> np.ndarray:
    theta = np.asarray(theta, float)
    if theta.ndim != 1:
        raise ValueError(f"expected one parameter vector, got shape {theta.shape}")
    return theta


def _mech(model: Model, theta):
    return tuple(float(v) for v in model.mechanics(theta))


def threshold_grid(model: Model, theta, *, decades=(5.0, 6.0), points: int = 4000):
    """``(omega [rad/s], Z(jω) [Ω])``: terminal impedance on ``ω0·10^-5 .. ω0·10^6`` (log) plus a
    dense patch over ``ω0 (1 ± (40ζ + 0.01))`` resolving the motional resonance, where loop-reactance
    zeros are sought. Pass it to :func:`instability_threshold` to reuse it for many ``Cs``."""
    theta = _one(theta)
    zeta, omega0, _ = _mech(model, theta)
    half = 40.0 * zeta + 0.01
    omega = np.union1d(np.geomspace(omega0 * 10.0 ** -decades[0], omega0 * 10.0 ** decades[1], points),
                       np.linspace(omega0 * (1 - min(half, 0.9)), omega0 * (1 + half), 1500))
    return omega, model.impedance_s(1j * omega, theta)


def _infinity_candidate(model: Model, theta, omega0: float) -> float:
    """``−Z_t(∞)`` when the terminal impedance stays bounded at high frequency, else −inf.

    With ``Z_t ≈ Z∞ + c/s`` (``c > 0``) for large ``s``, the loop ``Rs + 1/(Cs s) + Z_t`` has a root
    ``s ≈ −(1/Cs + c)/(Rs + Z∞)``, real and in the right half-plane once ``Rs < −Z∞``: a pole arrives
    from infinity. ``Z∞`` is a resistance for a coil without series inductance (model II) and 0 when a
    capacitance across the terminals takes over (any negative Rs is then unstable in the ideal loop,
    at ``s ≈ 1/(|Rs| Cp)``; see ``bandwidth`` in :func:`instability_threshold`)."""
    if has_foster_form(model):
        f = foster_realisation(model, theta)
        return -(f.R0 + float(np.sum(f.R))) if f.G <= 0 else -np.inf
    z = model.impedance_s(1j * omega0 * np.array([1e8, 1e10]), theta)
    if abs(z[1] - z[0]) <= 1e-6 * abs(z[1]) and abs(z[1].imag) <= 1e-6 * abs(z[1]):
        return -float(z[1].real)
    if abs(z[1]) <= 0.02 * abs(z[0]):  # decays like 1/s (or faster): Z∞ = 0
        return 0.0
    return -np.inf


#: the last few ``_infinity_candidate`` values by (model, θ): an optimiser asks for the threshold at
#: thousands of ``Cs`` on one parameter vector, and the candidate does not depend on ``Cs``
_INF_CACHE: dict = {}


def _infinity_candidate_cached(model: Model, theta) -> float:
    key = (id(model), theta.tobytes())
    hit = _INF_CACHE.get(key)
    if hit is not None and hit[0] is model:
        return hit[1]
    v = _infinity_candidate(model, theta, float(model.mechanics(theta)[1]))
    if len(_INF_CACHE) >= 16:
        _INF_CACHE.pop(next(iter(_INF_CACHE)))
    _INF_CACHE[key] = (model, v)
    return v


def instability_threshold(model: Model, theta, Cs: float, *, grid=None, refine: bool = True,
                          bandwidth: float | None = None):
    """The Rs [Ω] below which the RC-shunted loop is unstable (module docstring).

    Parameters
    ----------
    model : transducer model (any, including augmented ones).
    theta : parameter vector ``(k,)`` or a stack ``(..., k)`` (looped; returns an array ``(...)``).
    Cs : shunt capacitance [F].
    grid : a :func:`threshold_grid` result for this ``theta`` (one vector only), to reuse.
    refine : polish each candidate crossing with Brent's method on the exact model (else linear
        interpolation on the grid, ~1e-6 Ω; what the optimiser uses).
    bandwidth : [rad/s] the shunt realisation's bandwidth: crossings above it and poles arriving from
        infinity are left out (a synthetic impedance has no gain there). ``None``: the ideal loop.
    """
    theta = np.asarray(theta, float)
    if theta.ndim > 1:
        flat = theta.reshape(-1, theta.shape[-1])
        out = [instability_threshold(model, t, Cs, refine=refine, bandwidth=bandwidth) for t in flat]
        return np.array(out).reshape(theta.shape[:-1])
    if not (Cs > 0 and math.isfinite(Cs)):
        raise ValueError(f"Cs must be a positive capacitance [F], got {Cs!r}")
    omega, Z = grid if grid is not None else threshold_grid(model, theta)
    X = Z.imag - 1.0 / (omega * Cs)
    idx = np.flatnonzero(np.sign(X[:-1]) != np.sign(X[1:]))
    if bandwidth is not None:
        idx = idx[omega[idx] <= bandwidth]
    f = X[idx] / (X[idx] - X[idx + 1])
    cand = -(Z[idx].real + f * (Z[idx + 1].real - Z[idx].real))
    if refine and idx.size:
        def x_exact(w):
            return float(model.impedance_s(np.array([1j * w]), theta)[0].imag - 1.0 / (w * Cs))

        # only the leading candidates can be the maximum
        top = np.argsort(cand)[::-1][:3]
        for j in top:
            i = idx[j]
            wc = optimize.brentq(x_exact, omega[i], omega[i + 1], xtol=1e-15 * omega[i], rtol=1e-15)
            cand[j] = -float(model.impedance_s(np.array([1j * wc]), theta)[0].real)
    best = float(np.max(cand)) if cand.size else -np.inf
    if bandwidth is not None:
        return best
    return max(best, _infinity_candidate_cached(model, theta))


def characteristic_function(model: Model, theta, Rs: float, Cs: float, omega):
    """``H(jω)`` (module docstring), ``omega`` [rad/s]: ``mech (Cs s (Z_t + Rs) + 1)`` with ``Z_t`` the
    device's terminal impedance, written without the motional branch's poles,
    ``mech Z_t = (φ̄² s + mech Ze) mech/(mech + Yp (φ̄² s + mech Ze))`` (``= φ̄² s + mech Ze`` when
    nothing sits across the terminals: the paper's ``mech (Cs s (Ze + Rs) + 1) + φ̄² Cs s²``)."""
    s = 1j * np.asarray(omega, float)
    lp = model.loop(s, theta)
    mech, ze, yp = lp.mech, lp.z_series, lp.y_parallel
    num = float(lp.phi) ** 2 * s + mech * ze
    mz = num if not np.any(yp) else num * mech / (mech + yp * num)
    return Cs * s * (mz + mech * Rs) + mech


def count_unstable_poles(model: Model, theta, Rs: float, Cs: float, *, max_points: int = 400_000) -> int:
    """Closed-loop poles with ``Re p > 0`` by the argument principle on the exact model (any model).

    Raises
    ------
    ArithmeticError
        When a pole is (numerically) on the imaginary axis or the count does not come out an integer.
    """
    theta = _one(theta)
    _, omega0, _ = _mech(model, theta)
    w = np.union1d(np.geomspace(omega0 * 1e-6, omega0 * 1e10, 3200),
                   np.linspace(0.3 * omega0, 3.0 * omega0, 800))
    h = characteristic_function(model, theta, Rs, Cs, w)
    for _ in range(80):
        d = np.angle(h[1:] / h[:-1])
        bad = np.flatnonzero(np.abs(d) > np.pi / 4)
        if bad.size == 0:
            break
        if w.size + 8 * bad.size > max_points:
            raise ArithmeticError(f"model {model.label}, Rs = {Rs:.6g}: a closed-loop pole is too close "
                                  "to the imaginary axis to count (marginally stable)")
        new = np.concatenate([np.geomspace(w[i], w[i + 1], 10)[1:-1] for i in bad])
        w_all = np.concatenate([w, new])
        h_all = np.concatenate([h, characteristic_function(model, theta, Rs, Cs, new)])
        order = np.argsort(w_all)
        w, h = w_all[order], h_all[order]
    else:
        raise ArithmeticError(f"model {model.label}: the phase of H(jω) could not be resolved")
    darg = float(np.sum(np.angle(h[1:] / h[:-1]))) + float(np.angle(h[0] / omega0**2))
    n = math.log(abs(h[-1]) / abs(h[-2])) / math.log(w[-1] / w[-2])
    count = n / 2 - darg / np.pi
    if abs(count - round(count)) > 0.1:
        raise ArithmeticError(f"model {model.label}: argument-principle count {count:.3f} is not an integer "
                              f"(high-frequency slope {n:.3f})")
    return int(round(count))


def closed_loop_poles(model: Model, theta, Rs: float, Cs: float, *, sections: int = BESSEL_SECTIONS):
    """Closed-loop poles [1/s] of the RC-shunted system from the Foster realisation.

    Exact for I, II, NL, UL; for III/UD from ``sections`` eddy-current modes (error bound in
    :mod:`bayes_emt.shunt.foster`). Descriptor form ``E x' = A x`` with ``x = (x̄, v̄, v_C, i, j_1..j_n)``:
    ``x̄' = v̄``; ``v̄' = −ω0² x̄ − 2ζω0 v̄ + φ̄ i``; ``Cs v_C' = i``;
    ``G i' = −φ̄ v̄ − v_C − (R0 + Rs + ΣR_k) i + Σ R_k j_k``; ``L_k j_k' = R_k (i − j_k)``.
    """
    theta = _one(theta)
    zeta, omega0, phi = _mech(model, theta)
    f = foster_realisation(model, theta, sections=sections)
    n = f.L.size
    Rk = f.R
    A = np.zeros((4 + n, 4 + n))
    A[0, 1] = 1.0
    A[1, :4] = [-(omega0**2), -2 * zeta * omega0, 0.0, phi]
    A[2, 3] = 1.0
    A[3, :4] = [0.0, -phi, -1.0, -(f.R0 + Rs + Rk.sum())]
    A[3, 4:] = Rk
    A[4:, 3] = Rk
    A[4:, 4:] = np.diag(-Rk)
    e = np.r_[1.0, 1.0, Cs, f.G, f.L]
    if f.G > 0:
        return np.linalg.eigvals(A / e[:, None])
    p = linalg.eigvals(A, np.diag(e))
    return p[np.isfinite(p)]


@dataclass(frozen=True)
class StabilityReport:
    """Stability of one RC-shunted loop.

    Attributes
    ----------
    stable : all closed-loop poles in the open left half-plane.
    n_unstable : number of poles with ``Re p > 0``.
    max_pole_real : ``max Re p`` [1/s] (None when the model has no Foster form).
    min_damping_ratio : ``min(−Re p/|p|)`` over the poles (None likewise).
    method : how ``stable`` was decided.
    """

    stable: bool
    n_unstable: int
    max_pole_real: float | None
    min_damping_ratio: float | None
    method: str


def assess_stability(model: Model, theta, Rs: float, Cs: float) -> StabilityReport:
    """Stable or not, and the pole margins (module docstring).

    Exact-Foster models (I, II, NL, UL): decided by the eigenvalues. Bessel models (III, UD) and any
    other model: decided by the argument principle on the exact impedance; III/UD also get
    their margins from the Foster approximation's eigenvalues.
    """
    theta = _one(theta)
    if has_foster_form(model):
        p = closed_loop_poles(model, theta, Rs, Cs)
        maxre = float(np.max(p.real))
        damp = float(np.min(-p.real / np.abs(p)))
        if foster_realisation(model, theta).exact:
            n_un = int(np.count_nonzero(p.real > 0))
            return StabilityReport(n_un == 0, n_un, maxre, damp, "eigenvalues of the exact realisation")
        n_un = count_unstable_poles(model, theta, Rs, Cs)
        return StabilityReport(n_un == 0, n_un, maxre, damp,
                               "argument principle on the exact model; poles from "
                               f"{BESSEL_SECTIONS} eddy-current modes")
    n_un = count_unstable_poles(model, theta, Rs, Cs)
    return StabilityReport(n_un == 0, n_un, None, None, "argument principle on the exact model")
