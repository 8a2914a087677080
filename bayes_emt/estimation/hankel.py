"""Ring count for NL by Hankel singular values.

The blocked admittance ``Yb(s) = 1/(Z_NL(s) + R0)`` of an n-ring fit has ``n + 1`` states. Its
Hankel singular values (HSV) ``σ_1 ≥ … ≥ σ_{n+1}`` [S] measure how much each state of a balanced
realisation contributes to the input-output behaviour; an over-parameterised fit shows a sharp drop
after the states the data really support. The paper fitted n = 7 and saw the drop between states 6
and 7 (the coil current plus five rings), hence n = 5.

Realisation
-----------
The modal (Foster) form of the coil (:func:`~bayes_emt.models.rational.foster_form`; exact forms only),

    Ze(s) = R0 + G s + Σ_k L_k s / (1 + τ_k s),      G = N² Pg,

is a series RL circuit: the gap inductance ``G`` carries the terminal current ``i_0``, and section
``k`` is ``L_k`` in parallel with ``R_k = L_k/τ_k`` (inductor current ``j_k``). With the inductance
matrix ``M = diag(G, L_1..L_n)`` and the symmetric resistance matrix ``Rm`` of that circuit,
``M x' = −Rm x + e_0 v`` and ``i_0 = e_0ᵀ x``. In *energy coordinates* ``ξ = M^½ x`` the system is
state-space symmetric, ``A = −M^-½ Rm M^-½ = Aᵀ``, ``B = Cᵀ = e_0/√G``, so the controllability and
observability gramians coincide, ``W = Wc = Wo``, and the HSV are simply the eigenvalues of ``W``.
With ``A = −V Λ Vᵀ`` (a symmetric eigen-decomposition) the Lyapunov equation
``A W + W A + B Bᵀ = 0`` is solved in closed form, ``W̃_ij = b̃_i b̃_j/(λ_i + λ_j)`` with
``b̃ = Vᵀ B``: no gramian product, no Cholesky factor of a near-singular gramian, and time
constants from 1e-7 to 1e2 s cost nothing in accuracy (errors are ``≈ 1e-16 σ_1`` absolute).
Two exact checks follow: the HSV sum to ``Yb(0)/2 = 1/(2 R0)`` (``trace W = ½ Bᵀ(−A)⁻¹B``), and a
single section-less coil ``1/(R0 + L0 s)`` has the single HSV ``1/(2 R0)``.
:func:`gramian_hsv` is the general square-root method (two Lyapunov solves after scaling), kept for
any stable ``(A, B, C)`` and used by the tests as an independent cross-check.

Modes outside the band
----------------------
A least-squares fit with too many rings often parks a spare ring where the data cannot see it:
a corner ``1/τ_k`` decades below the band (the section is then just a resistor ``L_k/τ_k`` in
series with ``R0``) or decades above it (just an inductor ``L_k`` added to ``G``). Such a state has
a *large* HSV, because HSV weigh all frequencies, yet the data say nothing about it. Such modes
(corner a decade or more outside the measured band) are therefore folded into ``R0`` or ``G``
first and reported with HSV 0. Without folding, the 7-ring fit of the paper-bench data has a mode
at 0.03 rad/s (0.28 Ω of its apparent ``R0``) and a sixth state as large as a real ring.

States in the noise
-------------------
A spare ring can also stay in band and fit noise. Its HSV is then small but not always sharply
so, so :func:`select_rings` first declares unresolved every state whose largest possible effect on
the admittance (``2σ_i``, the balanced-truncation bound) is below five per-point noise standard
deviations, and looks for the sharp drop among the rest (:func:`choose_rings`, which documents the
rule).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from ..errors import IdentifiabilityWarning
from ..measurement import Measurement
from ..models import DEFAULT_N_TURNS, Model, build_model
from ..models.rational import foster_form as _foster
from ..models.residual import relative_residual
from .results import FitResult

__all__ = ["hankel_singular_values", "gramian_hsv", "blocked_state_space", "fold_out_of_band",
           "choose_rings", "noise_level", "select_rings", "RingChoice", "SHARP_DROP", "RESOLUTION"]

#: a drop ``σ_i/σ_{i+1}`` at least this large counts as *sharp*; resolved ring states fall by
#: factors of about 3-5 each (paper-bench NL(7) fit: 3.8, 3.4, 3.2, 4.2)
SHARP_DROP = 10.0
#: a state is resolved when its largest effect on the admittance, 2σ (balanced truncation), is at
#: least this many per-point noise standard deviations (:func:`select_rings`)
RESOLUTION = 5.0
#: HSV below this fraction of ``σ_1`` count as zero in :func:`choose_rings`: removing a state
#: changes ``Yb`` by at most ``2σ`` (balanced truncation), here < 1e-6 of the smallest in-band |Yb| of
#: a typical coil, far below any instrument's resolution
HSV_FLOOR = 1e-8


def foster_parts(model: Model, theta):
    """``(R0, G, L, tau)`` of the model's exact Foster form; ``ValueError`` when it has none (the
    Bessel models' infinite form, or a term without a finite RL form)."""
    f = _foster(model, theta)
    if f is None or not f.exact:
        raise ValueError(f"model {model.label} has no exact Foster form; Hankel singular values need "
                         "a rational coil (I, II, NL, UL, or these with lead or LR-2 terms)")
    return f.R0, f.G, f.L, f.tau


