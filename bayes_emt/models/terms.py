"""Pure physics: impedance terms as vectorised functions of the Laplace variable ``s``.

Every function takes ``s`` (complex, any shape) and parameter arrays that broadcast against it,
SI units only, and returns a complex impedance [ohm] (or admittance [S] where said). No I/O,
no globals (bar one lazily built, read-only interpolation table). Equation numbers refer to the
source paper (see Physics and conventions).

Fast paths on the imaginary axis ``s = jω`` (what a likelihood evaluates, walkers × frequencies):

* :func:`bessel_ratio_jw` / :func:`bessel_eddy_jw`: ``I1(w)/I0(w)`` for ``w = sqrt(jαω)``, whose
  angle is fixed at 45°, from a cubic Hermite table in ``ln|w|`` (relative error < 1e-13 over
  ``1e-4 ≤ |w| ≤ 1e3``; exact series outside), tens of times faster than complex ``ive``/``jv``
  and finite where ``jv`` overflows. :func:`bessel_eddy` takes this path by itself when every
  ``s`` lies on the positive imaginary axis.
* Rational terms as polynomial pairs (``Z = num(s)/den(s)``, coefficients lowest power first,
  leading axes = parameter sets): :func:`inductance_polynomials`, :func:`lossy_inductance_polynomials`,
  :func:`motional_polynomials`, :func:`ladder_polynomials` (the NL ring ladder by a continued
  fraction, no eigen-decomposition), summed by :func:`add_rational` and evaluated at ``jω`` by
  real matrix products (:func:`jw_power_basis`, :func:`polynomial_jw`). All coefficients of these
  polynomials are positive for physical parameters, so evaluating them on the imaginary axis
  loses at most a factor ``Π (1 + x)/sqrt(1 + x²) ≤ 2^(d/2)`` (times ``1/(2ζ)`` across the
  mechanical resonance) over the rounding of a single term.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import special

__all__ = [
    "motional_impedance",
    "mechanical_polynomial",
    "inductance",
    "lossy_inductance",
    "bessel_eddy",
    "bessel_eddy_rational",
    "ring_ladder",
    "ring_ladder_modes",
    "uniform_rings",
    "bessel_ratio_jw",
    "bessel_eddy_jw",
    "table_position",
    "bessel_h_into",
    "resistance_polynomials",
    "inductance_polynomials",
    "lossy_inductance_polynomials",
    "motional_polynomials",
    "ladder_polynomials",
    "poly_mul",
    "add_rational",
    "jw_power_basis",
    "polynomial_jw",
]

# Above this |w| the ratio I1(w)/I0(w) is replaced by its asymptotic series (error < 1e-16).
_ASYMPTOTIC_W = 1e3


def mechanical_polynomial(s, zeta, omega0):
    """``s² + 2 ζ ω0 s + ω0²`` (the mass-normalised mechanical impedance times s)."""
    s = np.asarray(s)
    if np.iscomplexobj(s) and s.size and np.all(s.real == 0):  # s = jω: real and imaginary parts apart
        w = s.imag
        zeta, omega0 = np.asarray(zeta, float), np.asarray(omega0, float)
        re = omega0 * omega0 - w * w
        im = 2.0 * zeta * omega0 * w
        out = np.empty(np.broadcast_shapes(re.shape, im.shape), complex)
        out.real, out.imag = re, im
        return out
    return s * s + 2.0 * zeta * omega0 * s + omega0 * omega0


def motional_impedance(s, zeta, omega0, phi):
    """Motional impedance ``φ̄² s / (s² + 2ζω0 s + ω0²)`` [ohm] (the last term of eq. 47)."""
    return phi * phi * s / mechanical_polynomial(s, zeta, omega0)


def inductance(s, L):
    """``L s`` [ohm]: model I's coil (and the air-gap term ``Lg s`` of UD)."""
    return L * s


def lossy_inductance(s, L0, Rmu):
    """Model II: ``Rμ L0 s / (Rμ + L0 s)`` [ohm], eddy loss lumped as a resistor across ``L0``."""
    return Rmu * L0 * s / (Rmu + L0 * s)


