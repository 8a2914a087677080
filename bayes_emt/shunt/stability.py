"""Closed-loop stability of a shunted transducer.

The shunted system's poles are the zeros of ``mech(s) · (Z(s) + Zs(s))`` where ``Z`` is the
terminal impedance (coil, R0 and motional branch) and ``Zs`` the shunt (``G = (Ze+Zs)/(mech (Z+Zs))``).

**Threshold in Rs (any model, exact).** With ``Zs = Rs + 1/(Cs s)``, a pole sits on the imaginary
axis at ``jω`` exactly when ``Z(jω) + Rs + 1/(jωCs) = 0``, i.e. where the loop reactance
``X(ω) = Im Z(jω) − 1/(ωCs)`` vanishes and ``Rs = −Re Z(jω)``. For ``Rs → +∞`` the loop is open
and stable (ζ > 0, passive coil), so as Rs decreases the first crossing — the largest of these
``−Re Z(jω_c)`` — is where stability is lost: ``Rs_instability``. This needs no rational
approximation, so it holds for the Bessel models (III, UD) as well.

**Exact poles (rational models I, II, NL, UL).** The characteristic polynomial
``mech·(N Cs s + D (Rs Cs s + 1)) + φ̄² Cs s² D = 0`` with ``Ze = N/D``; its roots give the pole
margin ``max Re(p)`` [1/s] for cross-checks.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as P
from scipy import optimize

from ..models import Model
from ..models.rational import rational_form

__all__ = ["instability_threshold", "closed_loop_poles", "is_rational", "wide_grid_impedance"]

RATIONAL_MODELS = ("I", "II", "NL", "UL")


def is_rational(model: Model) -> bool:
    return model.name in RATIONAL_MODELS


def wide_grid_impedance(model: Model, theta, *, decades: float = 4.0, points: int = 16000):
    """``(omega, Z(jω))`` on ``ω0·10^±decades`` [rad/s] (where loop reactance zeros are sought)."""
    omega0 = float(model.mechanics(theta)[1])
    omega = np.geomspace(omega0 * 10.0**-decades, omega0 * 10.0**decades, points)
    return omega, model.impedance_s(1j * omega, theta)


def instability_threshold(model: Model, theta, Cs: float, *, grid=None, refine: bool = True) -> float:
    """The Rs [Ω] below which the RC-shunted loop is unstable (exact crossing condition above).

    ``grid`` may pass a precomputed ``wide_grid_impedance`` result; ``refine`` polishes each
    crossing frequency with Brent's method on the exact model (otherwise linear interpolation).
    """
    omega, Z = grid if grid is not None else wide_grid_impedance(model, theta)
    X = Z.imag - 1.0 / (omega * Cs)
    idx = np.flatnonzero(np.sign(X[:-1]) != np.sign(X[1:]))
    if idx.size == 0:
        return -np.inf
    theta = np.asarray(theta, float)

    def x_exact(w):
        return float(model.impedance_s(np.array([1j * w]), theta)[0].imag - 1.0 / (w * Cs))

    best = -np.inf
    for i in idx:
        if refine:
            wc = optimize.brentq(x_exact, omega[i], omega[i + 1], xtol=1e-14 * omega[i], rtol=1e-14)
            rs = -float(model.impedance_s(np.array([1j * wc]), theta)[0].real)
        else:
            f = X[i] / (X[i] - X[i + 1])
            rs = -float(Z[i].real + f * (Z[i + 1].real - Z[i].real))
        best = max(best, rs)
    return best


def closed_loop_poles(model: Model, theta, Rs: float, Cs: float) -> np.ndarray:
    """Poles [1/s] of the RC-shunted system (rational models only)."""
    if not is_rational(model):
        raise ValueError(f"exact poles need a rational model ({', '.join(RATIONAL_MODELS)}); "
                         f"{model.name} has a Bessel term: use instability_threshold")
    zeta, omega0, phi = (float(v) for v in model.mechanics(theta))
    num, den = rational_form(model, theta)
    mech = np.array([omega0**2, 2 * zeta * omega0, 1.0])
    loop = P.polyadd(P.polymul(num, [0.0, Cs]), P.polymul(den, [1.0, Rs * Cs]))
    char = P.polyadd(P.polymul(mech, loop), P.polymul([0.0, 0.0, phi**2 * Cs], den))
    # scale s to omega0 for conditioning: roots of c(omega0 x)
    k = np.arange(char.size)
    scaled = char * omega0**k
    scaled = scaled / np.max(np.abs(scaled))
    return P.polyroots(scaled) * omega0