def fold_out_of_band(R0, G, Lk, tau, band, decades: float = 1.0):
    """Fold the sections whose corner ``1/τ_k`` lies ``decades`` or more outside ``band`` [rad/s].

    Below the band a section ``L_k s/(1 + τ_k s)`` is the resistor ``L_k/τ_k`` [Ω] (added to
    ``R0``); above it, the inductor ``L_k`` [H] (added to ``G``).

    Returns
    -------
    R0, G, Lk, tau, n_folded
    """
    Lk, tau = np.asarray(Lk, float), np.asarray(tau, float)
    corner = 1.0 / tau
    slow = corner < band[0] / 10**decades
    fast = corner > band[1] * 10**decades
    keep = ~(slow | fast)
    return (R0 + float(np.sum(Lk[slow] / tau[slow])), G + float(np.sum(Lk[fast])), Lk[keep], tau[keep],
            int(np.count_nonzero(~keep)))


def blocked_state_space(model: Model, theta, band=None):
    """Symmetric realisation ``(A, B, C)`` of ``1/(Zc(s) + R0)`` (voltage in, current out).

    Energy coordinates (module docstring): ``A`` symmetric negative definite [1/s], ``B = Cᵀ``
    [H^-½]. ``n + 1`` states for NL(n)/UL(n), one for model I; fewer when ``band`` (rad/s) is
    given and out-of-band sections are folded (:func:`fold_out_of_band`).
    """
    R0, G, Lk, tau = foster_parts(model, theta)
    if band is not None:
        R0, G, Lk, tau, _ = fold_out_of_band(R0, G, Lk, tau, band)
    if not G > 0:
        raise ValueError(f"model {model.label}: the blocked admittance needs a series (gap) inductance > 0 "
                         "(models I, NL, UL)")
    # K = M^-½ Rm M^-½ with Rm = [[R0 + ΣR_k, −R_k], [−R_k, diag R_k]], R_k = L_k/τ_k
    K = np.diag(np.r_[(R0 + np.sum(Lk / tau)) / G, 1.0 / tau])
    off = -np.sqrt(Lk / G) / tau
    K[0, 1:] = off
    K[1:, 0] = off
    B = np.zeros((Lk.size + 1, 1))
    B[0, 0] = 1.0 / np.sqrt(G)
    return -K, B, B.T.copy()


def _symmetric_hsv(A, B):
    """HSV of a state-space symmetric system (``A = Aᵀ`` stable, ``C = Bᵀ``), largest first."""
    lam, V = np.linalg.eigh(-0.5 * (A + A.T))
    if not np.all(lam > 0):
        raise ValueError("the realisation is not asymptotically stable (an eigenvalue of A >= 0)")
    b = V.T @ B[:, 0]
    W = np.outer(b, b) / (lam[:, None] + lam[None, :])
    return np.clip(np.linalg.eigvalsh(W)[::-1], 0.0, None)


def gramian_hsv(A, B, C) -> np.ndarray:
    """HSV of any stable ``(A, B, C)`` by the square-root method, largest first.

    Time is rescaled to the slowest diagonal rate and the states by LAPACK's diagonal balancing
    (both similarity transforms, which leave HSV unchanged) before the two Lyapunov solves
    ``A Wc + Wc Aᵀ = −B Bᵀ``, ``Aᵀ Wo + Wo A = −Cᵀ C``; then ``σ = svd(Loᵀ Lc)`` for any factors
    ``W = L Lᵀ``.
    """
    A, B, C = (np.atleast_2d(np.asarray(x, float)) for x in (A, B, C))
    t0 = 1.0 / np.min(np.abs(np.diag(A)))
    A, B, C = A * t0, B * np.sqrt(t0), C * np.sqrt(t0)
    d = linalg.matrix_balance(A, permute=False, separate=True)[1][0]  # balanced: D⁻¹ A D
    A = A * d[None, :] / d[:, None]
    B = B / d[:, None]
    C = C * d[None, :]
    Wc = linalg.solve_continuous_lyapunov(A, -B @ B.T)
    Wo = linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
    return linalg.svdvals(_sqrt_factor(Wo).T @ _sqrt_factor(Wc))