def _i1_over_i0(w):
    """``I1(w)/I0(w)`` for complex ``w`` with ``Re w ≥ 0``, overflow-free.

    Exponentially scaled Bessel functions (``ive``) share the factor ``exp(-|Re w|)`` so their
    ratio is exact; for very large ``|w|`` the Hankel asymptotic series is used instead.
    """
    w = np.asarray(w, dtype=complex)
    out = np.empty_like(w)
    big = np.abs(w) > _ASYMPTOTIC_W
    small = ~big
    if np.any(small):
        ws = w[small]
        out[small] = special.ive(1, ws) / special.ive(0, ws)
    if np.any(big):
        x = 1.0 / w[big]
        # I1/I0 ~ 1 - 1/(2w) - 1/(8w²) - 1/(8w³) - 25/(128 w⁴) ...  (Abramowitz & Stegun 9.7.1)
        out[big] = 1.0 - x / 2 - x**2 / 8 - x**3 / 8 - 25 * x**4 / 128 - 13 * x**5 / 32
    return out


def bessel_eddy(s, alpha, beta):
    """Model III: ``-β sqrt(-s) J1(sqrt(-α s)) / J0(sqrt(-α s))`` [ohm].

    Rewritten with ``J_n(i w) = i^n I_n(w)``, ``w = sqrt(α s)``, as ``β sqrt(s) I1(w)/I0(w)``
    (identical on the principal branch, since the ratio is odd in its argument), which stays
    finite for any ``|α s|``: LF limit ``β sqrt(α) s / 2``, HF limit ``β sqrt(s)`` (45°).
    When every ``s`` is ``jω`` with ``ω > 0`` the table of :func:`bessel_eddy_jw` is used.
    """
    s = np.asarray(s, complex)
    if s.size and np.all(s.real == 0) and np.all(s.imag > 0):
        re, im = bessel_eddy_jw(s.imag, alpha, beta)
        out = np.empty(re.shape, complex)
        out.real, out.imag = re, im
        return out
    s, alpha, beta = np.broadcast_arrays(s, np.asarray(alpha, float), np.asarray(beta, float))
    rs = np.sqrt(s)
    w = np.sqrt(alpha) * rs
    return beta * rs * _i1_over_i0(w)


# ---- the Bessel ratio on the 45° ray (s = jω) ---------------------------------------------------
# h(t) = w I1(w)/I0(w) with w = e^t e^{jπ/4}, tabulated on a uniform grid in t = ln|w| as cubic
# Hermite pieces (value and dh/dt = w² (1 − (I1/I0)²) at the nodes, from scipy's ive). In t, h grows
# like e^{2t} (small |w|) and e^t (large |w|), so the relative interpolation error is uniform:
# max 9e-14 at |w| ≈ 2 with a step of 2^-10 (tests/test_models.py checks 2e-13 against a
# backward continued fraction).
_TABLE_T = (math.log(1e-4), math.log(1e3))
_TABLE_STEP = 2.0**-10
_E45 = complex(math.sqrt(0.5), math.sqrt(0.5))


@functools.cache
def _h_table() -> tuple[np.ndarray, ...]:
    """Per-interval coefficients ``c0..c3`` (real parts, then imaginary parts) of
    ``h(t_i + x Δ) = c0 + c1 x + c2 x² + c3 x³``, ``0 ≤ x ≤ 1``."""
    t0, t1 = _TABLE_T
    n = int(math.ceil((t1 - t0) / _TABLE_STEP)) + 1
    w = np.exp(t0 + _TABLE_STEP * np.arange(n)) * _E45
    r = special.ive(1, w) / special.ive(0, w)
    h = w * r
    d = _TABLE_STEP * w * w * (1.0 - r * r)
    cs = (h[:-1], d[:-1], 3.0 * (h[1:] - h[:-1]) - 2.0 * d[:-1] - d[1:],
          2.0 * (h[:-1] - h[1:]) + d[:-1] + d[1:])
    out = tuple(np.ascontiguousarray(c.real) for c in cs) + tuple(np.ascontiguousarray(c.imag) for c in cs)
    for c in out:
        c.setflags(write=False)
    return out


def table_position(half_log_alpha, half_log_omega, out=None):
    """Position in the Bessel table [intervals] of ``t = ½ ln α + ½ ln ω`` (``α`` [s], ``ω``
    [rad/s]; the halves broadcast, e.g. ``(W, 1)`` against ``(F,)``)."""
    a = (np.asarray(half_log_alpha, float) - _TABLE_T[0]) / _TABLE_STEP
    return np.add(a, np.asarray(half_log_omega, float) / _TABLE_STEP, out=out)


