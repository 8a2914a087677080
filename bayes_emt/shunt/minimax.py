"""The last polish of the one-at-a-time RC shunt design: the min–max over the peaks solved as a
smooth problem (epigraph form) by sequential quadratic programming.

The H∞ norm ``max_k h_k(Rs, Cs)`` over the local maxima ``h_k`` of ``|m·G_RC(jω)|`` (eq. 50) is not
differentiable where two or more peaks are equal, which is where its minimum usually lies: two equal
peaks (Den Hartog's condition), or, with two design variables, three (the generic vertex of a
two-variable min–max problem: two resonance peaks and the low end of the design band on a
loudspeaker with creep and a second mode). Nelder–Mead stops within its simplex tolerance of such a
point, and its stopping point moves with the start (on the LS10-44 added-mass posterior: 0.02 Ω
and 1.5e-4 dB off on one draw of twenty). In epigraph form,

    minimise t over (Rs, u = ln Cs, t)   subject to   ln h_k(Rs, u) ≤ t  for every peak near the top,
                                                      ln g_edge ≤ ln g_peak − gap,  u ≤ u_max,

every function is smooth: each ``h_k`` is its peak followed within its own window of ``log ω`` (a
bounded Brent search on the exact model, as :meth:`Plant.local_peaks` refines), and the edge row
keeps the band's low end ``ω0/40`` below the largest interior maximum on the design's grid, the
value past which :meth:`Plant.peak` leaves the band (the norm jumps there; ``gap`` 1e-9). SLSQP
(Kraft 1988) with central-difference gradients identifies the active peaks itself and converges
superlinearly to the KKT point: zero in the convex hull of the active gradients. The result is
kept only when it is admissible (stable by the grid threshold, Cs within its bound) and its exact
H∞ norm is not above the start's.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from .receptance import Plant, rc_impedance
from .stability import instability_threshold

__all__ = ["minimax_polish"]

#: peaks within this (in ln h) of the highest enter the problem
_NEAR = 0.05
#: the edge row's margin below the largest interior grid maximum, in ln h (the batched design's
#: ``_EDGE_GAP``)
EDGE_GAP = 1e-9
_H = 1e-7  # central-difference step: Rs relative to |Rs| + R0, ln Cs absolute
#: how far below its start the polish may take Cs (a factor): it refines an optimum already found
POLISH_CS_RANGE = 1e3


def _peak_in(plant: Plant, rs: float, lcs: float, lo: float, hi: float) -> float:
    """``ln max |m·G|`` over ``log ω ∈ [lo, hi]``, around the window's best of nine points (the
    plant's cached splines, ~1e-12 relative; the result is judged on the exact model)."""
    zs = lambda s: rc_impedance(s, rs, math.exp(lcs))  # noqa: E731
    x = np.linspace(lo, hi, 9)
    g = np.abs(plant.receptance(np.exp(x), zs, exact=False))
    i = int(np.argmax(g))
    a, b = x[max(i - 1, 0)], x[min(i + 1, x.size - 1)]

    neg = plant._scalar_neg(plant._spline, 0.0, zs)
    r = optimize.minimize_scalar(neg, bounds=(a, b), method="bounded", options={"xatol": 1e-11})
    return math.log(max(-float(r.fun), float(g[i])))


def _grid_top(plant: Plant, rs: float, lcs: float) -> tuple[float, float]:
    """``(ln |m·G| at the band's low edge, ln of the largest interior grid maximum)``."""
    g = plant.grid_magnitude(lambda s: rc_impedance(s, rs, math.exp(lcs)))
    inner = (g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])
    top = float(np.max(g[1:-1][inner])) if inner.any() else float(np.max(g[1:]))
    return math.log(float(g[0])), math.log(top)


def _finish(val_jac, x, n_pk: int, use_edge: bool, lcs_max: float, n_iter: int = 8, near: float = 1e-6):
    """SLSQP ends within its tolerance of the active constraints, and a vertex whose edge row is
    violated by 5e-8 is past the jump of the norm (measured on an LS10-44 two-mode draw): Newton on the
    active rows (peaks within 1e-6 of the highest made equal, the edge row zero where it is below
    1e-6, ln Cs held where it is on its bound), the least-norm step where they are fewer than the
    free variables. From the start itself every row within ``near`` (the problem's :data:`_NEAR`)
    counts: the vertex of all of them."""
    at_bound = x[1] >= lcs_max - 1e-12
    for _ in range(n_iter):
        f, J = val_jac(x)
        lnh = -f[:n_pk]
        act = np.flatnonzero(lnh > lnh.max() - near)
        ref = act[np.argmax(lnh[act])]
        eqs = [(lnh[k] - lnh[ref], J[ref] - J[k]) for k in act if k != ref]
        if use_edge and f[-1] < near:
            eqs.append((f[-1], J[-1]))
        if not eqs:
            break
        E = np.array([e for e, _ in eqs])
        A = np.array([a for _, a in eqs])
        if at_bound:
            A[:, 1] = 0.0
        step = -np.linalg.lstsq(A, E, rcond=None)[0]
        if at_bound:
            step[1] = 0.0
        x = x + step
        if np.all(np.abs(E) < 1e-13):
            break
    return x