def _sqrt_factor(W):
    """``L`` with ``L Lᵀ = W`` for a symmetric positive semi-definite ``W`` (round-off clipped)."""
    w, V = np.linalg.eigh(0.5 * (W + W.T))
    return V * np.sqrt(np.clip(w, 0.0, None))


def hankel_singular_values(model: Model, theta, band=None) -> np.ndarray:
    """Hankel singular values [S] of ``1/(Zc(s) + R0)``, largest first.

    Parameters
    ----------
    model : a model with a series coil inductance: ``NL`` or ``UL`` (``n + 1`` states) or ``I``.
    theta : (k,) parameter vector in ``model.names`` order [SI].
    band : (omega_min, omega_max) [rad/s] or None; when given, sections with corners a decade or
        more outside it are folded (module docstring) and their HSV reported as 0.

    Returns
    -------
    (n_states,) array; ``sum = 1/(2 R0)`` with ``R0`` including folded slow sections.
    """
    A, B, _ = blocked_state_space(model, theta, band)
    n_states = foster_parts(model, theta)[2].size + 1
    hsv = _symmetric_hsv(A, B)
    return np.pad(hsv, (0, n_states - hsv.size))


def choose_rings(hsv, sharp_drop: float = SHARP_DROP, noise_floor: float = 0.0) -> int:
    """Ring count from Hankel singular values of the blocked admittance (largest first).

    Rule: values below ``noise_floor`` [S] are unresolved and count as 0 (so do folded states);
    zeros are then raised to ``HSV_FLOOR σ_1 = 1e-8 σ_1`` (immaterial to any measurement) so that
    a drop to "nothing" is a large but finite ratio and a drop between two negligible states
    cannot outrank a real one. The coil current (state 1) always stays; among the remaining cuts,
    keep the states before the **largest** ratio ``σ_i/σ_{i+1}`` (``i ≥ 2``; the first on ties):
    ``n = i − 1`` rings. If that ratio is below ``sharp_drop`` there is no sharp drop and every
    state is kept (``n = len(hsv) − 1``: the data may support even more rings). When no ring
    state is resolved at all, ``n = 1`` (the smallest NL).

    Example: the paper's n = 7 fit (8 states) drops between states 6 and 7, so n = 5.
    """
    hsv = np.asarray(hsv, dtype=float)
    if hsv.ndim != 1 or hsv.size < 1 or not np.all(np.isfinite(hsv)) or np.any(hsv < 0) or not hsv[0] > 0:
        raise ValueError("hsv must be a non-empty 1-D array of non-negative values with hsv[0] > 0")
    if np.any(np.diff(hsv) > 1e-12 * hsv[0]):
        raise ValueError("hsv must be sorted largest first")
    if hsv.size < 3:
        return hsv.size - 1
    resolved = hsv >= noise_floor
    if not resolved[1]:
        return 1
    s = np.maximum(np.where(resolved, hsv, 0.0), HSV_FLOOR * hsv[0])
    ratios = s[1:-1] / s[2:]  # ratios[j] = σ_{j+2}/σ_{j+3}: keep j + 2 states
    j = int(np.argmax(ratios))
    if ratios[j] < sharp_drop:
        return hsv.size - 1
    return j + 1


def noise_level(meas: Measurement, fit: FitResult) -> float:
    """Per-point noise of the admittance where it is smallest, ``ε = s min_ω |Y_fit(jω)|`` [S].

    ``s`` is the fit's relative residual scale per real component, ``s² = Σ|ΔY/Y|²/(2F − k)``
    (about the simulator's ``noise``; model error included on real data, which makes ``ε``
    conservative).
    """
    Yfit = fit.model.admittance(meas.omega, fit.theta)
    rel = relative_residual(fit.model, fit.theta, meas)
    s = float(np.sqrt(np.sum(np.abs(rel) ** 2) / max(2 * meas.n_points - fit.model.ndim, 1)))
    return s * float(np.min(np.abs(Yfit)))


