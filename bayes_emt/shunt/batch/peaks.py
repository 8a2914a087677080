"""Local maxima of ``|m·G_RC(jω)|`` (eq. 50) for many draws at once, with their gradients in the
shunt: the batched counterpart of :meth:`Plant.peak <bayes_emt.shunt.Plant.peak>`.

Receptances come only from :func:`~bayes_emt.shunt.receptance.receptance`, one vectorised call per
*shared* frequency grid (all draws of a call share its frequencies; a model call costs about the
same per draw for 20 frequencies as for one, so shared grids beat per-draw loops).

1. **Coarse.** ``log|m·G|`` on a shared log grid (``Δ log ω = 0.012``) spanning every draw's
   window ``[0.8 ω_lo, 1.25 ω_hi]``, with ``ω_lo, ω_hi`` the extreme loop-reactance zeros near ω0
   (:class:`~bayes_emt.shunt.batch.plant.Crossings`; the shunted peaks sit between them) or
   ``ω0/2.5 .. 2.5 ω0``; the two largest local maxima per draw, plus the binding crossing
   frequency (where the lightly damped mode of a draw close to instability peaks).
2. **Fine.** Each candidate is re-sampled at ``Δ/8`` on bands shared by the draws whose candidates
   lie close together; the maximum within ``±4`` fine points is found (a maximum on the window edge
   moves the window and repeats), and a sextic through the seven points around it (in ``log ω``)
   gives the peak: height error of order ``(Δ/w)^7`` for a peak of log-width ``w``, and its frequency
   within ``w (Δ/w)^6``. The frequency matters as much as the height: the gradients below are taken
   there, and a peak's gradient turns with frequency (the parallel_driver catalogue term: a shift of
   1e-8 in ``log ω`` turns it by 4e-7 rad, where the quartic used before placed the peak 3e-8 off and
   the equal-peak check, ``|g_lo × g_hi| < 1e-6``, failed on a converged design). A peak narrower
   than six fine points is re-sampled eight times finer.
3. **Gradients** (optional) by the envelope theorem: at a peak, ``d ln h/dp = ∂ ln|G|/∂p`` at fixed
   frequency; with ``G`` holomorphic in ``Zs``, ``∂ ln|G|/∂Zs = G'/G`` comes from one central
   difference in ``Zs`` (``±δ``, error ~(δ/|Ze + Zs|)²), and ``∂Zs/∂Rs = 1``,
   ``∂Zs/∂ log Cs = −1/(Cs s)``. They are interpolated to the peak with the same sextic.

**Below the band.** Where the band's low edge ``ω0/SPAN`` is the largest value (``wide``), the
nominal design (:meth:`Plant.local_peaks <bayes_emt.shunt.Plant.local_peaks>`) searches a 200×
wider log band below it (down to ``ω0/WIDE``); :func:`below_band` does the same for all such draws
at once: one shared coarse grid, the same refinement, the value at ``ω0/WIDE`` where the response
keeps rising towards zero frequency. (It was one scalar Brent search per draw and per evaluation:
on a loudspeaker, where the robust choice scores shunts whose response is flat down to the static
compliance, 250 of the 260 s of ``shunt --posterior``.)

A draw whose largest value lies on the edge of its coarse window is handed to the exact
:class:`~bayes_emt.shunt.Plant` (rare: a shunt far from any sensible tuning).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..receptance import Plant, rc_impedance, receptance
from .plant import SPAN, BatchPlant, Crossings

__all__ = ["PeakBatch", "rc_peaks_batch", "band_edge", "below_band", "grid_value", "SLOTS"]

COARSE = 0.012  # Δ log ω of the coarse grid
FINE = COARSE / 8
_HALF = 4  # half-width of the search window, in grid steps
_MAX_BAND = 240  # grid steps per shared band before it is split
_UNION = 400  # bands evaluated in one model call for every draw while their union is this short
_SHARP = 40  # a peak narrower than this many fine steps (log-width) is resampled 8 times finer
# sextic through t = -3..3: coefficients = _VINV @ values
_STENCIL = 3
_VINV = np.linalg.inv(np.vander(np.arange(-3.0, 4.0), 7, increasing=True))
#: log-frequency step of the nominal design's grid (:class:`Plant`: 2600 points over ω0/40 .. 40 ω0)
_PLANT_STEP = float(np.log(SPAN * SPAN) / 2599)
_DIAG_CHUNK = 64  # draws per model call when each draw has its own frequency
WIDE = 8000.0  # the wide search reaches ω0/WIDE, as Plant._wide_peak does
SLOTS = 4  # peak slots of a search from scratch: two coarse maxima, the binding crossing, the low edge


def grid_value(bp, rows, omega, Rs, Cs):
    """``ln|m·G|`` at the nominal design's grid point nearest ``omega`` (per draw) and its two
    neighbours, the largest of the three: the value :meth:`Plant.local_peaks` compares a band edge
    with before it searches below the band."""
    m = rows.size
    out = np.full(m, np.nan)
    lo = np.log(bp.omega0[rows] / SPAN)
    k = np.rint((np.log(omega) - lo) / _PLANT_STEP)
    for a in range(0, m, _DIAG_CHUNK):
        c = np.arange(a, min(a + _DIAG_CHUNK, m))
        om = np.concatenate([np.exp(lo[c] + (k[c] + j) * _PLANT_STEP) for j in (-1, 0, 1)])
        f, _ = _log_receptance(bp, rows[c], om, Rs[c], Cs[c])
        i = np.arange(c.size)
        out[c] = np.max(np.stack([f[i, j * c.size + i] for j in range(3)]), axis=0)
    return out


def band_edge(bp, rows, Rs, Cs, delta=None):
    """The low end of each draw's band, ``ω0/SPAN``, where the nominal design's grid starts:
    ``(ln|m·G| there, whether it exceeds its inward grid neighbour, gradient or None)``.

    The nominal design (:meth:`Plant.local_peaks`) counts a band edge where ``|m·G|`` falls inward as
    a peak; a loudspeaker's optimal shunt (Cs of farads) makes that edge one of its two equal
    peaks, so the batched design must see it too (each draw at its own ω0, one model call per
    :data:`_DIAG_CHUNK` draws).
    """
    m = rows.size
    f_e, f_n = np.full(m, np.nan), np.full(m, np.nan)
    g_e = np.full((m, 2), np.nan) if delta is not None else None
    for a in range(0, m, _DIAG_CHUNK):
        c = np.arange(a, min(a + _DIAG_CHUNK, m))
        we = bp.omega0[rows[c]] / SPAN
        om = np.concatenate([we, we * np.exp(_PLANT_STEP)])
        f, g = _log_receptance(bp, rows[c], om, Rs[c], Cs[c], delta)
        k = np.arange(c.size)
        f_e[c], f_n[c] = f[k, k], f[k, c.size + k]
        if g is not None:
            g_e[c] = g[k, k]
    return f_e, f_e > f_n, g_e


def below_band(bp, rows, Rs, Cs, delta=None):
    """The largest value of ``|m·G|`` on ``ω0/WIDE .. ω0/SPAN`` (and the local maximum it leads to,
    which may lie just above ``ω0/SPAN``), per draw ``rows``: ``(ln h, ω [rad/s], gradient or None,
    ok)``, the batched :meth:`Plant._wide_peak <bayes_emt.shunt.Plant.local_peaks>` (module
    docstring). ``Rs``, ``Cs`` are per row of ``rows``."""
    m = rows.size
    w0 = bp.omega0[rows]
    lo, hi = np.log(w0 / WIDE), np.log(w0 / SPAN)
    x = np.arange(lo.min(), hi.max() + 2 * COARSE, COARSE)
    f, _ = _log_receptance(bp, rows, np.exp(x), Rs, Cs)
    inside = (x[None, :] >= lo[:, None]) & (x[None, :] <= hi[:, None] + COARSE)
    f = np.where(inside, f, -np.inf)
    j = np.argmax(f, axis=1)
    first = np.argmax(inside, axis=1)
    x_out, v_out = np.full(m, np.nan), np.full(m, np.nan)
    g_out = np.full((m, 2), np.nan) if delta is not None else None
    ok = np.zeros(m, bool)
    # rising towards zero frequency: the value at ω0/WIDE (where Plant's wide grid starts)
    low = j == first
    if low.any():
        k = np.flatnonzero(low)
        fl, _, gl = band_edge_at(bp, rows[k], w0[k] / WIDE, Rs[k], Cs[k], delta)
        x_out[k], v_out[k], ok[k] = lo[k], fl, True
        if g_out is not None:
            g_out[k] = gl
    k = np.flatnonzero(~low)
    if k.size:
        xs, vs, gs, oks = _refine(_Rows(bp, rows), k, x[j[k]], Rs, Cs, FINE, delta)
        x_out[k], v_out[k], ok[k] = xs, vs, oks
        if g_out is not None:
            g_out[k] = gs
    return v_out, np.exp(x_out), g_out, ok & np.isfinite(v_out)


def band_edge_at(bp, rows, omega, Rs, Cs, delta=None):
    """``ln|m·G|`` (and its gradient) of draw ``rows[i]`` at its own ``omega[i]`` [rad/s]:
    ``(value (m,), None, gradient (m, 2) or None)``."""
    m = rows.size
    out = np.full(m, np.nan)
    g_out = np.full((m, 2), np.nan) if delta is not None else None
    for a in range(0, m, _DIAG_CHUNK):
        c = np.arange(a, min(a + _DIAG_CHUNK, m))
        f, g = _log_receptance(bp, rows[c], omega[c], Rs[c], Cs[c], delta)
        k = np.arange(c.size)
        out[c] = f[k, k]
        if g is not None:
            g_out[c] = g[k, k]
    return out, None, g_out


class _Rows:
    """Draws ``rows`` of a plant, re-indexed ``0..m-1`` (what :func:`_refine` indexes)."""

    def __init__(self, bp, rows):
        self.model, self.thetas, self.omega0 = bp.model, bp.thetas[rows], bp.omega0[rows]


@dataclass(frozen=True)
class _View:
    """The draws of a :class:`BatchPlant` a call works on (without its threshold cache)."""

    model: object
    thetas: np.ndarray
    omega0: np.ndarray
    R0: np.ndarray


@dataclass(frozen=True)
class PeakBatch:
    """Local maxima of ``|m·G|`` per draw and candidate slot.

    Attributes
    ----------
    value : ``(m, K)`` peak heights [s²] (mass-normalised; NaN where a slot found nothing).
    omega : ``(m, K)`` where [rad/s].
    grad : ``(m, K, 2)`` ``d ln h / d(Rs [Ω], ln Cs)`` at each peak, or None.
    exact : ``(m,)`` whether the draw was handed to the exact :class:`Plant` search.
    """

    value: np.ndarray
    omega: np.ndarray
    grad: np.ndarray | None
    exact: np.ndarray

    @property
    def hinf(self) -> np.ndarray:
        """``(m,)`` the H∞ norm: the largest peak [s²]."""
        return np.nanmax(self.value, axis=1)


def _zs(Rs, Cs, s):
    return rc_impedance(s[None, :], Rs[:, None], Cs[:, None])


def _log_receptance(bp: BatchPlant, rows, omega, Rs, Cs, delta=None):
    """``ln|m·G|`` ``(r, F)`` of draws ``rows`` on the shared ``omega``; with ``delta`` also
    ``∂ ln|G|/∂(Rs, ln Cs)`` ``(r, F, 2)`` (module docstring)."""
    s = 1j * omega
    zs = _zs(Rs, Cs, s)
    th = bp.thetas[rows]
    if delta is None:
        return np.log(np.abs(receptance(bp.model, th, omega, lambda _s: zs))), None
    F = omega.size
    ext = np.concatenate([zs, zs + delta, zs - delta], axis=1)
    g = receptance(bp.model, th, np.tile(omega, 3), lambda _s: ext)
    G, Gp, Gm = g[:, :F], g[:, F : 2 * F], g[:, 2 * F :]
    dlog = (Gp - Gm) / (2 * delta) / G  # d ln G / d Zs
    grad = np.stack([dlog.real, (dlog * (-1.0 / (Cs[:, None] * s[None, :]))).real], axis=-1)
    return np.log(np.abs(G)), grad


def _poly(a, t, d=0):
    """The ``d``-th derivative at ``t`` of the polynomials with coefficients ``a (n, k)`` (increasing)."""
    k = a.shape[1]
    out = np.zeros_like(t)
    for j in range(k - 1, d - 1, -1):
        c = math.perm(j, d)
        out = out * t + c * a[:, j]
    return out


def _sextic_max(y7):
    """Maximum of the sextic through ``y7 (n, 7)`` at ``t = -3..3``: ``(t*, value, p''(t*))``."""
    a = y7 @ _VINV.T
    c = _STENCIL
    den = y7[:, c - 1] - 2 * y7[:, c] + y7[:, c + 1]
    t = np.where(den < 0, 0.5 * (y7[:, c - 1] - y7[:, c + 1]) / np.where(den < 0, den, -1.0), 0.0)
    t = np.clip(t, -1.0, 1.0)
    for _ in range(8):
        d1, d2 = _poly(a, t, 1), _poly(a, t, 2)
        t = np.clip(t - np.where(d2 < 0, d1 / np.where(d2 < 0, d2, -1.0), 0.0), -1.5, 1.5)
    return t, _poly(a, t), _poly(a, t, 2)


def _bands(centres, step):
    """Group job indices whose centres fit one shared band (a gap of more than a window, or a band
    longer than ``_MAX_BAND`` steps, starts a new group)."""
    order = np.argsort(centres)
    c = centres[order]
    group = np.r_[0, np.cumsum(np.diff(c) > 4 * _HALF * step)]
    out = []
    for g in np.split(np.arange(c.size), np.flatnonzero(np.diff(group)) + 1):
        part = np.floor((c[g] - c[g[0]]) / (_MAX_BAND * step)).astype(int)
        out.extend(order[g][part == k] for k in np.unique(part))
    return out


def _band_values(bp, rows, todo, c, Rs, Cs, step, delta):
    """``(jobs, x0, x, ln|G|, grad)`` per shared band of the jobs ``todo`` (centres ``c``); one
    model call on the union of the bands when that is short, else one call per band."""
    bands = []
    for grp in _bands(c[todo], step):
        jobs = todo[grp]
        lo = c[jobs].min() - (_HALF + 2) * step
        k = int(np.ceil((c[jobs].max() + (_HALF + 2) * step - lo) / step)) + 1
        bands.append((jobs, lo, lo + step * np.arange(k)))
    if sum(b[2].size for b in bands) <= _UNION:
        ur = np.unique(rows[todo])
        f_all, g_all = _log_receptance(bp, ur, np.exp(np.concatenate([b[2] for b in bands])), Rs[ur], Cs[ur],
                                       delta)
        off = 0
        for jobs, lo, x in bands:
            pos = np.searchsorted(ur, rows[jobs])
            sl = slice(off, off + x.size)
            off += x.size
            yield jobs, lo, x, f_all[pos, sl], None if g_all is None else g_all[pos, sl]
        return
    for jobs, lo, x in bands:
        ur, inv = np.unique(rows[jobs], return_inverse=True)
        f, g = _log_receptance(bp, ur, np.exp(x), Rs[ur], Cs[ur], delta)
        yield jobs, lo, x, f[inv], None if g is None else g[inv]


def _refine(bp, rows, centres, Rs, Cs, step, delta, follow=None):
    """Refine one candidate per job (``rows[j]``, log-frequency ``centres[j]``) at spacing ``step``;
    a job with ``follow[j]`` moves its window up to 7 times after a maximum on its edge, the others
    give up. Returns ``(x*, ln h, grad or None, ok)``; ``ok`` False where the search did not settle."""
    n = rows.size
    follow = np.ones(n, bool) if follow is None else follow
    x_out, v_out = np.full(n, np.nan), np.full(n, np.nan)
    g_out = np.full((n, 2), np.nan) if delta is not None else None
    ok = np.zeros(n, bool)
    todo = np.arange(n)
    c = centres.copy()
    for _ in range(8):
        if todo.size == 0:
            break
        again = []
        for jobs, lo, x, f, g in _band_values(bp, rows, todo, c, Rs, Cs, step, delta):
            jc = np.rint((c[jobs] - lo) / step).astype(int)
            win = jc[:, None] + np.arange(-_HALF, _HALF + 1)
            jm = win[np.arange(jobs.size), np.argmax(np.take_along_axis(f, win, 1), axis=1)]
            edge = np.abs(jm - jc) == _HALF
            again.extend(jobs[edge & follow[jobs]])
            c[jobs[edge]] = x[jm[edge]]
            sel = ~edge
            seven = jm[sel, None] + np.arange(-_STENCIL, _STENCIL + 1)
            t, val, d2 = _sextic_max(np.take_along_axis(f[sel], seven, 1))
            j = jobs[sel]
            x_out[j], v_out[j] = x[jm[sel]] + t * step, val
            ok[j] = d2 < 0
            sharp = (d2 < 0) & (-d2 > 1.0 / _SHARP**2)  # narrower than _SHARP steps: resample finer
            if g is not None:
                w = np.vander(t, 2 * _STENCIL + 1, increasing=True) @ _VINV
                for q in range(2):
                    g_out[j, q] = np.sum(w * np.take_along_axis(g[sel][..., q], seven, 1), axis=1)
            if sharp.any() and step > FINE / 100:
                jj = j[sharp]
                xs, vs, gs, oks = _refine(bp, rows[jj], x_out[jj], Rs, Cs, step / 8, delta, follow[jj])
                x_out[jj], v_out[jj], ok[jj] = xs, vs, oks
                if g_out is not None:
                    g_out[jj] = gs
        todo = np.asarray(again, int)
    return x_out, v_out, g_out, ok


def _coarse(bp, rows, Rs, Cs, cross: Crossings, full: bool = False, from_edge=None):
    """Candidate centres ``(m, 3)`` in ``log ω`` and the rows whose maximum left the window; the
    window spans the crossings (module docstring), or with ``full`` the whole band
    ``ω0/SPAN .. SPAN ω0`` (``cross`` then gives the binding crossing only). ``from_edge`` (m,): rows
    whose window starts at the band's low edge ``ω0/SPAN`` instead (where the edge is a peak: the
    response between it and the crossings is flat and may hold a peak of its own)."""
    w0 = bp.omega0[rows]
    if full:
        lo, hi = np.log(w0 / SPAN), np.log(w0 * SPAN)
    else:
        lo = np.where(np.isfinite(cross.omega_min), cross.omega_min * 0.8, w0 / 2.5)
        hi = np.where(np.isfinite(cross.omega_max), cross.omega_max * 1.25, w0 * 2.5)
        if from_edge is not None:
            lo = np.where(from_edge, w0 / SPAN, lo)
        lo, hi = np.log(np.maximum(lo, w0 / SPAN)), np.log(np.minimum(hi, w0 * SPAN))
    x = np.arange(lo.min() - COARSE, hi.max() + 2 * COARSE, COARSE)
    f, _ = _log_receptance(bp, rows, np.exp(x), Rs, Cs)
    f = np.where((x[None, :] >= lo[:, None]) & (x[None, :] <= hi[:, None]), f, -np.inf)
    inner = ((f[:, 1:-1] >= f[:, :-2]) & (f[:, 1:-1] >= f[:, 2:]) & np.isfinite(f[:, :-2])
             & np.isfinite(f[:, 2:]))
    vals = np.where(inner, f[:, 1:-1], -np.inf)
    m = rows.size
    first = np.argmax(vals, axis=1)
    second = np.argmax(np.where(np.arange(vals.shape[1]) == first[:, None], -np.inf, vals), axis=1)
    top = np.stack([first, second], axis=1)
    cent = np.full((m, 3), np.nan)
    for k in range(2):
        j = top[:, k]
        found = np.isfinite(vals[np.arange(m), j])
        cent[found, k] = x[j[found] + 1]
    lwc = np.log(cross.omega_c)
    cent[:, 2] = np.where((lwc > lo) & (lwc < hi), lwc, np.nan)
    gmax = np.max(f, axis=1)
    best_inner = np.max(vals, axis=1)
    escaped = ~(best_inner >= gmax)  # the largest value sits on the window's edge
    at_low = escaped & (np.argmax(f, axis=1) == np.argmax(np.isfinite(f), axis=1))  # ... its low edge
    return cent, escaped, at_low


def _exact_rows(bp, rows, Rs, Cs, delta, out_v, out_w, out_g, where):
    for i in where:
        r = rows[i]
        zs = lambda s, i=i: rc_impedance(s, Rs[i], Cs[i])  # noqa: E731
        # as many peaks as the caller has slots (K = 2 when it passes known centres, 3 otherwise): a
        # model with a second mechanical mode or creep can show more (it was an IndexError)
        pk = sorted(Plant(bp.model, bp.thetas[r]).local_peaks(zs), key=lambda p: -p.value)[: out_v.shape[1]]
        out_v[i] = np.nan
        out_w[i] = np.nan
        for k, p in enumerate(pk):
            out_v[i, k], out_w[i, k] = p.value, p.omega
        if out_g is not None:
            w = out_w[i, np.isfinite(out_w[i])]
            _, g = _log_receptance(bp, np.array([r]), w, Rs[i : i + 1], Cs[i : i + 1], delta)
            out_g[i] = np.nan
            out_g[i, : w.size] = g[0]


def rc_peaks_batch(bp: BatchPlant, Rs, Cs, idx=None, *, gradients: bool = False,
                   centres=None, crossings: Crossings | None = None, wide: bool = True) -> PeakBatch:
    """Local maxima of ``|m·G|`` for the RC shunt(s) ``(Rs [Ω], Cs [F])`` on draws ``idx``.

    Parameters
    ----------
    bp : the draws. Rs, Cs : one shunt for all draws, or one per draw (arrays ``(m,)``).
    idx : draws to evaluate (default all). gradients : also ``d ln h/d(Rs, ln Cs)``.
    centres : ``(m, K)`` known peak frequencies [rad/s] (skips the coarse search: for small
        changes of the shunt, as in finite differences). crossings : reuse thresholds for ``Cs``.
    wide : where the band's low edge is the largest value, search below the band as the nominal
        design does (exact, one draw at a time); False: keep the edge's value (Newton iterates).
    """
    rows = np.arange(bp.n) if idx is None else np.asarray(idx)
    m = rows.size
    Rs = np.array(np.broadcast_to(np.asarray(Rs, float), (m,)))
    Cs = np.array(np.broadcast_to(np.asarray(Cs, float), (m,)))
    local = np.arange(m)
    sub = bp if idx is None else _View(bp.model, bp.thetas[rows], bp.omega0[rows], bp.R0[rows])
    escaped = np.zeros(m, bool)
    delta = 1e-6 * float(np.median(sub.R0)) if gradients else None
    # the low band edge where |m·G| falls inward (a peak of the nominal design's grid): its own slot
    # below, and where it is one the coarse window reaches down to it: the nominal design's grid sees
    # every local maximum between the edge and the crossings, and an edge-balanced optimum can have
    # one there (ScanSpeak 18W diagnosed posterior: a third equal peak near 99 rad/s, below the
    # window's 0.8 ω_lo, for 30 % of the draws; the batch never saw it and its Newton cycled)
    fe, is_peak, ge = band_edge(sub, local, Rs, Cs, delta)
    if centres is None:
        cross = crossings if crossings is not None else bp.crossings(Cs, idx, Rs=Rs)
        cent, escaped, _ = _coarse(sub, local, Rs, Cs, cross, from_edge=is_peak)
        if escaped.any():
            # the largest value left the window around the crossings (a shunt that flattens the
            # resonance: the response falls from the band's low edge): look over the whole band,
            # as Plant.local_peaks does; a maximum on its low edge is the edge slot's below
            e = np.flatnonzero(escaped)
            ce = Crossings(*(np.asarray(a)[e] for a in (cross.threshold, cross.omega_c, cross.omega_min,
                                                        cross.omega_max, cross.upper)))
            cent[e], esc_e, low_e = _coarse(_Rows(sub, e), np.arange(e.size), Rs[e], Cs[e], ce, full=True)
            escaped[e] = esc_e & ~low_e
    else:
        cent = np.log(np.asarray(centres, float))
        # a known peak at the band edge is the edge itself (refining would walk out of the band)
        cent = np.where(np.abs(cent - np.log(sub.omega0 / SPAN)[:, None]) < 1e-9, np.nan, cent)
    K = cent.shape[1]
    value, omega = np.full((m, K), np.nan), np.full((m, K), np.nan)
    grad = np.full((m, K, 2), np.nan) if gradients else None
    # slots 0, 1: the coarse maxima, followed wherever they lead; slot 2 (the binding crossing):
    # only a peak right there counts, so its window does not move
    jr, jk = np.nonzero(np.isfinite(cent) & ~escaped[:, None])
    x, v, g, ok = _refine(sub, jr, cent[jr, jk], Rs, Cs, FINE, delta, jk < 2)
    good = ok & np.isfinite(v)
    value[jr[good], jk[good]], omega[jr[good], jk[good]] = np.exp(v[good]), np.exp(x[good])
    if gradients:
        grad[jr[good], jk[good]] = g[good]
    failed = np.zeros(m, bool)
    failed[jr[~good & (jk < 2)]] = True
    failed |= escaped
    # last slot: the low band edge where |m·G| falls inward (computed above)
    failed |= ~(np.isfinite(value).any(axis=1) | is_peak)
    value = np.concatenate([value, np.where(is_peak, np.exp(fe), np.nan)[:, None]], axis=1)
    omega = np.concatenate([omega, np.where(is_peak, sub.omega0 / SPAN, np.nan)[:, None]], axis=1)
    if gradients:
        grad = np.concatenate([grad, np.where(is_peak[:, None], ge, np.nan)[:, None]], axis=1)
    # the edge the largest value: the nominal design searches below the band (Plant.local_peaks);
    # the batch does the same search for all such draws at once, into the edge's slot
    if wide:
        below = np.flatnonzero(is_peak & ~failed & ~(np.exp(fe) < np.nanmax(
            np.where(np.isfinite(value[:, :-1]), value[:, :-1], 0.0), axis=1, initial=0.0)))
        if below.size:
            vb, wb, gb, okb = below_band(sub, below, Rs[below], Cs[below], delta)
            value[below, -1], omega[below, -1] = np.exp(vb), wb
            if gradients:
                grad[below, -1] = gb
            failed[below[~okb]] = True
    _exact_rows(sub, local, Rs, Cs, delta, value, omega, grad, np.flatnonzero(failed))
    return PeakBatch(value, omega, grad, failed)
