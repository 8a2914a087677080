"""Ring count for NL by Hankel singular values (SPEC §3.3).

The blocked admittance ``1/(Z_NL(s) + R0)`` of an n-ring fit has ``n + 1`` states. Its Hankel
singular values (HSV) measure how much each state contributes to the input-output behaviour;
an over-parameterised fit shows a sharp drop after the states the data really support. The
paper fitted n = 7 and saw the drop between states 6 and 7, hence n = 5.

Realisation: the modal (Foster) form ``Ze = R0 + G s + Σ L_k s/(1 + τ_k s)`` as a circuit with
the series current and each section's inductor current as states. The gramians come from
Lyapunov equations after a diagonal (time- and state-) scaling that keeps time constants from
1e-2 to 1e-7 s well conditioned; HSV are invariant to such similarity transforms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from .data import Measurement
from .models import Model, build_model
from .models.rational import foster_form
from .results import FitResult

__all__ = ["hankel_singular_values", "choose_rings", "select_rings", "RingChoice", "blocked_state_space"]


def fold_out_of_band(R0, G, Lk, tau, band):
    """Fold modes whose corner ``1/τ_k`` lies a decade or more outside ``band`` [rad/s]: below,
    the section is a resistor ``L_k/τ_k`` in the band (added to R0); above, an inductor ``L_k``
    (added to G). Such states cannot be resolved by the data, whatever the fit made of them."""
    corner = 1.0 / tau
    slow = corner < band[0] / 10
    fast = corner > band[1] * 10
    keep = ~(slow | fast)
    return (R0 + float(np.sum(Lk[slow] / tau[slow])), G + float(np.sum(Lk[fast])), Lk[keep], tau[keep],
            int(np.count_nonzero(~keep)))


def blocked_state_space(model: Model, theta, band=None):
    """``(A, B, C)`` of ``1/Ze(s)`` (voltage in, current out) for a rational model, n+1 states
    (fewer when ``band`` [rad/s] is given and modes outside it are folded)."""
    R0, G, Lk, tau = foster_form(model, theta)
    if band is not None:
        R0, G, Lk, tau, _ = fold_out_of_band(R0, G, Lk, tau, band)
    if G <= 0:
        raise ValueError("the blocked admittance needs a series (gap) inductance Pg > 0")
    n = Lk.size
    Rk = Lk / tau
    A = np.zeros((n + 1, n + 1))
    A[0, 0] = -(R0 + Rk.sum()) / G
    A[0, 1:] = Rk / G
    A[1:, 0] = 1.0 / tau
    A[1:, 1:] = np.diag(-1.0 / tau)
    B = np.zeros((n + 1, 1))
    B[0, 0] = 1.0 / G
    C = np.zeros((1, n + 1))
    C[0, 0] = 1.0
    return A, B, C


def hankel_singular_values(model: Model, theta, band=None) -> np.ndarray:
    """HSV of ``1/(Zc(s) + R0)``, largest first (``n + 1`` values for NL(n)); with ``band``
    (rad/s), modes outside it are folded first and their HSV reported as 0."""
    A, B, C = blocked_state_space(model, theta, band)
    n_states = (model.rings or 0) + 1
    # balance the scaling: time in units of the slowest pole, states scaled so that the
    # diagonal of A is of order one
    t0 = 1.0 / np.min(np.abs(np.diag(A)))
    A = A * t0
    B = B * np.sqrt(t0)
    C = C * np.sqrt(t0)
    d = linalg.matrix_balance(A, permute=False, separate=True)[1][0]
    A = A / d[None, :] * d[:, None]
    B = B * d[:, None]
    C = C / d[None, :]
    Wc = linalg.solve_continuous_lyapunov(A, -B @ B.T)
    Wo = linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
    # square-root method: HSV = singular values of Lo^T Lc for any factors W = L L^T
    hsv = linalg.svdvals(_sqrt_factor(Wo).T @ _sqrt_factor(Wc))
    return np.pad(hsv, (0, max(n_states - hsv.size, 0)))


def _sqrt_factor(W):
    """``L`` with ``L Lᵀ = W`` for a symmetric positive semi-definite ``W`` (round-off clipped)."""
    w, V = np.linalg.eigh(0.5 * (W + W.T))
    return V * np.sqrt(np.clip(w, 0.0, None))


SHARP_DROP = 20.0


def choose_rings(hsv, sharp_drop: float = SHARP_DROP) -> int:
    """Ring count from HSV (largest first): the states before the first *sharp* drop
    ``σ_i/σ_{i+1} ≥ sharp_drop`` (resolved ring states fall by factors of about 3–10 each, so a
    drop of 20 or more — or to zero, a folded state — marks what the data do not support);
    ``n = states kept − 1`` since one state is the coil current. With no sharp drop, all states
    are kept."""
    hsv = np.asarray(hsv, float)
    for i in range(1, hsv.size - 1):  # i = states kept; the coil state (i = 0) always stays
        if hsv[i + 1] <= 0 or hsv[i] / hsv[i + 1] >= sharp_drop:
            return i
    return hsv.size - 1


@dataclass(frozen=True)
class RingChoice:
    """Hankel singular values of an NL(``max_rings``) fit and the chosen ring count."""

    hsv: np.ndarray
    rings: int
    fit: FitResult

    def to_json_dict(self) -> dict:
        return {"max_rings": self.fit.model.rings, "hankel_singular_values": [float(x) for x in self.hsv],
                "ratios": [float(a / b) if b > 0 else None
                           for a, b in zip(self.hsv[:-1], self.hsv[1:], strict=True)],
                "rings": self.rings, "fit_rms_rel_residual": self.fit.rms_rel_residual}


def select_rings(meas: Measurement, max_rings: int = 7, *, n_turns: float = 480.0) -> RingChoice:
    """Fit NL(``max_rings``) and choose the ring count by its Hankel singular values."""
    from .fitting import fit_admittance

    if int(max_rings) != max_rings or max_rings < 2:
        raise ValueError(f"max_rings must be an integer >= 2, got {max_rings!r}")
    fit = fit_admittance(meas, build_model("NL", rings=int(max_rings), n_turns=n_turns))
    hsv = hankel_singular_values(fit.model, fit.theta, band=(meas.omega[0], meas.omega[-1]))
    return RingChoice(hsv, choose_rings(hsv), fit)
