"""The H∞-optimal RC shunt of every draw at once: Newton's method on the equal-peak conditions.

At an equal-peak optimum of ``min_x max(ln h_lo(x), ln h_hi(x))`` over ``x = (Rs, ln Cs)``
(``h_lo``, ``h_hi`` the two peaks of ``|m·G|`` below and above the anti-resonance, eq. 50) the two
heights are equal and no direction lowers both: their gradients are anti-parallel. Per draw this
is two equations in two unknowns,

    F1 = ln h_lo − ln h_hi = 0,    F2 = ∠(g_lo, −g_hi) = 0

(``F2`` the angle between ``g_lo`` and ``−g_hi``, :func:`_opposition`: near the root the normalised
cross product ``(g_lo × g_hi)/(|g_lo| |g_hi|)``, which the final check asks below 1e-6 together with
``g_lo · g_hi < 0``, but zero only where the gradients are opposite, not where two peaks merge; with
the band's edge as the lower peak the cross product itself, see :func:`_f2`),
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

from ..design import rc_optimum
from .peaks import PeakBatch, grid_value, rc_peaks_batch
from .plant import SPAN, BatchPlant


def terminal_impedance_series(model, s, thetas):
    """``Ze(s)`` [Ω], the series (blocked) impedance the design's coil equivalent is read from."""
    return model.electrical_impedance_s(s, thetas)

__all__ = ["DrawOptima", "design_draws", "cs_bound"]

_H_RS, _H_LCS = 1e-6, 1e-6
_TOL = 1e-10
#: a step below this, relative (Rs against ``|Rs| + R0``; ln Cs as it is), also ends a draw's
#: iteration: the equal-peak residuals are known to ~1e-12 in ``F1`` and ~1e-9 in ``F2`` (quartic peak
#: heights, a central difference in Zs), so near the root the finite-difference Jacobian turns that
#: noise into steps of ~1e-8 relative that never fall below :data:`_TOL` (measured on the GRS 12SW
#: woofer's UD+semi_inductance+suspension_creep+second_resonance posterior: 31 of 40 draws cycled at
#: |dRs| 1e-9 .. 6e-8 Ω with |F1| < 5e-12 after 25 iterations and fell back, though at the solution);
#: a step of 1e-7 relative is 10 times below the 1e-6 the tests compare the designs to
_TOL_REL = 1e-7
#: Rs step [Ω] of a draw whose only peak is the band's edge (see :func:`design_draws`)
_LONE_STEP = 0.02
#: the Newton step in Rs is cut to this [Ω], the cut doubling (up to _RS_STEP_MAX) while successive
#: steps are cut in the same direction
_RS_STEP, _RS_STEP_MAX = 0.02, 0.64


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


_EDGE_GAP = 1e-9


def _edge_first(pb, lnw, rows, bp):
    """Whether the lower peak of each pair is the band's low edge ``ω0/SPAN``."""
    return np.abs(lnw[:, 0] - np.log(bp.omega0[rows] / SPAN)) < 1e-9


#: a third distinct peak within this (in ln h) of the highest makes a draw a three-peak candidate
#: (fresh LS10-44 added-mass posterior, 1000 draws: 0.01 -> 65 fallbacks, 0.03 -> 29, 0.1 -> 29; draws
#: 1-2 % below the vertex cycled between pairs with the edge just outside 0.01)
_TRI_TOL = 0.03
#: hull weights above -_LAM_TOL take the three-peak step (weights from gradients away from the vertex
#: carry an error of this order: LS10-44 added-mass draw 45, -0.0005 for the highest peak where the
#: vertex's own weight is +0.002); below it the peak is dropped (:func:`_active_pair`). The final
#: check asks for weights >= 0 at the vertex itself
_LAM_TOL = 0.01


