"""Minimum-phase estimate of an impedance's phase from its magnitude (Bode's gain-phase relation).

A moving-coil transducer's electrical impedance is a passive, minimum-phase one-port (no zeros in
the right half plane), so its phase follows from its magnitude (Bode 1945, *Network Analysis and
Feedback Amplifier Design*, ch. 14; Oppenheim & Schafer, *Discrete-Time Signal Processing*, §5.6):

    φ(ω0) = (1/π) ∫ d ln|Z| / du · ln coth(|u|/2) du,     u = ln(ω/ω0).

The slope of ln|Z| against ln ω is taken as constant on each interval between measured points,
and continued with the end slopes beyond the band; the kernel's integral has a closed form,
G(x) = ∫_0^x ln coth(t/2) dt = π²/4 − 2[Li₂(e^{−x}) − Li₂(e^{−2x})/4], so the estimate is exact
for a piecewise power law. It is used only for the start of a magnitude-only fit and to keep
such a Measurement complex; the magnitude-only likelihood never reads it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import spence

__all__ = ["minimum_phase_deg"]


def _li2(y: np.ndarray) -> np.ndarray:
    return spence(1.0 - y)


def _kernel_integral(x: np.ndarray) -> np.ndarray:
    """H(x) = sign(x) G(|x|), G as in the module docstring."""
    a = np.abs(x)
    g = math.pi**2 / 4 - 2.0 * (_li2(np.exp(-a)) - _li2(np.exp(-2.0 * a)) / 4.0)
    return np.sign(x) * g


def minimum_phase_deg(f_hz: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """Minimum-phase phase [deg] at ``f_hz`` of a curve with magnitudes ``mag`` (increasing ``f_hz``)."""
    f_hz = np.asarray(f_hz, float)
    mag = np.asarray(mag, float)
    u = np.log(f_hz)
    lm = np.log(mag)
    slopes = np.diff(lm) / np.diff(u)
    x = u[None, :] - u[:, None]  # x[i, k] = u_k - u0_i
    H = _kernel_integral(x)
    inner = (slopes[None, :] * (H[:, 1:] - H[:, :-1])).sum(axis=1)
    quarter = math.pi**2 / 4
    below = slopes[0] * (_kernel_integral(x[:, 0]) + quarter)
    above = slopes[-1] * (quarter - _kernel_integral(x[:, -1]))
    return np.degrees((inner + below + above) / math.pi)