@dataclass(frozen=True)
class RingChoice:
    """The ring count chosen from an over-sized NL fit (:func:`select_rings`).

    Attributes
    ----------
    hsv : (max_rings + 1,) Hankel singular values [S] of ``1/(Zc + R0)`` of the fit, largest
        first, 0 for folded out-of-band states.
    rings : the chosen ring count n (:func:`choose_rings`).
    fit : the NL(``max_rings``) :class:`~bayes_emt.estimation.results.FitResult` the HSV come from.
    band : (omega_min, omega_max) [rad/s] of the data, used to fold out-of-band modes.
    n_folded : how many modes were folded.
    noise_floor : HSV below it [S] are unresolved (``RESOLUTION ε / 2``, :func:`noise_level`).
    sharp_drop : the threshold of :func:`choose_rings` that was applied.
    """

    hsv: np.ndarray
    rings: int
    fit: FitResult
    band: tuple[float, float]
    n_folded: int
    noise_floor: float = 0.0
    sharp_drop: float = SHARP_DROP

    @property
    def ratios(self) -> np.ndarray:
        """``σ_i/σ_{i+1}`` (``inf`` where ``σ_{i+1} = 0``)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.hsv[1:] > 0, self.hsv[:-1] / self.hsv[1:], np.inf)

    @property
    def resolved(self) -> np.ndarray:
        """Which states stand out of the noise (``hsv >= noise_floor``, and not folded)."""
        return (self.hsv >= self.noise_floor) & (self.hsv > 0)

    def to_json_dict(self) -> dict:
        return {"max_rings": self.fit.model.rings, "rings": self.rings,
                "hankel_singular_values": [float(x) for x in self.hsv],
                "ratios": [float(r) if np.isfinite(r) else None for r in self.ratios],
                "resolved": [bool(x) for x in self.resolved], "noise_floor": self.noise_floor,
                "units": "S", "band_rad_s": [float(b) for b in self.band], "folded_states": self.n_folded,
                "rule": (f"unresolved (HSV < {self.noise_floor:.3g} S) and folded states count as 0; "
                         f"largest drop sigma_i/sigma_(i+1), i >= 2, if >= {self.sharp_drop:g}: n = i - 1"),
                "fit_rms_rel_residual": float(self.fit.rms_rel_residual),
                "fit_parameters": self.fit.parameters}


def select_rings(meas: Measurement, max_rings: int = 7, *, n_turns: float = DEFAULT_N_TURNS,
                 sharp_drop: float = SHARP_DROP, resolution: float = RESOLUTION) -> RingChoice:
    """Fit NL(``max_rings``) to ``meas`` and choose the ring count by its Hankel singular values.

    The fit is :func:`~bayes_emt.estimation.fitting.fit_admittance` from its automatic initial estimate.
    Modes outside the measured band are folded (module docstring), and states whose largest
    possible effect on the admittance, ``2σ_i`` (the balanced-truncation bound), is below
    ``resolution`` per-point noise standard deviations ``ε`` (:func:`noise_level`) are
    unresolved: ``noise_floor = resolution ε / 2``. Then :func:`choose_rings`.

    Why the noise floor: with noise, the spare rings of an over-sized fit do not always collapse.
    On Table 5 data with 0.2 % noise (ε ≈ 1.3e-5 S) the last true ring has σ_6 ≈ 5.5-7.7 ε while
    a spare in-band ring reached σ_7 ≈ 1.3 ε (seeds 1-4, 11), fitting noise only (an NL(7) fit
    lowered χ² by 1.2 against NL(5)); the raw ratio σ_6/σ_7 was then 5.6, no sharp drop, while
    for other seeds a spare ring at 1e-6 S made the drop *after* it the largest.

    Warns :class:`~bayes_emt.errors.IdentifiabilityWarning` when there is no sharp drop (the data
    may support ``max_rings`` or more rings).
    """
    from .fitting import fit_admittance

    if isinstance(max_rings, bool) or int(max_rings) != max_rings or max_rings < 2:
        raise ValueError(f"max_rings must be an integer >= 2, got {max_rings!r}")
    fit = fit_admittance(meas, build_model("NL", rings=int(max_rings), n_turns=n_turns))
    band = (float(meas.omega[0]), float(meas.omega[-1]))
    R0, G, Lk, tau = foster_parts(fit.model, fit.theta)
    n_folded = fold_out_of_band(R0, G, Lk, tau, band)[4]
    hsv = hankel_singular_values(fit.model, fit.theta, band=band)
    floor = 0.5 * resolution * noise_level(meas, fit)
    rings = choose_rings(hsv, sharp_drop, floor)
    if rings == hsv.size - 1:
        warnings.warn(f"{meas.source}: no sharp drop (>= {sharp_drop:g}x) in the Hankel singular values of "
                      f"an NL({max_rings}) fit; the data may support {max_rings} rings or more",
                      IdentifiabilityWarning, stacklevel=2)
    return RingChoice(hsv, rings, fit, band, n_folded, floor, float(sharp_drop))