def _three_peaks(pb: PeakBatch):
    """The three highest distinct peaks per draw (the band edge's slot included), highest first:
    ``(lnh (m, 3), lnw (m, 3), grad (m, 3, 2), ok (m,))``."""
    v = np.where(np.isfinite(pb.value), pb.value, 0.0)
    m, K = v.shape
    rows = np.arange(m)
    with np.errstate(divide="ignore", invalid="ignore"):
        lw = np.log(np.where(v > 0, pb.omega, np.nan))
    order = np.argsort(-v, axis=1)
    sel, cnt = np.zeros((m, 3), int), np.zeros(m, int)
    for k in range(K):
        j = order[:, k]
        dup = np.zeros(m, bool)
        for q in range(3):
            dup |= (q < cnt) & (np.abs(lw[rows, j] - lw[rows, sel[:, q]]) < 1e-4)
        take = (v[rows, j] > 0) & ~dup & (cnt < 3)
        sel[take, cnt[take]] = j[take]
        cnt[take] += 1
    ok = cnt == 3
    r = rows[:, None]
    lnh = np.log(np.where(ok[:, None], v[r, sel], 1.0))
    lnw = np.where(ok[:, None], lw[r, sel], 0.0)
    g = pb.grad[r, sel] if pb.grad is not None else None
    return lnh, lnw, g, ok


def _hull_weights(g):
    """``λ (m, 3)`` with ``Σ λ_k g_k = 0``, ``Σ λ_k = 1`` (NaN where the gradients are degenerate):
    zero lies in the convex hull of the three peaks' gradients when every ``λ_k ≥ 0``, the
    optimality condition of ``min max(h1, h2, h3)`` at a point where all three are equal."""
    m = g.shape[0]
    A = np.ones((m, 3, 3))
    A[:, :2, :] = np.swapaxes(g, 1, 2)
    det = np.linalg.det(A)
    fine = np.isfinite(det) & (np.abs(det) > 1e-300)
    lam = np.full((m, 3), np.nan)
    if fine.any():
        b = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (int(fine.sum()), 3))
        lam[fine] = np.linalg.solve(A[fine], b[..., None])[..., 0]
    return lam


def _active_pair(pb: PeakBatch, skip=None, tol=None):
    """The pair of peaks the two-peak step and check use: the two highest (:func:`_two_peaks`), except
    where a third distinct peak lies within :data:`_TRI_TOL` of the highest and the three gradients'
    hull weights (:func:`_hull_weights`) are not all above ``-_LAM_TOL``: there the peak with the most
    negative weight is dropped (its height falls along the direction that lowers the other two, so the
    optimum is the other pair's; LS10-44 added-mass: the edge and the upper resonance peak, the
    lower one 4e-7 above the edge at the start of the step). ``skip`` (m,): draws to leave as the
    two highest; ``tol`` (m,) the weight below ``-tol`` that drops a peak (default :data:`_LAM_TOL`).
    Returns :func:`_two_peaks`'s tuple, then ``(l3, w3, g3, ok3, lam, near)``."""
    lnh, lnw, g, ok = _two_peaks(pb)
    l3, w3, g3, ok3 = _three_peaks(pb)
    near = ok3 & (l3[:, 0] - l3[:, 2] < _TRI_TOL)
    if skip is not None:
        near &= ~skip
    lam = np.full((near.size, 3), np.nan)
    k = np.flatnonzero(near)
    if k.size and g3 is not None:
        lam[k] = _hull_weights(g3[k])
        t = np.full(near.size, _LAM_TOL) if tol is None else np.broadcast_to(tol, near.shape)
        drop = k[np.isfinite(lam[k]).all(axis=1) & (lam[k] < -t[k, None]).any(axis=1)]
        if drop.size:
            out = np.argmin(lam[drop], axis=1)
            keep = np.array([[1, 2], [0, 2], [0, 1]])[out]
            r = drop[:, None]
            order = np.argsort(w3[r, keep], axis=1)  # by frequency, as _two_peaks orders its pair
            keep = np.take_along_axis(keep, order, axis=1)
            lnh[drop], lnw[drop], g[drop] = l3[r, keep], w3[r, keep], g3[r, keep]
            ok[drop] = True
    return lnh, lnw, g, ok, l3, w3, g3, ok3, lam, near