def minimax_polish(plant: Plant, model, theta, grid, rs: float, lcs: float, lcs_max: float, info: dict,
                   bandwidth=None) -> tuple[float, float]:
    """``(Rs, ln Cs)`` polished by SQP (module docstring), or the start where that does not help."""
    zs0 = lambda s: rc_impedance(s, rs, math.exp(lcs))  # noqa: E731
    peaks = plant.local_peaks(zs0)
    edge_w = float(plant.omega[0])
    inner = sorted((p for p in peaks if abs(math.log(p.omega / edge_w)) > 1e-9), key=lambda p: p.omega)
    if not inner:
        return rs, lcs
    top = max(math.log(p.value) for p in peaks)
    near = sum(math.log(p.value) > top - 1e-3 for p in peaks)
    e0, gtop = _grid_top(plant, rs, lcs)
    use_edge = e0 >= top - _NEAR
    if "polish" not in info and near < 3 and not e0 >= top - 1e-3:
        return rs, lcs  # the equal-peak polish solved it (two interior peaks), or one smooth peak
    lw = [math.log(p.omega) for p in inner]
    wins = []
    for k, p in enumerate(inner):
        if math.log(p.value) < top - _NEAR:
            continue
        band = (math.log(plant.omega[0]), math.log(plant.omega[-1]))
        lo = max(lw[k] - 0.2, 0.5 * (lw[k - 1] + lw[k]) if k else -math.inf, band[0])
        hi = min(lw[k] + 0.2, 0.5 * (lw[k] + lw[k + 1]) if k + 1 < len(lw) else math.inf, band[1])
        wins.append((lo, hi))
    hr = _H * (abs(rs) + plant.R0)
    steps = np.array([hr, _H])

    def rows(x):
        """The constraint rows ``c(x) ≥ 0`` without t: ``(−ln h_k ..., edge row)``."""
        out = [-_peak_in(plant, x[0], x[1], lo, hi) for lo, hi in wins]
        if use_edge:
            e, gt = _grid_top(plant, x[0], x[1])
            out.append(gt - EDGE_GAP - e)
        return np.array(out)

    cache: dict = {}

    def val_jac(x):
        key = (float(x[0]), float(x[1]))
        if key not in cache:
            f = rows(x[:2])
            J = np.empty((f.size, 2))
            for q in range(2):
                d = np.zeros(2)
                d[q] = steps[q]
                J[:, q] = (rows(x[:2] + d) - rows(x[:2] - d)) / (2 * steps[q])
            cache.clear()
            cache[key] = (f, J)
        return cache[key]

    n_pk = len(wins)

    def cons(x):
        f, _ = val_jac(x)
        out = f.copy()
        out[:n_pk] += x[2]
        return out

    def cons_jac(x):
        _, J = val_jac(x)
        out = np.zeros((J.shape[0], 3))
        out[:, :2] = J
        out[:n_pk, 2] = 1.0
        return out

    x0 = np.array([rs, min(lcs, lcs_max), top])
    # a polish stays near its start: Cs at most POLISH_CS_RANGE times smaller (without a floor a trial
    # step reached ln Cs = -1330, where Cs underflows to 0 and the RC shunt is numerically 1/0)
    lcs_lo = float(x0[1]) - math.log(POLISH_CS_RANGE)
    try:
        r = optimize.minimize(lambda x: x[2], x0, jac=lambda x: np.array([0.0, 0.0, 1.0]), method="SLSQP",
                              constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
                              bounds=[(None, None), (lcs_lo, lcs_max), (None, None)],
                              options={"ftol": 1e-15, "maxiter": 60})
    except (ValueError, ArithmeticError) as exc:  # a window or a threshold without a value
        info["minimax_polish"] = f"not used ({exc})"
        return rs, lcs
    before = plant.peak(zs0).value
    best, why = None, "its point is past the stability threshold"
    # SLSQP's point finished by Newton; failing that (a jump past the edge, a point past the
    # threshold), Newton on the active rows from the start itself (an LS10-44 two-mode draw: SLSQP
    # left the region where the edge is below the peak, Newton from the start reached the vertex)
    starts = ((np.array([r.x[0], min(r.x[1], lcs_max)]), 1e-6), (np.array([rs, min(lcs, lcs_max)]), _NEAR))
    for x, near in starts:
        x = _finish(val_jac, x, n_pk, use_edge, lcs_max, near=near)
        rs1, lcs1 = float(x[0]), float(x[1])
        if not (math.isfinite(rs1) and math.isfinite(lcs1) and lcs1 >= lcs_lo):
            continue
        if rs1 <= instability_threshold(model, theta, math.exp(lcs1), grid=grid, refine=False,
                                        bandwidth=bandwidth):
            continue
        after = plant.peak(lambda s, rs1=rs1, lcs1=lcs1: rc_impedance(s, rs1, math.exp(lcs1))).value
        if after <= before * (1 + 1e-12):
            best = (rs1, lcs1, after)
            break
        why = f"its H-inf peak {after:.10g} is above the start's {before:.10g}"
    if best is None:
        info["minimax_polish"] = f"not used ({why})"
        return rs, lcs
    rs1, lcs1, after = best
    info["minimax_polish"] = (f"SLSQP on {n_pk} peak(s)" + (" and the band's low edge" if use_edge else "")
                              + f", {r.nit} iterations, then Newton on the active rows; peak "
                              f"{before:.10g} -> {after:.10g}")
    return rs1, lcs1