def bessel_h_into(pos, re, im, idx, frac, tmp) -> None:
    """``h = w I1(w)/I0(w)`` at table positions ``pos`` (:func:`table_position`), written into
    ``re``, ``im``: the allocation-free core of :func:`bessel_eddy_jw`. ``idx`` (intp), ``frac``
    and ``tmp`` are scratch arrays of ``pos``'s shape; ``pos`` is left unchanged except where it
    lies outside the table (those points are evaluated exactly instead)."""
    tab = _h_table()
    last = tab[0].size  # the table's intervals are 0 .. last - 1
    lo, hi = (float(pos.min()), float(pos.max())) if pos.size else (0.0, 0.0)
    mask = None
    if not (lo >= 0.0 and hi < last):  # also for NaN
        mask = ~((pos >= 0.0) & (pos < last))
        t_out = pos[mask] * _TABLE_STEP + _TABLE_T[0]
        pos[mask] = 0.0
    np.copyto(idx, pos, casting="unsafe")  # truncation = floor for 0 <= pos < last
    np.subtract(pos, idx, out=frac)
    for (c0, c1, c2, c3), acc in ((tab[:4], re), (tab[4:], im)):
        np.take(c3, idx, out=acc, mode="clip")  # "raise" would buffer out
        for c in (c2, c1, c0):
            acc *= frac
            acc += np.take(c, idx, out=tmp, mode="clip")
    if mask is not None and np.any(mask):
        with np.errstate(all="ignore"):
            w = np.exp(t_out) * _E45
            h = w * _i1_over_i0(w)
        re[mask], im[mask] = h.real, h.imag
        pos[mask] = (t_out - _TABLE_T[0]) / _TABLE_STEP


def _h_at(half_log_alpha, half_log_omega):
    """``(Re h, Im h)`` at ``t = ½ ln α + ½ ln ω`` (arrays broadcasting to the result's shape)."""
    pos = np.asarray(table_position(half_log_alpha, half_log_omega), float)
    shape = pos.shape
    pos = pos.reshape(-1)
    re, im, frac, tmp = (np.empty_like(pos) for _ in range(4))
    bessel_h_into(pos, re, im, np.empty(pos.shape, np.intp), frac, tmp)
    return re.reshape(shape), im.reshape(shape)


def bessel_ratio_jw(alpha, omega) -> np.ndarray:
    """``I1(w)/I0(w)`` for ``w = sqrt(j α ω)`` (angle 45°) [1], complex, broadcast shape of
    ``alpha`` [s] and ``omega`` [rad/s] (both > 0). Equals ``j J1(-jw)/J0(-jw)``; from the table
    for ``1e-4 ≤ |w| ≤ 1e3`` (relative error < 1e-13), :func:`_i1_over_i0` outside it."""
    with np.errstate(divide="ignore", invalid="ignore"):
        la, lw = 0.5 * np.log(np.asarray(alpha, float)), 0.5 * np.log(np.asarray(omega, float))
        re, im = _h_at(la, lw)
        scale = math.sqrt(0.5) * np.exp(-(la + lw))  # r = h / w = h e^{-jπ/4} / |w|
    out = np.empty(re.shape, complex)
    out.real = (re + im) * scale
    out.imag = (im - re) * scale
    return out