def _three_residuals(bp, rows, rs, cs, lnh, lnw, g):
    """The two equations of a three-equal-peak optimum and their Jacobian in ``(Rs, ln Cs)``:
    ``(F (m, 2), J (m, 2, 2))``. Three true peaks: ``ln h1 − ln h2`` and ``ln h1 − ln h3``. With the
    band's low edge among them: the other two equal, and the edge :data:`_EDGE_GAP` below the larger
    of their values on the nominal design's grid (as :func:`_balance`: the nominal design's norm jumps
    where the edge passes that value). Jacobian from the peaks' envelope-theorem gradients (for the
    edge row the grid value's gradient is taken as its peak's)."""
    m = rows.size
    F, J = np.empty((m, 2)), np.empty((m, 2, 2))
    F[:, 0], F[:, 1] = lnh[:, 0] - lnh[:, 1], lnh[:, 0] - lnh[:, 2]
    J[:, 0], J[:, 1] = g[:, 0] - g[:, 1], g[:, 0] - g[:, 2]
    edge = np.abs(lnw - np.log(bp.omega0[rows] / SPAN)[:, None]) < 1e-9
    e = np.flatnonzero(edge.any(axis=1))
    if e.size:
        ke = np.argmax(edge[e], axis=1)
        others = np.array([[1, 2], [0, 2], [0, 1]])[ke]
        q, r = others[:, 0], others[:, 1]
        gq = grid_value(bp, rows[e], np.exp(lnw[e, q]), rs[e], cs[e])
        gr = grid_value(bp, rows[e], np.exp(lnw[e, r]), rs[e], cs[e])
        top = np.where(gq >= gr, q, r)
        F[e, 0] = lnh[e, q] - lnh[e, r]
        J[e, 0] = g[e, q] - g[e, r]
        F[e, 1] = lnh[e, ke] - np.maximum(gq, gr) + _EDGE_GAP
        J[e, 1] = g[e, ke] - g[e, top]
    return F, J


def _balance(bp, rows, rs, cs, lnh, lnw):
    """``F1``: the two peaks' log-height difference; where the lower one is the band's edge, the
    edge against the other peak's value on the nominal design's grid, less :data:`_EDGE_GAP` (the
    nominal design's norm jumps where the edge passes that grid value, and its optimum sits just
    before the jump)."""
    F1 = lnh[:, 0] - lnh[:, 1]
    e = np.flatnonzero(_edge_first(None, lnw, rows, bp))
    if e.size:
        gv = grid_value(bp, rows[e], np.exp(lnw[e, 1]), rs[e], cs[e])
        F1[e] = lnh[e, 0] - gv + _EDGE_GAP
    return F1


def _cross(g):
    lo, hi = g[:, 0], g[:, 1]
    num = lo[:, 0] * hi[:, 1] - lo[:, 1] * hi[:, 0]
    return num / (np.linalg.norm(lo, axis=1) * np.linalg.norm(hi, axis=1))


def _opposition(g):
    """``F2`` of the Newton step: the angle [rad] between ``g_lo`` and ``−g_hi``, in ``(−π, π]``.

    Near the optimum it equals the normalised cross product :func:`_cross` up to its sign and terms
    of third order (the same root, the same Newton steps there), but it vanishes only where the two
    gradients are opposite: the cross product also vanishes where they are parallel, which is where
    two peaks merge into one, and Newton from a start with ``g_lo · g_hi > 0`` was drawn there (the
    parallel_driver catalogue term: 6 of 20 draws stepped onto a single merged peak and fell back)."""
    lo, hi = g[:, 0], g[:, 1]
    cross = lo[:, 0] * hi[:, 1] - lo[:, 1] * hi[:, 0]
    dot = lo[:, 0] * hi[:, 0] + lo[:, 1] * hi[:, 1]
    return np.arctan2(-cross, -dot)


def _f2(g, edge):
    """``F2`` per draw: :func:`_opposition` for two true peaks; the normalised cross product where the
    lower one is the band's edge, whose optimum may have the two gradients pointing the same way (the
    edge's multiplier above 1: see the final check in :func:`design_draws`)."""
    return np.where(edge, _cross(g), _opposition(g))


def _f2_at(bp, idx, Rs, Cs, lnw):
    """``F2`` of the pair at ``lnw`` (the same two peaks, followed from their frequencies: slots 0 and
    1, or the band edge's slot where the lower one is the edge), after a small change of the shunt."""
    pb = rc_peaks_batch(bp, Rs, Cs, idx, gradients=True, centres=np.exp(lnw), wide=False)
    e = _edge_first(None, lnw, np.asarray(idx), bp)
    g = pb.grad[:, :2].copy()
    g[e, 0] = pb.grad[e, -1]
    v = pb.value[:, :2].copy()
    v[e, 0] = pb.value[e, -1]
    ok = np.isfinite(g).all(axis=(1, 2)) & np.isfinite(v).all(axis=1) & (v > 0).all(axis=1)
    x = np.flatnonzero(pb.exact)  # slots filled by the exact search (by height): the two highest
    if x.size:
        _, _, gx, okx = _two_peaks(pb)
        g[x], ok[x] = gx[x], okx[x]
    return _f2(g, e), ok


