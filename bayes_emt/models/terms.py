"""Pure physics: impedance terms as vectorised functions of the Laplace variable ``s``.

Every function takes ``s`` (complex, any shape) and parameter arrays that broadcast against it,
SI units only, and returns a complex impedance [ohm] (or admittance [S] where said). No I/O,
no globals. Equation numbers refer to the source paper as restated in SPEC.md §1–2.
"""

from __future__ import annotations

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
]

# Above this |w| the ratio I1(w)/I0(w) is replaced by its asymptotic series (error < 1e-16).
_ASYMPTOTIC_W = 1e3


def mechanical_polynomial(s, zeta, omega0):
    """``s² + 2 ζ ω0 s + ω0²`` (the mass-normalised mechanical impedance times s)."""
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
    """
    s, alpha, beta = np.broadcast_arrays(np.asarray(s, complex), np.asarray(alpha, float),
                                         np.asarray(beta, float))
    rs = np.sqrt(s)
    w = np.sqrt(alpha) * rs
    return beta * rs * _i1_over_i0(w)


def bessel_eddy_rational(s, alpha, beta):
    """First-order rational approximation of model III used for the initial estimate (SPEC §3.1):
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
    shape ``(..., n)``. Returns ``(..., F)``. O(n) per frequency after one eigen-decomposition.
    """
    gap, Lk, tau = ring_ladder_modes(Pg, P, R, n_turns)
    s = np.asarray(s, dtype=complex)
    ss = s[..., None]  # (..., F, 1)
    modal = np.sum(Lk[..., None, :] * ss / (1.0 + tau[..., None, :] * ss), axis=-1)
    return gap[..., None] * s + modal


def uniform_rings(Lg, alpha, beta, n_rings, n_turns):
    """UL: the NL ring parameters of a uniform core cut into ``n`` equal-area rings (SPEC §2).

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
