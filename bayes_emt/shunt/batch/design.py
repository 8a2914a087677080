"""The H∞-optimal RC shunt of every draw at once: Newton's method on the equal-peak conditions.

At an equal-peak optimum of ``min_x max(ln h_lo(x), ln h_hi(x))`` over ``x = (Rs, ln Cs)``
(``h_lo``, ``h_hi`` the two peaks of ``|m·G|`` below and above the anti-resonance, eq. 50) the two
heights are equal and no direction lowers both: their gradients are anti-parallel. Per draw this
is two equations in two unknowns,

    F1 = ln h_lo − ln h_hi = 0,    F2 = (g_lo × g_hi) / (|g_lo| |g_hi|) = 0,   g_lo · g_hi < 0,

solved for all draws together by Newton's method: heights and gradients from
:func:`~bayes_emt.shunt.batch.peaks.rc_peaks_batch` (envelope-theorem gradients), ``∂F1/∂x =
g_lo − g_hi`` exactly and ``∂F2/∂x`` by forward differences (steps 1e-6 Ω and 1e-6 in ln Cs; an
approximate Jacobian only slows Newton down, the solution is set by F). Draws start from a
warm start (the nominal design, its Rs shifted by the draw's R0 offset so that ``R0 + Rs`` is kept)
and leave the iteration once a step is below 1e-10 (Ω and ln Cs). A draw that does not converge,
whose optimum is not an equal-peak one (``g_lo · g_hi ≥ 0``, or one peak only) or is unstable is
designed by :func:`~bayes_emt.shunt.design_rc_shunt` instead, and counted.

Exactness is checked against :func:`~bayes_emt.shunt.design_rc_shunt` in the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import design_rc_shunt
from .peaks import PeakBatch, rc_peaks_batch
from .plant import BatchPlant

__all__ = ["DrawOptima", "design_draws"]

_H_RS, _H_LCS = 1e-6, 1e-6
_TOL = 1e-10


@dataclass(frozen=True)
class DrawOptima:
    """Each draw's own H∞-optimal RC shunt.

    Attributes
    ----------
    Rs, Cs : ``(n,)`` [Ω], [F]. attenuation_db : ``(n,)`` ``20 log10(‖G_RC‖∞/‖G_open‖∞)`` [dB].
    margin : ``(n,)`` ``Rs − Rs_instability`` at the draw's own design [Ω].
    fallback : ``(n,)`` designed by :func:`design_rc_shunt` rather than the batched Newton.
    iterations : Newton iterations used (the slowest draw).
    """

    Rs: np.ndarray
    Cs: np.ndarray
    attenuation_db: np.ndarray
    margin: np.ndarray
    fallback: np.ndarray
    iterations: int


def _two_peaks(pb: PeakBatch):
    """The two highest distinct peaks per draw, ordered by frequency:
    ``(lnh (m, 2), lnw (m, 2), grad (m, 2, 2), ok (m,))``."""
    v = np.where(np.isfinite(pb.value), pb.value, 0.0)
    w = np.where(np.isfinite(pb.omega), pb.omega, np.nan)
    m = v.shape[0]
    rows = np.arange(m)
    a = np.argmax(v, axis=1)
    dup = np.abs(np.log(w) - np.log(w[rows, a])[:, None]) < 1e-4
    b = np.argmax(np.where(dup | ~np.isfinite(w), 0.0, v), axis=1)
    ok = (v[rows, a] > 0) & (v[rows, b] > 0) & ~dup[rows, b]
    pair = np.stack([a, b], axis=1)
    swap = w[rows, b] < w[rows, a]
    pair[swap] = pair[swap][:, ::-1]
    lnh = np.log(np.where(ok[:, None], v[rows[:, None], pair], 1.0))
    lnw = np.log(np.where(ok[:, None], w[rows[:, None], pair], 1.0))
    g = pb.grad[rows[:, None], pair] if pb.grad is not None else None
    return lnh, lnw, g, ok


def _cross(g):
    lo, hi = g[:, 0], g[:, 1]
    num = lo[:, 0] * hi[:, 1] - lo[:, 1] * hi[:, 0]
    return num / (np.linalg.norm(lo, axis=1) * np.linalg.norm(hi, axis=1))


def _f2_at(bp, idx, Rs, Cs, lnw):
    pb = rc_peaks_batch(bp, Rs, Cs, idx, gradients=True, centres=np.exp(lnw))
    lnh, _, g, ok = _two_peaks(pb)
    return _cross(g), ok


def design_draws(bp: BatchPlant, start: tuple[float, float], *, R0_start: float | None = None,
                 max_iter: int = 25) -> DrawOptima:
    """Each draw's H∞-optimal RC shunt (module docstring).

    Parameters
    ----------
    bp : the draws. start : the warm start ``(Rs [Ω], Cs [F])`` (the nominal design).
    R0_start : the R0 [Ω] the start was designed for; each draw then starts from
        ``Rs + R0_start − R0`` (default: ``Rs`` as given).
    max_iter : Newton iterations before a draw is handed to :func:`design_rc_shunt`.
    """
    n = bp.n
    Rs = np.full(n, float(start[0]))
    if R0_start is not None:
        Rs = Rs + (R0_start - bp.R0)
    lcs = np.full(n, math.log(start[1]))
    active = np.arange(n)
    iters = 0
    while active.size and iters < max_iter:
        iters += 1
        rs, cs = Rs[active], np.exp(lcs[active])
        pb = rc_peaks_batch(bp, rs, cs, active, gradients=True)
        lnh, lnw, g, ok = _two_peaks(pb)
        F1, F2 = lnh[:, 0] - lnh[:, 1], _cross(g)
        f2r, okr = _f2_at(bp, active, rs + _H_RS, cs, lnw)
        f2u, oku = _f2_at(bp, active, rs, cs * math.exp(_H_LCS), lnw)
        J = np.empty((active.size, 2, 2))
        J[:, 0] = g[:, 0] - g[:, 1]
        J[:, 1, 0], J[:, 1, 1] = (f2r - F2) / _H_RS, (f2u - F2) / _H_LCS
        det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        good = ok & okr & oku & np.isfinite(det) & (det != 0)
        d = np.where(good, det, 1.0)
        dR = -(J[:, 1, 1] * F1 - J[:, 0, 1] * F2) / d
        dU = -(-J[:, 1, 0] * F1 + J[:, 0, 0] * F2) / d
        scale = np.minimum(1.0, np.minimum(0.02 / np.maximum(np.abs(dR), 1e-300),
                                           0.1 / np.maximum(np.abs(dU), 1e-300)))
        Rs[active[good]] += (scale * dR)[good]
        lcs[active[good]] += (scale * dU)[good]
        done = good & (np.abs(dR) < _TOL) & (np.abs(dU) < _TOL)
        active = active[~done & good]
    Cs = np.exp(lcs)
    pb = rc_peaks_batch(bp, Rs, Cs, gradients=True)
    lnh, _, g, ok = _two_peaks(pb)
    margin = bp.margin(Rs, Cs)
    anti = np.einsum("ij,ij->i", g[:, 0], g[:, 1]) < 0
    fine = ok & anti & (np.abs(lnh[:, 0] - lnh[:, 1]) < 1e-7) & (np.abs(_cross(g)) < 1e-6) & (margin > 0)
    fine[active] = False
    att = 20 * np.log10(pb.hinf / bp.open_peak)
    fallback = ~fine
    for i in np.flatnonzero(fallback):
        d = design_rc_shunt(bp.model, bp.thetas[i], start=(float(Rs[i]) if np.isfinite(Rs[i]) else start[0],
                                                            float(Cs[i]) if np.isfinite(Cs[i]) else start[1]))
        Rs[i], Cs[i], att[i], margin[i] = d.Rs, d.Cs, d.attenuation_db, d.stability_margin
    return DrawOptima(Rs, Cs, att, margin, fallback, iters)