#: Rs of a design on the stability boundary: this far above the threshold, relative to
#: ``max(|threshold|, R0)`` (the one-at-a-time design ends within ~1e-15 Ω of it)
_BOUNDARY_GAP = 1e-9
_H_THR = 1e-6  # ln Cs step of the threshold's finite difference


def _boundary_state(bp, idx, u):
    """Rs on the stability boundary for ``ln Cs = u`` and the single peak there: ``(Rs, D, g, ok)``
    with ``D = d ln h/d ln Cs`` along the boundary (``∂/∂ ln Cs + ∂/∂Rs · d threshold/d ln Cs``)."""
    cs = np.exp(u)
    thr = bp.threshold(cs, idx)
    thr2 = bp.threshold(cs * math.exp(_H_THR), idx)
    rs = thr + _BOUNDARY_GAP * np.maximum(np.abs(thr), bp.R0[idx])
    pb = rc_peaks_batch(bp, rs, cs, idx, gradients=True, wide=False)
    v = np.where(np.isfinite(pb.value), pb.value, 0.0)
    j = np.argmax(v, axis=1)
    rows = np.arange(idx.size)
    g = pb.grad[rows, j]
    one = (np.count_nonzero(v > 0, axis=1) == 1) & np.isfinite(thr) & np.isfinite(thr2)
    D = g[:, 1] + g[:, 0] * (thr2 - thr) / _H_THR
    return rs, D, g, one & np.isfinite(D)


def _on_boundary(bp, idx, u0, max_iter=30):
    """Single-peak draws ``idx`` whose optimum lies on the stability boundary (a winding capacitance
    makes the ideal loop unstable for any negative Rs: threshold 0 at every Cs): Rs on the boundary,
    ``ln Cs`` by secant steps on ``D = 0`` (:func:`_boundary_state`). Returns ``(Rs, ln Cs, ok)``;
    ``ok``: converged to one peak with ``D ≈ 0`` and ``∂ ln h/∂Rs > 0`` (the peak would fall only
    through the boundary: the Karush–Kuhn–Tucker conditions of ``Rs ≥ threshold``)."""
    u = u0.copy()
    rs, D, g, ok = _boundary_state(bp, idx, u)
    du = -np.sign(D) * 0.01
    live = ok.copy()
    for _ in range(max_iter):
        if not live.any():
            break
        k = np.flatnonzero(live)
        u_new = u[k] + du[k]
        rs_k, D_k, g_k, ok_k = _boundary_state(bp, idx[k], u_new)
        den = D_k - D[k]
        step = np.where(den != 0, -D_k * du[k] / np.where(den != 0, den, 1.0), 0.0)
        step = np.clip(step, -0.1, 0.1)
        u[k], D[k], rs[k], g[k], ok[k] = u_new, D_k, rs_k, g_k, ok_k
        du[k] = step
        live[k] = ok_k & (np.abs(step) > 1e-10)
    fine = ok & ~live & (g[:, 0] > 0) & (np.abs(D) <= 1e-6 * np.linalg.norm(g, axis=1))
    return rs, u, fine


def _at_corner(bp, idx, u):
    """Draws ``idx`` whose optimum is the corner of both bounds: ``ln Cs = u`` (its upper bound) and
    Rs on the stability boundary. Returns ``(Rs, ok)``; ``ok``: one peak is the highest (the next
    more than 1e-9 lower in ln h) and its gradient ``g`` meets the Karush–Kuhn–Tucker conditions of
    ``Rs ≥ threshold(ln Cs)``, ``ln Cs ≤ u``: ``g = (μ1, −μ1·d threshold/d ln Cs − μ2)`` with both
    multipliers ``≥ 0`` (lowering Rs or raising Cs, the only ways down, leave the admissible set).
    Measured on the LS10-44 free-air NL(3)+second_resonance+winding_capacitance posterior (threshold
    0 at every Cs): 50 of 100 draws had their equal-peak Rs on the Cs bound below 0 and fell back to
    the one-at-a-time design, which ends at this corner (Rs ~1e-13 Ω, Cs on its bound)."""
    cs = np.exp(u)
    thr = bp.threshold(cs, idx)
    thr2 = bp.threshold(cs * math.exp(_H_THR), idx)
    rs = thr + _BOUNDARY_GAP * np.maximum(np.abs(thr), bp.R0[idx])
    pb = rc_peaks_batch(bp, rs, cs, idx, gradients=True)
    v = np.where(np.isfinite(pb.value) & (pb.value > 0), pb.value, 0.0)
    rows = np.arange(idx.size)
    order = np.argsort(-v, axis=1)
    top, nxt = order[:, 0], order[:, 1]
    lv = np.log(np.where(v > 0, v, np.nan))
    gap = lv[rows, top] - np.where(v[rows, nxt] > 0, lv[rows, nxt], -np.inf)
    g = pb.grad[rows, top]
    mu1 = g[:, 0]
    mu2 = -g[:, 1] - g[:, 0] * (thr2 - thr) / _H_THR
    ok = (np.isfinite(thr) & np.isfinite(thr2) & (v[rows, top] > 0) & (gap > 1e-9)
          & np.isfinite(g).all(axis=1) & (mu1 >= 0) & (mu2 >= 0))
    return rs, ok


