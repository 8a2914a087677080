"""The Q of a transducer's mechanical resonance with a network across its terminals: the driver's
Qts (voltage drive), Qms (open terminals) and the shunted driver's Qts' (an RC shunt), per draw.

**Definition.** The shunted mechanics obey ``D(s) x = F/m`` with (eq. 50's denominator)

    D(s) = mech(s) + φ² s / (Ze(s) + Zx(s)),

``mech`` the mechanical polynomial ``s² + 2ζω0 s + ω0²`` (with the model's stiffness modifiers and
motional loads), ``φ² = (Bl)²/m``, ``Ze`` the coil's series impedance and ``Zx`` the network across
the terminals (:mod:`bayes_emt.shunt.receptance`). The network's reactance moves the resonance: it
lies at ``ω_r`` where ``Re D(jω)`` falls through zero (stiffness-controlled below, mass-controlled
above; of several such, the one with the least damping ``Im D``, the tallest peak), and

    Q = ω_r |∂ Re D/∂ω| / (2 Im D)    at ω_r,

the loaded Q from the effective damping at the resonance: for ``s² + 2ζω0 s + ω0²`` it is ``1/(2ζ)``
exactly, and the peak of the receptance is ``≈ Q/ω_r²`` (so Q and ω_r together give the peak
reduction). With ``Zx = 0`` (an amplifier: zero source impedance) and a resistive coil ``Ze = Re``,
``ω_r = ω0`` and ``1/Q = 1/Qms + 1/Qes`` with ``Qes = ω0 m Re/(Bl)²``: Small's total Q, Qts
(R. H. Small, "Direct-radiator loudspeaker system analysis", *J. Audio Eng. Soc.* 20 (1972)
383–395); a series resistor ``Zx = Rs`` then gives ``Qes' = Qes (Re + Rs)/Re``. With the coil's own
reactance (inductance, eddy currents) and with the RC shunt ``Zx = Rs + 1/(jω Cs)`` the electrical
damping is ``φ² Re{1/(Ze + Zx)}`` and the added stiffness ``−ω φ² Im{1/(Ze + Zx)}``, both at ω_r.
``Q < 1/√2``: no resonant peak; NaN where ``Re D`` does not fall through zero within ``ω0/3 .. 40 ω0``
(a negative-resistance shunt can move a loudspeaker's resonance up to 6.5 f0; below ω0/3 lie the
shunt's electrical resonances, not the driver's).
"""

from __future__ import annotations

import numpy as np

from ..models import Model
from .receptance import rc_impedance, receptance

__all__ = ["resonance_q"]

_POINTS = 1600
_LOW, _HIGH = 3.0, 40.0  # the resonance is looked for within ω0/_LOW .. _HIGH ω0
_CHUNK = 64


def resonance_q(model: Model, thetas, Zs=None, *, open_terminals: bool = False):
    """``(Q (n,), f_r [Hz] (n,))`` of each draw's mechanical resonance (module docstring) with the
    network across the terminals: ``Zs=None`` a zero-impedance source (the driver's Qts),
    ``open_terminals=True`` no current (Qms), or ``Zs=(Rs [Ω], Cs [F])`` an RC shunt (Qts')."""
    thetas = np.atleast_2d(np.asarray(thetas, float))
    n = thetas.shape[0]
    w0 = np.asarray(model.mechanics(thetas)[1], float)
    q, fr = np.full(n, np.nan), np.full(n, np.nan)
    if n == 0:
        return q, fr
    if open_terminals:
        net = None
    elif Zs is None:
        def net(s):
            return np.zeros_like(s)
    else:
        rs, cs = Zs

        def net(s):
            return rc_impedance(s, rs, cs)
    lw = np.linspace(np.log(w0.min() / _LOW), np.log(w0.max() * _HIGH), _POINTS)
    w = np.exp(lw)
    for a in range(0, n, _CHUNK):
        c = np.arange(a, min(a + _CHUNK, n))
        D = 1.0 / receptance(model, thetas[c], w, net)
        re, im = D.real, D.imag
        inside = (w[None, :-1] >= w0[c, None] / _LOW) & (w[None, 1:] <= _HIGH * w0[c, None])
        r, k = np.nonzero((re[:, :-1] > 0) & (re[:, 1:] <= 0) & inside)
        if r.size == 0:
            continue
        t = re[r, k] / (re[r, k] - re[r, k + 1])
        wr = w[k] * np.exp(t * (lw[k + 1] - lw[k]))
        imr = im[r, k] + t * (im[r, k + 1] - im[r, k])
        # per draw, the crossing with the least damping (the tallest peak)
        key = np.where(imr > 0, imr, np.inf)
        order = np.lexsort((key, r))
        first = np.r_[True, r[order][1:] != r[order][:-1]]
        pick = order[first]
        rows = c[r[pick]]
        qr, wr = _polish(model, thetas[rows], wr[pick], net)
        q[rows], fr[rows] = qr, wr / (2 * np.pi)
    return q, fr


def _polish(model, thetas, wr, net, steps: int = 3, h: float = 1e-6):
    """Newton steps on ``Re D(jω) = 0`` from the grid's ``wr``, each draw at its own frequency
    (central differences, relative step ``h``), then Q there: the grid's secant slope alone was
    off by up to half a grid step (0.15 %)."""
    m = wr.size
    k = np.arange(m)
    for it in range(steps + 1):
        om = np.concatenate([wr, wr * (1 + h), wr * (1 - h)])
        D = 1.0 / receptance(model, thetas, om, net)
        d0, dp, dm = D[k, k], D[k, m + k], D[k, 2 * m + k]
        slope = (dp.real - dm.real) / (2 * h * wr)
        if it == steps:
            break
        ok = slope < 0
        wr = np.where(ok, wr - np.where(ok, d0.real / np.where(ok, slope, -1.0), 0.0), wr)
    good = (d0.imag > 0) & (slope < 0)
    return np.where(good, wr * np.abs(slope) / (2 * np.where(good, d0.imag, 1.0)), np.nan), wr