def bessel_eddy_jw(omega, alpha, beta) -> tuple[np.ndarray, np.ndarray]:
    """Model III on the imaginary axis, ``(Re, Im)`` of ``Z_III(jω)`` [ohm], real arithmetic.

    ``Z_III(jω) = β sqrt(jω) I1(w)/I0(w) = (β/sqrt(α)) h``, ``h = w I1(w)/I0(w)``,
    ``w = sqrt(j α ω)``. ``omega`` [rad/s] > 0, ``alpha`` [s], ``beta`` [H s^-½] broadcast
    (e.g. ``(F,)`` against ``(W, 1)``).
    """
    alpha = np.asarray(alpha, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        la = 0.5 * np.log(alpha)
        re, im = _h_at(la, 0.5 * np.log(np.asarray(omega, float)))
        g = np.asarray(beta, float) * np.exp(-la)
    if np.broadcast_shapes(re.shape, g.shape) == re.shape:
        re *= g
        im *= g
        return re, im
    return re * g, im * g


def bessel_eddy_rational(s, alpha, beta):
    """First-order rational approximation of model III used for the initial estimate:
    ``β sqrt(α) s (α s + 8) / (4 α s + 16)``."""
    return beta * np.sqrt(alpha) * s * (alpha * s + 8.0) / (4.0 * alpha * s + 16.0)


def ring_ladder_modes(Pg, P, R, n_turns):
    """Modal form of the NL coil (eq. 41): ``Z = N² [Pg s + Σ_k L_k s / (1 + τ_k s)]``.

    With ``A = D P Dᵀ`` (SPD), ``b = D P U`` and ``R`` diagonal, ``(A s + R)⁻¹`` diagonalises in the
    symmetric eigenbasis of ``R^-½ A R^-½ = Q Λ Qᵀ``: ``τ_k = λ_k``, ``c = Qᵀ R^-½ b`` and
    ``L_k = c_k² / λ_k``; since ``Σ c_k²/λ_k = bᵀA⁻¹b = Uᵀ P U`` the ``s`` and ``s²`` terms of (41)
    combine into first-order terms with no cancellation.

    Parameters
    ----------
    Pg : array (...,) ; P, R : arrays (..., n) ; n_turns : float
        Leading axes are parameter sets (vectorised ``eigh`` on a stack).

    Returns
    -------
    gap : (...,) the gap inductance ``N² Pg`` [H]
    Lk : (..., n) modal inductances ``N² L_k`` [H]
    tau : (..., n) modal time constants [s]
    """
    P = np.asarray(P, dtype=float)
    R = np.asarray(R, dtype=float)
    n = P.shape[-1]
    # A_ij = sum_{l <= min(i,j)} P_l  (D lower-triangular ones)
    cum = np.cumsum(P, axis=-1)
    idx = np.minimum.outer(np.arange(n), np.arange(n))
    A = cum[..., idx]
    b = cum  # (D P U)_i = sum_{l<=i} P_l
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rinv = 1.0 / np.sqrt(R)
        M = A * rinv[..., :, None] * rinv[..., None, :]
    # a non-physical parameter set (non-finite, R <= 0) yields NaN, never an exception, so an
    # optimiser or sampler that strays there just sees a bad point
    bad = ~np.all(np.isfinite(M), axis=(-2, -1)) | np.any(R <= 0, axis=-1) | np.any(P < 0, axis=-1)
    if np.any(bad):
        M = np.where(bad[..., None, None], np.eye(n), M)
        rinv = np.where(bad[..., None], 1.0, rinv)
    lam, Q = np.linalg.eigh(M)
    c = np.einsum("...ij,...i->...j", Q, b * rinv)
    lam = np.maximum(lam, np.finfo(float).tiny)
    N2 = float(n_turns) ** 2
    Lk = N2 * c * c / lam
    if np.any(bad):
        Lk = np.where(bad[..., None], np.nan, Lk)
        lam = np.where(bad[..., None], np.nan, lam)
    return N2 * np.asarray(Pg, float), Lk, lam


def ring_ladder(s, Pg, P, R, n_turns):
    """Model NL: coil coupled to ``n`` resistive rings (eq. 41) [ohm].

    ``s`` has shape ``(F,)`` (or broadcasts as ``(..., F)``); ``Pg`` shape ``(...)``; ``P, R``
    shape ``(..., n)``. Returns ``(..., F)``. On the imaginary axis (``s = jω``, up to
    :data:`LADDER_POLY_MAX_RINGS` rings) through :func:`ladder_polynomials` and real matrix
    products; elsewhere O(n) per frequency after one eigen-decomposition
    (:func:`ring_ladder_modes`).
    """
    s = np.asarray(s, dtype=complex)
    P = np.asarray(P, dtype=float)
    if (s.ndim == 1 and s.size and P.shape[-1] <= LADDER_POLY_MAX_RINGS and np.all(s.real == 0)
            and np.all(s.imag > 0)):
        num, den = ladder_polynomials(Pg, P, R, n_turns)
        with np.errstate(over="ignore"):
            basis = jw_power_basis(s.imag, num.shape[-1] - 1)
        if all(np.all(np.isfinite(b)) for b in basis):
            nr, ni = polynomial_jw(num, basis=basis)
            dr, di = polynomial_jw(den, basis=basis)
            with np.errstate(all="ignore"):
                out = np.empty(nr.shape, complex)
                out.real, out.imag = nr, ni
                den_c = np.empty(dr.shape, complex)
                den_c.real, den_c.imag = dr, di
                return out / den_c
    gap, Lk, tau = ring_ladder_modes(Pg, P, R, n_turns)
    ss = s[..., None]  # (..., F, 1)
    modal = np.sum(Lk[..., None, :] * ss / (1.0 + tau[..., None, :] * ss), axis=-1)
    return gap[..., None] * s + modal


#: Most rings :func:`ring_ladder` evaluates through polynomials (degree n + 1 in s) on s = jω.
LADDER_POLY_MAX_RINGS = 12


def uniform_rings(Lg, alpha, beta, n_rings, n_turns):
    """UL: the NL ring parameters of a uniform core cut into ``n`` equal-area rings.

    ``Pg = Lg/N²``, ``Pj = β sqrt(α)/(2 N² n)``,
    ``Rj = β/(N² sqrt(α)) · sqrt(j)/(sqrt(j) − sqrt(j−1))``. Returns ``Pg (...), P (..., n), R (..., n)``.
    """
    Lg, alpha, beta = (np.asarray(a, dtype=float) for a in (Lg, alpha, beta))
    N2 = float(n_turns) ** 2
    j = np.arange(1, n_rings + 1, dtype=float)
    shape_r = np.sqrt(j) / (np.sqrt(j) - np.sqrt(j - 1.0))
    Pg = Lg / N2
    P = (beta * np.sqrt(alpha) / (2.0 * N2 * n_rings))[..., None] * np.ones(n_rings)
    R = (beta / (N2 * np.sqrt(alpha)))[..., None] * shape_r
    return Pg, P, R


# ---- rational terms as polynomial pairs, evaluated on the imaginary axis -------------------------
def _stack_coeffs(*cols):
    cols = np.broadcast_arrays(*(np.asarray(c, float) for c in cols))
    return np.stack(cols, axis=-1)


def resistance_polynomials(R):
    """``R`` [ohm] as ``(num, den)`` coefficient arrays ``(..., 1)``, lowest power first."""
    R = np.asarray(R, float)
    return R[..., None], np.ones(R.shape + (1,))


def inductance_polynomials(L):
    """``L s`` [ohm] (model I, the gap term ``Lg s``) as ``(num (..., 2), den (..., 1))``."""
    L = np.asarray(L, float)
    return _stack_coeffs(np.zeros_like(L), L), np.ones(L.shape + (1,))


def lossy_inductance_polynomials(L0, Rmu):
    """Model II ``Rμ L0 s / (Rμ + L0 s)`` as ``(num, den)``, each ``(..., 2)``."""
    L0, Rmu = np.broadcast_arrays(np.asarray(L0, float), np.asarray(Rmu, float))
    return _stack_coeffs(np.zeros_like(L0), Rmu * L0), _stack_coeffs(Rmu, L0)


def motional_polynomials(zeta, omega0, phi):
    """Motional impedance ``φ̄² s / (s² + 2ζω0 s + ω0²)`` (eq. 47) as ``(num (..., 2), den (..., 3))``."""
    zeta, omega0, phi = np.broadcast_arrays(*(np.asarray(a, float) for a in (zeta, omega0, phi)))
    return (_stack_coeffs(np.zeros_like(phi), phi * phi),
            _stack_coeffs(omega0 * omega0, 2.0 * zeta * omega0, np.ones_like(omega0)))


def ladder_polynomials(Pg, P, R, n_turns):
    """The NL coil (eq. 41) as ``(num (..., n + 2), den (..., n + 1))`` with ``Zc = num(s)/den(s)``.

    The ring equations of (41) form a magnetic ladder: with ``q_0 = 0`` and, ring by ring from
    the innermost outwards, ``q_j = (q_{j-1} + P_j) / (1 + s (q_{j-1} + P_j) / R_j)`` (ring ``j``'s
    loop in parallel with everything it encloses), ``Zc = N² s (Pg + q_n)``. The recursion on
    polynomial pairs ``q_j = a_j/b_j`` (``b_j(0) = 1``) has only sums and products of positive
    numbers: no eigen-decomposition and no cancellation. Leading axes of ``Pg (...)``,
    ``P, R (..., n)`` are parameter sets; a non-physical set (``P < 0``, ``R ≤ 0``, non-finite)
    gives NaN coefficients.
    """
    P = np.asarray(P, float)
    R = np.asarray(R, float)
    Pg = np.asarray(Pg, float)
    lead = np.broadcast_shapes(Pg.shape, P.shape[:-1], R.shape[:-1])
    n = P.shape[-1]
    a = np.zeros(lead + (n + 1,))
    b = np.zeros(lead + (n + 1,))
    b[..., 0] = 1.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for j in range(n):
            # c = a + P_j b (degree j); a <- c; b <- b + (s / R_j) c (degree j + 1)
            c = a[..., : j + 1] + P[..., j, None] * b[..., : j + 1]
            a[..., : j + 1] = c
            b[..., 1 : j + 2] += c / R[..., j, None]
        num = np.zeros(lead + (n + 2,))
        num[..., 1:] = float(n_turns) ** 2 * (Pg[..., None] * b + a)
    bad = ~(np.all(P >= 0, axis=-1) & np.all(R > 0, axis=-1) & np.isfinite(Pg) & (Pg >= 0)
            & np.all(np.isfinite(P), axis=-1) & np.all(np.isfinite(R), axis=-1))
    if np.any(bad):
        num[bad] = np.nan
        b[bad] = np.nan
    return num, b


def poly_mul(a, b):
    """Product of polynomials ``(..., m)`` and ``(..., n)`` (lowest power first) → ``(..., m + n − 1)``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    lead = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    m, n = a.shape[-1], b.shape[-1]
    if m > n:
        a, b, m, n = b, a, n, m
    out = np.zeros(lead + (m + n - 1,))
    for i in range(m):
        out[..., i : i + n] += a[..., i, None] * b
    return out


def _poly_add(a, b):
    m, n = a.shape[-1], b.shape[-1]
    if m < n:
        a, b, m, n = b, a, n, m
    lead = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    out = np.array(np.broadcast_to(a, lead + (m,)))
    out[..., :n] += b
    return out


def add_rational(first, second):
    """Sum of two series impedances given as ``(num, den)`` pairs: ``(n1 d2 + n2 d1, d1 d2)``
    (a constant denominator ``(..., 1)`` only scales)."""
    (n1, d1), (n2, d2) = first, second
    if d2.shape[-1] == 1 and d1.shape[-1] == 1:
        return _poly_add(n1 * d2, n2 * d1), d1 * d2
    return _poly_add(poly_mul(n1, d2), poly_mul(n2, d1)), poly_mul(d1, d2)


def jw_power_basis(omega, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary parts of ``(jω)^k``, ``k = 0..degree``: ``(even (⌊d/2⌋+1, F), odd (⌈d/2⌉, F))``.

    ``Re p(jω) = c[0::2] @ even`` and ``Im p(jω) = c[1::2] @ odd`` for coefficients ``c``
    (lowest power first): row ``i`` of ``even`` is ``(−1)^i ω^{2i}``, of ``odd`` ``(−1)^i ω^{2i+1}``.
    """
    omega = np.asarray(omega, float)
    basis = np.empty((degree + 1, omega.size))
    basis[0] = 1.0
    for k in range(1, degree + 1):  # (jω)^k = j ω (jω)^(k−1): products, not pow()
        np.multiply(basis[k - 1], omega, out=basis[k])
    basis[2::4] *= -1.0
    basis[3::4] *= -1.0
    return np.ascontiguousarray(basis[0::2]), np.ascontiguousarray(basis[1::2])


def polynomial_jw(coeffs, omega=None, *, basis=None) -> tuple[np.ndarray, np.ndarray]:
    """``(Re, Im)`` of polynomials ``coeffs (..., d + 1)`` at ``s = jω``: two real matrix products
    with :func:`jw_power_basis` (pass a precomputed ``basis`` to skip building it)."""
    c = np.asarray(coeffs, float)
    if basis is None:
        basis = jw_power_basis(omega, c.shape[-1] - 1)
    even, odd = basis
    ne, no = (c.shape[-1] + 1) // 2, c.shape[-1] // 2
    re = c[..., 0::2] @ even[:ne]
    im = c[..., 1::2] @ odd[:no] if no else np.zeros(c.shape[:-1] + (even.shape[1],))
    return re, im