def _place(bp, k, rs, u, Rs, lcs, Cs, margin, fine, pb: PeakBatch) -> PeakBatch:
    """Draws ``k`` moved to ``Rs = rs``, ``ln Cs = u`` (in place in ``Rs``, ``lcs``, ``Cs``,
    ``margin``, ``fine``: accepted where stable); returns the peaks with theirs replaced."""
    if not k.size:
        return pb
    Rs[k], lcs[k] = rs, u
    Cs[k] = np.exp(lcs[k])
    pk = rc_peaks_batch(bp, Rs[k], Cs[k], k)
    margin[k] = bp.margin(Rs[k], Cs[k], k)
    pb = PeakBatch(pb.value.copy(), pb.omega.copy(), pb.grad, pb.exact)
    pb.value[k], pb.omega[k] = pk.value, pk.omega
    fine[k] = margin[k] > 0
    return pb


def cs_bound(bp: BatchPlant) -> np.ndarray:
    """``(n,)`` each draw's upper bound on ``ln Cs``, as :func:`design_rc_shunt` sets it:
    ``Cs_max = 1e3/(L_eq ω0²)`` with ``L_eq = Im(Ze(jω0) − R0)/ω0`` (one model call per chunk)."""
    out = np.empty(bp.n)
    for a in range(0, bp.n, 64):
        c = np.arange(a, min(a + 64, bp.n))
        w0 = bp.omega0[c]
        z = terminal_impedance_series(bp.model, 1j * w0, bp.thetas[c])
        k = np.arange(c.size)
        L = np.maximum((z[k, k] - bp.R0[c]).imag / w0, 1e-300)
        out[c] = np.log(1e3 / (L * w0**2))
    return out


def design_draws(bp: BatchPlant, start: tuple[float, float], *, R0_start: float | None = None,
                 max_iter: int = 40, progress=None) -> DrawOptima:
    """Each draw's H∞-optimal RC shunt (module docstring).

    Parameters
    ----------
    bp : the draws. start : the warm start ``(Rs [Ω], Cs [F])`` (the nominal design).
    R0_start : the R0 [Ω] the start was designed for; each draw then starts from
        ``Rs + R0_start − R0`` (default: ``Rs`` as given).
    max_iter : Newton iterations before a draw is handed to :func:`design_rc_shunt`.
    progress : optional ``callable(done, total)`` told as draws settle and as the fallback proceeds.

    Where the start sits at the upper bound of Cs (:func:`cs_bound`; a loudspeaker: weak coupling,
    Cs of farads, the optimum a near pure negative resistance), the draw is solved on that bound:
    ``F1 = 0`` in Rs alone (the two peaks equal, their Rs-gradients opposite, and a larger Cs would
    lower both: the Karush–Kuhn–Tucker conditions of the bounded min-max problem). A Newton step that
    crosses the bound also lands the draw on it.
    """
    n = bp.n
    Rs = np.full(n, float(start[0]))
    if R0_start is not None:
        Rs = Rs + (R0_start - bp.R0)
    lmax = cs_bound(bp)
    lcs = np.minimum(np.full(n, math.log(start[1])), lmax)
    bound = lcs >= lmax - 1e-6
    lcs[bound] = lmax[bound]
    active = np.arange(n)
    radius, last_sign = np.full(n, _RS_STEP), np.zeros(n)
    three = np.zeros(n, bool)  # the last step taken was a three-peak one
    was_cut = np.zeros(n, bool)  # the last step was cut to the radius
    strict = np.zeros(n, bool)  # hull weights judged against 0 (see below)
    iters = 0
    while active.size and iters < max_iter:
        iters += 1
        was_three = three[active].copy()
        three[active] = False
        rs, cs = Rs[active], np.exp(lcs[active])
        pb = rc_peaks_batch(bp, rs, cs, active, gradients=True, wide=False)
        tol = np.where(strict[active], 0.0, _LAM_TOL)
        lnh, lnw, g, ok, l3, w3, g3, ok3, lam3, near3 = _active_pair(pb, skip=bound[active], tol=tol)
        # a three-peak step that landed where a weight is clearly negative (below -_LAM_TOL) aimed at a
        # vertex that is no optimum: the optimum is a pair beside it, and the draw goes on with weights
        # judged strictly (ScanSpeak 18W diagnosed posterior: weights -0.002 and -0.0105 at the two ends
        # of the step, and the pair's step went back: 4 of 200 draws cycled so until max_iter)
        overshot = was_three & near3 & (lam3 < -tol[:, None]).any(axis=1) & ~strict[active]
        if overshot.any():
            strict[active[overshot]] = True
            tol = np.where(strict[active], 0.0, _LAM_TOL)
            lnh, lnw, g, ok, l3, w3, g3, ok3, lam3, near3 = _active_pair(pb, skip=bound[active], tol=tol)
        # a pair with the band's low edge (:func:`~bayes_emt.shunt.batch.peaks.band_edge`) is solved
        # to the edge lying _EDGE_GAP below the other peak: the nominal design's norm jumps where the
        # edge becomes the largest value (its peak search then goes below the band), and its
        # optimum sits on the side before that jump
        F1 = _balance(bp, active, rs, cs, lnh, lnw)
        b = bound[active]
        J00 = g[:, 0, 0] - g[:, 1, 0]
        dR, dU = np.zeros(active.size), np.zeros(active.size)
        good = ok.copy()
        # on the bound: F1 = 0 in Rs alone
        gb = good & b & np.isfinite(J00) & (J00 != 0)
        dR[gb] = -F1[gb] / J00[gb]
        good[b] = gb[b]
        free = np.flatnonzero(~b & ok)
        if free.size:
            sub = active[free]
            F2 = _f2(g[free], _edge_first(None, lnw[free], sub, bp))
            f2r, okr = _f2_at(bp, sub, rs[free] + _H_RS, cs[free], lnw[free])
            f2u, oku = _f2_at(bp, sub, rs[free], cs[free] * math.exp(_H_LCS), lnw[free])
            J = np.empty((free.size, 2, 2))
            J[:, 0] = g[free, 0] - g[free, 1]
            J[:, 1, 0], J[:, 1, 1] = (f2r - F2) / _H_RS, (f2u - F2) / _H_LCS
            det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
            gf = okr & oku & np.isfinite(det) & (det != 0)
            d = np.where(gf, det, 1.0)
            f1 = F1[free]
            dR[free] = np.where(gf, -(J[:, 1, 1] * f1 - J[:, 0, 1] * F2) / d, 0.0)
            dU[free] = np.where(gf, -(-J[:, 1, 0] * f1 + J[:, 0, 0] * F2) / d, 0.0)
            good[free] = gf
        # three equal peaks (two design variables: the generic min-max optimum has three active
        # peaks): where a third distinct peak lies within _TRI_TOL of the highest and zero lies in the
        # convex hull of the three gradients, Newton on the two height differences (no finite
        # differences). The two-peak step alternated there between the pair and the single peak a
        # step in ln Cs of ~0.06 merges it into (LS10-44 added-mass NL(2)+second_resonance+
        # suspension_creep: 97 of 100 draws fell back)
        tri = np.flatnonzero(near3 & (lam3 > -tol[:, None]).all(axis=1))
        if tri.size:
            F3, J3 = _three_residuals(bp, active[tri], rs[tri], cs[tri], l3[tri], w3[tri], g3[tri])
            det3 = J3[:, 0, 0] * J3[:, 1, 1] - J3[:, 0, 1] * J3[:, 1, 0]
            g3ok = np.isfinite(det3) & (det3 != 0) & np.isfinite(F3).all(axis=1)
            tri, F3, J3, det3 = tri[g3ok], F3[g3ok], J3[g3ok], det3[g3ok]
            dR[tri] = -(J3[:, 1, 1] * F3[:, 0] - J3[:, 0, 1] * F3[:, 1]) / det3
            dU[tri] = -(-J3[:, 1, 0] * F3[:, 0] + J3[:, 0, 0] * F3[:, 1]) / det3
            good[tri] = True
            three[active[tri]] = True
        # the band's edge the only peak (the resonance flattened, |m·G| falling from the edge): the
        # start damps too much for this draw, and the second peak of an edge-balanced optimum grows
        # with Rs (LS10-44 NL(4)+winding_capacitance: 8 of 100 draws started there and fell back)
        lone = ~ok & np.isfinite(pb.value[:, -1]) & ~np.isfinite(pb.value[:, :-1]).any(axis=1)
        dR[lone], dU[lone], good[lone] = _LONE_STEP, 0.0, True
        # trust region in Rs: _RS_STEP, doubled while the steps keep being cut in the same direction
        # (SEAS E0018 NL(5)+suspension_creep+winding_capacitance: draws 0.5 ohm from the start walked
        # 0.02 ohm per iteration and ran out of iterations, Newton asking -0.56 .. -0.07 ohm all the way)
        # A cut step that reverses a cut step is an oscillation between two sides of a kink (a peak
        # that exists on one side only: LS10-44 added-mass NL(2)+second_resonance+suspension_creep,
        # where the two resonance peaks of the three-peak optimum coexist only within ~0.01 ohm and
        # the iterate jumped +-0.02 ohm between the two single-peak sides for 25 iterations): the
        # radius halves until the iterate lands where both exist
        rad = radius[active]
        sgn = np.sign(dR)
        cut = np.abs(dR) > rad
        grow = cut & (sgn == last_sign[active])
        same = sgn == last_sign[active]
        swing = cut & (sgn == -last_sign[active]) & was_cut[active]
        rad = np.where(grow, np.minimum(2 * rad, _RS_STEP_MAX),
                       np.where(same, rad, np.where(swing, 0.5 * np.minimum(rad, _RS_STEP), _RS_STEP)))
        radius[active], last_sign[active], was_cut[active] = rad, sgn, cut
        scale = np.minimum(1.0, np.minimum(rad / np.maximum(np.abs(dR), 1e-300),
                                           0.1 / np.maximum(np.abs(dU), 1e-300)))
        ag = active[good]
        Rs[ag] += (scale * dR)[good]
        lcs[ag] += (scale * dU)[good]
        hit = ag[lcs[ag] > lmax[ag]]
        lcs[hit], bound[hit] = lmax[hit], True
        small = (np.abs(dR) < np.maximum(_TOL, _TOL_REL * (np.abs(Rs[active]) + np.abs(bp.R0[active])))) & \
            (np.abs(dU) < np.maximum(_TOL, _TOL_REL))
        done = good & small
        # a three-peak step settled at a vertex where one weight is slightly negative (above -_LAM_TOL):
        # the optimum is the pair without that peak, right beside the vertex; the draw goes on with
        # weights judged strictly (fresh LS10-44 added-mass posterior: -7e-4 on 5 % of the draws)
        vert = done & three[active] & ~strict[active] & near3 & (lam3 < 0).any(axis=1)
        strict[active[vert]] = True
        done &= ~vert
        active = active[~done & good]
        if progress is not None:
            progress(n - active.size, n)
    Cs = np.exp(lcs)
    pb = rc_peaks_batch(bp, Rs, Cs, gradients=True)
    lnh, lnw, g, ok, l3, w3, g3, ok3, lam3, near3 = _active_pair(pb, skip=bound, tol=0.0)
    margin = bp.margin(Rs, Cs)
    equal = np.abs(_balance(bp, np.arange(n), Rs, Cs, lnh, lnw)) < 1e-7
    # the pair is the norm: a peak :func:`_active_pair` left out (a negative hull weight) lies below it.
    # Without this a pair's stationary point with the dropped peak above it passes (seen on draws of the
    # LS10-44 added-mass NL(4)+second_resonance+suspension_creep posterior with variants of the Newton
    # step: the dropped peak 0.1 % and 2 % above the pair, 0.01 and 0.17 dB short of the draw's optimum)
    with np.errstate(divide="ignore", invalid="ignore"):
        equal &= np.max(lnh, axis=1) >= np.log(pb.hinf) - 1e-7
    edge = _edge_first(None, lnw, np.arange(n), bp)
    # the weight λ on the lower peak's gradient that cancels the Rs-components:
    # λ g_lo + (1 − λ) g_hi has zero Rs-gradient
    gr_lo, gr_hi = g[:, 0, 0], g[:, 1, 0]
    lam = np.where(gr_hi != gr_lo, gr_hi / np.where(gr_hi != gr_lo, gr_hi - gr_lo, 1.0), np.nan)
    # two true peaks (min of their max): λ in [0, 1], i.e. opposite gradients. The band's edge and a
    # peak: the nominal design's norm is the peak's height while the edge stays below it and jumps
    # (to the search below the band) past that, so the problem is min h_hi subject to
    # h_edge − h_hi ≤ 0, whose multiplier is λ ≥ 0 alone (measured on the LS10-44
    # NL(4)+winding_capacitance posterior: ∂/∂Rs of the edge +5.6e-5, of the peak +2.3e-2, λ 1.0025; the
    # opposite-sign test sent every such draw to the one-at-a-time design, which lands on the same
    # Rs within 7e-9 relative)
    weight_ok = np.where(edge, lam >= 0, gr_lo * gr_hi < 0)
    interior = ok & ~bound & equal & (np.abs(_cross(g)) < 1e-6) & np.where(
        edge, weight_ok, np.einsum("ij,ij->i", g[:, 0], g[:, 1]) < 0)
    # on the bound: the combination with zero Rs-gradient falls with Cs
    kkt = weight_ok & (lam * g[:, 0, 1] + (1 - lam) * g[:, 1, 1] < 0)
    on_bound = ok & bound & equal & kkt
    # three equal peaks: both equations met and zero in the convex hull of the three gradients
    tri = np.flatnonzero(near3 & ~(interior | on_bound))
    if tri.size:
        F3, _ = _three_residuals(bp, tri, Rs[tri], Cs[tri], l3[tri], w3[tri], g3[tri])
        triple = (np.abs(F3) < 1e-7).all(axis=1) & (lam3[tri] >= 0).all(axis=1)
        interior[tri[triple]] = True
    fine = (interior | on_bound) & (margin > 0)
    fine[active] = False
    # a single peak held down by the stability boundary (the ideal loop with a winding capacitance)
    v = np.where(np.isfinite(pb.value), pb.value, 0.0)
    single = np.flatnonzero(~fine & ~bound & (np.count_nonzero(v > 0, axis=1) == 1))
    if single.size:
        rs_b, u_b, ok_b = _on_boundary(bp, single, lcs[single].copy())
        pb = _place(bp, single[ok_b], rs_b[ok_b], u_b[ok_b], Rs, lcs, Cs, margin, fine, pb)
    # both bounds active: Cs at its upper bound and Rs on the stability boundary (the equal-peak Rs on
    # the Cs bound lies on the unstable side)
    corner = np.flatnonzero(~fine & bound & (margin <= 0))
    if corner.size:
        rs_c, ok_c = _at_corner(bp, corner, lmax[corner])
        pb = _place(bp, corner[ok_c], rs_c[ok_c], lmax[corner[ok_c]], Rs, lcs, Cs, margin, fine, pb)
    att = 20 * np.log10(pb.hinf / bp.open_peak)
    fallback = ~fine
    todo = np.flatnonzero(fallback)
    # the one-at-a-time search without its report (:func:`rc_optimum`: the design's Rs, Cs, attenuation
    # and margin, which is all the batch keeps); a draw repeated in the posterior (an MCMC chain
    # stays put on a rejected step) with the same start is the same problem and is solved once
    # (LS10-44 added-mass NL(4)+second_resonance+suspension_creep: 3 of its 8 fallbacks one vector)
    solved: dict = {}
    for k, i in enumerate(todo):
        x0 = (float(Rs[i]) if np.isfinite(Rs[i]) else start[0],
              float(Cs[i]) if np.isfinite(Cs[i]) else start[1])
        key = (bp.thetas[i].tobytes(), x0)
        if key not in solved:
            solved[key] = rc_optimum(bp.model, bp.thetas[i], start=x0)
        d = solved[key]
        Rs[i], Cs[i], att[i], margin[i] = d.Rs, d.Cs, d.attenuation_db, d.stability_margin
        if progress is not None:
            progress(n - todo.size + k + 1, n)
    return DrawOptima(Rs, Cs, att, margin, fallback, iters)
