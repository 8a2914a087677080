"""Shunted receptance (eq. 50, generalised to every device term) and its H∞ norm.

    G(s) = (1/m) / (mech(s) + φ̄² s / (Ze(s) + Zx(s)))                                      (50)

with the model's loop view (:meth:`~bayes_emt.models.Model.loop`): ``mech`` the mechanical polynomial
``s² + 2ζω0 s + ω0²`` with every stiffness modifier (creep) and motional load (a vented box) of the
model, ``Ze`` the device's series impedance besides the primary motional branch (``Zc + R0`` and any
other mode or lead), and ``Zx`` the external network across the terminals: the shunt ``Zs`` in
parallel with the device's own parallel admittance ``Yp`` (a winding capacitance),
``Zx = Zs/(1 + Zs Yp)``; open terminals leave ``Yp`` alone. For the paper's models ``Yp = 0`` and
this is eq. 50 exactly.

The mass ``m`` is not identifiable from the terminals and cancels in the attenuation ratio
``‖G_RC‖∞/‖G_open‖∞``, so everything here is the *mass-normalised* receptance ``m·G`` [s²].

**H∞ norm.** ``|m·G(jω)|`` on a dense log grid around ω0 locates every local maximum; each is then
refined by a bounded scalar (Brent) search in ``log ω`` on the exact model, to ~1e-12 relative in
frequency and ~1e-14 in height. A :class:`Plant` caches the loop on the grid (and cubic splines of it
in ``log ω``, accurate to ~1e-12) so an optimiser can evaluate many shunts cheaply.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import interpolate, optimize

from ..models import Model
from ..models.terms import mechanical_polynomial

__all__ = ["Plant", "Peak", "rc_impedance", "receptance", "open_peak", "rc_peaks"]


def rc_impedance(s, Rs, Cs):
    """Series RC shunt ``Zs = Rs + 1/(Cs s)`` [Ω] (``Rs`` [Ω], ``Cs`` [F])."""
    return Rs + 1.0 / (Cs * s)


def _shunted(mech, phi2s, ze, yp, zs):
    """``m·G`` from the loop parts; ``zs`` the shunt's impedance (``None``: open terminals)."""
    if zs is None:
        # open terminals: only the device's own parallel admittance closes the coil
        return 1.0 / (mech + phi2s * yp / (1.0 + ze * yp))
    return 1.0 / (mech + phi2s / (ze + zs / (1.0 + zs * yp)))


def receptance(model: Model, theta, omega, Zs: Callable | None = None):
    """Mass-normalised receptance ``m·G(jω)`` [s²] of (50), vectorised.

    Parameters
    ----------
    model : transducer model (any terms). theta : ``(..., k)`` parameter vectors.
    omega : ``(F,)`` [rad/s]. Zs : shunt impedance ``Zs(s) -> (F,)`` or ``(..., F)`` [Ω]; None for
    open terminals.

    Returns
    -------
    complex array ``(..., F)``.
    """
    theta = np.asarray(theta, float)
    s = 1j * np.asarray(omega, float)
    lp = model.loop(s, theta)
    phi2s = (np.asarray(lp.phi)[..., None] ** 2) * s
    return _shunted(lp.mech, phi2s, lp.z_series, lp.y_parallel, None if Zs is None else Zs(s))


def open_peak(model: Model, theta):
    """``(value [s²], omega [rad/s])`` of ``max |1/(s² + 2ζω0 s + ω0²)|``, closed form, vectorised:
    ``1/(2ζ sqrt(1−ζ²) ω0²)`` at ``ω0 sqrt(1 − 2ζ²)`` for ``ζ < 1/√2`` (else ``1/ω0²`` at 0).
    Holds for models with plain mechanics and nothing across the terminals
    (:attr:`Model.plain_mechanics`); :meth:`Plant.open_peak` handles the others numerically."""
    zeta, omega0, _ = (np.asarray(v, float) for v in model.mechanics(theta))
    under = zeta < 1 / np.sqrt(2)
    z = np.where(under, zeta, 0.5)
    value = np.where(under, 1.0 / (2 * z * np.sqrt(1 - z * z) * omega0**2), 1.0 / omega0**2)
    where = np.where(under, omega0 * np.sqrt(np.abs(1 - 2 * z * z)), 0.0)
    return value, where


@dataclass(frozen=True)
class Peak:
    """One local maximum of ``|m·G(jω)|``: ``value`` [s²] at ``omega`` [rad/s]."""

    value: float
    omega: float


def _scalar_table(spl):
    """``(breakpoints, coefficients)`` of a spline as Python lists (cached on the spline): per
    interval the four coefficient rows, each a tuple of complex values."""
    t = getattr(spl, "_scalar_table", None)
    if t is None:
        t = (spl.x.tolist(), [tuple(tuple(row) for row in iv) for iv in spl.c.transpose(1, 0, 2).tolist()])
        spl._scalar_table = t
    return t


def _local_max_indices(g):
    i = np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
    ends = [j for j, k in ((0, 1), (g.size - 1, g.size - 2)) if g[j] > g[k]]
    return np.r_[i, ends].astype(int)


class Plant:
    """One parameter vector of one model, prepared for evaluating many shunts.

    Parameters
    ----------
    model, theta : the transducer model and its physical parameter vector ``(k,)``.
    span : the grid covers ``ω0/span .. ω0·span`` [rad/s] (the shunted peaks stay near ω0, and the
        electrical resonance of any admissible design lies inside; a maximum at the edge triggers
        a search on a 1000× wider grid).
    points : log-spaced grid points.
    """

    def __init__(self, model: Model, theta, *, span: float = 40.0, points: int = 2600):
        self.model = model
        self.theta = np.asarray(theta, float)
        if self.theta.ndim != 1:
            raise ValueError(f"a Plant holds one parameter vector, got shape {self.theta.shape}")
        self.zeta, self.omega0, self.phi = (float(v) for v in model.mechanics(self.theta))
        self.R0 = float(self.theta[model.params.index("R0")])
        self.omega = np.geomspace(self.omega0 / span, self.omega0 * span, points)
        self.s = 1j * self.omega
        lp = model.loop(self.s, self.theta)
        self.Ze, self.mech, self.Yp = lp.z_series, lp.mech, lp.y_parallel
        self._lw = np.log(self.omega)
        # the plain mechanical polynomial is evaluated exactly; splines only for what the terms add
        self._plain_mech = not any(t.device and t.stage in ("stiffness", "motional_parallel")
                                   for t in model.terms)
        self._spline = interpolate.CubicSpline(self._lw, np.stack([self.Ze, self.mech, self.Yp], axis=-1))
        self._wide_cache = None
        self._wide_spl = None

    # ---- evaluation --------------------------------------------------------------------------
    def _parts(self, omega, exact: bool):
        """``(mech, Ze, Yp)`` at ``omega`` [rad/s] (exact, or the cached splines inside the grid)."""
        omega = np.asarray(omega, float)
        if exact or np.any(omega < self.omega[0]) or np.any(omega > self.omega[-1]):
            lp = self.model.loop(1j * omega, self.theta)
            return lp.mech, lp.z_series, lp.y_parallel
        v = self._spline(np.log(omega))
        mech = (mechanical_polynomial(1j * omega, self.zeta, self.omega0) if self._plain_mech else v[..., 1])
        return mech, v[..., 0], v[..., 2]

    def ze(self, omega, exact: bool = True):
        """Series impedance ``Ze`` [Ω] (``Zc + R0`` and any other series device term) at ``omega``."""
        return self._parts(omega, exact)[1]

    def receptance(self, omega, Zs: Callable | None = None, *, exact: bool = True):
        """``m·G(jω)`` [s²] at ``omega`` [rad/s]; ``Zs(s)`` the shunt (None: open terminals)."""
        omega = np.asarray(omega, float)
        s = 1j * omega
        mech, ze, yp = self._parts(omega, exact)
        return _shunted(mech, self.phi**2 * s, ze, yp, None if Zs is None else Zs(s))

    def grid_magnitude(self, Zs: Callable):
        """``|m·G|`` [s²] on the cached grid ``self.omega``."""
        return np.abs(_shunted(self.mech, self.phi**2 * self.s, self.Ze, self.Yp, Zs(self.s)))

    def open_peak(self) -> Peak:
        """H∞ norm of the open-terminal receptance: closed form (:func:`open_peak`) for plain
        mechanics, else the largest refined maximum of the exact open-terminal receptance."""
        if self.model.plain_mechanics:
            v, w = open_peak(self.model, self.theta)
            return Peak(float(v), float(w))
        g = np.abs(self.receptance(self.omega, None))
        idx = _local_max_indices(g)
        if idx.size == 0 or idx[np.argmax(g[idx])] in (0, g.size - 1):
            return self._wide_peak(None)
        i = int(idx[np.argmax(g[idx])])
        return self._refine(None, i, self._lw[i - 1], self._lw[i + 1], True)

    def rc_peak_fast(self, Rs: float, Cs: float) -> float:
        """Peak of ``|m·G_RC|`` [s²] from the grid with parabolic interpolation in ``log ω`` (for
        optimisers; relative error ~1e-7)."""
        g = self.grid_magnitude(lambda s: rc_impedance(s, Rs, Cs))
        i = int(np.argmax(g))
        if 0 < i < g.size - 1:
            y0, y1, y2 = np.log(g[i - 1 : i + 2])
            den = y0 - 2 * y1 + y2
            if den < 0:
                return float(np.exp(y1 - 0.125 * (y0 - y2) ** 2 / den))
        return float(g[i])

    def _scalar_neg(self, spl, c: float, Zs):
        """``u -> −|m·G(j exp(c + u))|`` on the spline ``spl`` of ``(Ze, mech, Yp)`` in ``log ω``, one
        point at a time in Python scalars (the searches' inner loop: the same sums as
        :meth:`receptance` with ``exact=False``, without an array per point; a plain mechanical
        polynomial evaluated exactly, as :meth:`_parts` does). Outside the spline's range the exact
        model is evaluated, as :meth:`_parts` does."""
        xs, coef = _scalar_table(spl)
        plain = self._plain_mech
        zeta, omega0, phi2 = self.zeta, self.omega0, self.phi**2
        last = len(xs) - 2
        w_lo, w_hi = math.exp(xs[0]), math.exp(xs[-1])

        def neg(u):
            x = c + u
            w = math.exp(x)
            if not w_lo <= w <= w_hi:
                return -float(np.abs(self.receptance(np.array([w]), Zs, exact=True))[0])
            i = min(max(bisect.bisect_right(xs, x) - 1, 0), last)
            dx = x - xs[i]
            z = dx * dx
            z3 = z * dx
            c0, c1, c2, c3 = coef[i]
            ze = c3[0] + c2[0] * dx + c1[0] * z + c0[0] * z3
            yp = c3[2] + c2[2] * dx + c1[2] * z + c0[2] * z3
            if plain:
                mech = complex(omega0 * omega0 - w * w, 2.0 * zeta * omega0 * w)
            else:
                mech = c3[1] + c2[1] * dx + c1[1] * z + c0[1] * z3
            s = complex(0.0, w)
            if Zs is None:
                g = 1.0 / (mech + phi2 * s * yp / (1.0 + ze * yp))
            else:
                zs = complex(Zs(s))
                g = 1.0 / (mech + phi2 * s / (ze + zs / (1.0 + zs * yp)))
            return -abs(g)

        return neg

    # ---- accurate peaks ------------------------------------------------------------------------
    def _refine(self, Zs, i, lo, hi, exact) -> Peak:
        """Maximise ``|m·G|`` over ``log ω ∈ [lo, hi]`` (around grid point ``i``)."""
        c = self._lw[i]

        if exact:
            def neg(u):
                return -float(np.abs(self.receptance(np.array([np.exp(c + u)]), Zs, exact=exact))[0])
        else:
            neg = self._scalar_neg(self._spline, c, Zs)

        r = optimize.minimize_scalar(neg, bounds=(lo - c, hi - c), method="bounded",
                                     options={"xatol": 1e-12})
        return Peak(-float(r.fun), float(np.exp(c + r.x)))

    def local_peaks(self, Zs: Callable, *, exact: bool = True, max_peaks: int = 4) -> list[Peak]:
        """The ``max_peaks`` largest local maxima of ``|m·G(jω)|``, refined, sorted by frequency."""
        g = self.grid_magnitude(Zs)
        idx = _local_max_indices(g)
        if idx.size and (idx[np.argmax(g[idx])] in (0, g.size - 1)):
            return [self._wide_peak(Zs, exact)]
        out = []
        for i in sorted(idx, key=lambda j: -g[j])[:max_peaks]:
            lo, hi = self._lw[max(i - 1, 0)], self._lw[min(i + 1, g.size - 1)]
            out.append(self._refine(Zs, i, lo, hi, exact))
        return sorted(out, key=lambda p: p.omega)

    def _wide(self):
        """``(w, lw, mech, Ze, Yp)`` on the wide grid ``ω0/8000 .. 8000 ω0`` (20000 log-spaced points),
        computed once per plant: the loop does not depend on the shunt."""
        if self._wide_cache is None:
            w = np.geomspace(self.omega0 / 8000, self.omega0 * 8000, 20000)
            lp = self.model.loop(1j * w, self.theta)
            self._wide_cache = (w, np.log(w), lp.mech, lp.z_series, lp.y_parallel)
        return self._wide_cache

    def _wide_spline(self):
        """The wide grid's ``(Ze, mech, Yp)`` as a cubic spline in ``log ω``, built on first use: it
        serves only the searches with ``exact=False``."""
        if self._wide_spl is None:
            _, lw, mech, ze, yp = self._wide()
            self._wide_spl = interpolate.CubicSpline(lw, np.stack([ze, mech, yp], axis=-1))
        return self._wide_spl

    def _wide_peak(self, Zs, exact: bool = True) -> Peak:
        """The largest maximum of ``|m·G|`` on ``ω0/8000 .. 8000 ω0``, refined on the exact model
        (``exact=False``: on the wide grid's spline, ~1e-12 relative, for optimisers)."""
        w, lw, mech, ze, yp = self._wide()
        s = 1j * w
        g = np.abs(_shunted(mech, self.phi**2 * s, ze, yp, None if Zs is None else Zs(s)))
        i = int(np.argmax(g))
        c = lw[i]

        if exact:
            def neg(u):
                return -float(np.abs(self.receptance(np.array([np.exp(c + u)]), Zs))[0])
        else:
            neg = self._scalar_neg(self._wide_spline(), c, Zs)

        lo, hi = lw[max(i - 1, 0)] - c, lw[min(i + 1, w.size - 1)] - c
        r = optimize.minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        return Peak(-float(r.fun), float(np.exp(c + r.x)))

    def peak(self, Zs: Callable | None, *, exact: bool = True) -> Peak:
        """Accurate H∞ norm of ``m·G`` (module docstring); ``Zs=None``: open terminals."""
        if Zs is None:
            return self.open_peak()
        return max(self.local_peaks(Zs, exact=exact), key=lambda p: p.value)

    def band_peaks(self, Rs: float, Cs: float, split: float, *, exact: bool = False) -> tuple[Peak, Peak]:
        """``sup |m·G_RC|`` below and above ``split`` [rad/s], refined: the two peak heights of the
        equal-peak (min-max) formulation. Continuous in ``(Rs, Cs)``; their maximum is the H∞ norm
        on the grid band."""
        Zs = lambda s: rc_impedance(s, Rs, Cs)  # noqa: E731
        g = self.grid_magnitude(Zs)
        k = int(np.searchsorted(self.omega, split))
        ls = np.log(split)
        out = []
        for sl, (a, b) in ((slice(0, k), (self._lw[0], ls)), (slice(k, g.size), (ls, self._lw[-1]))):
            i = sl.start + int(np.argmax(g[sl]))
            lo, hi = max(self._lw[max(i - 1, 0)], a), min(self._lw[min(i + 1, g.size - 1)], b)
            out.append(self._refine(Zs, i, lo, hi, exact))
        return out[0], out[1]


def rc_peaks(model: Model, thetas, Rs: float, Cs: float, *, refine: bool = True):
    """``‖m·G_RC‖∞`` [s²] of one RC shunt on many parameter vectors ``thetas (..., k)``.

    The grid evaluation is one vectorised model call per chunk of vectors; with ``refine`` each
    vector's largest grid maximum is then refined on the exact model. Returns ``(...)``.
    """
    thetas = np.asarray(thetas, float)
    flat = thetas.reshape(-1, thetas.shape[-1])
    w0 = np.asarray(model.mechanics(flat)[1])
    omega = np.geomspace(w0.min() / 8, w0.max() * 8, 1600)
    out = np.empty(flat.shape[0])
    Zs = lambda s: rc_impedance(s, Rs, Cs)  # noqa: E731
    for a in range(0, flat.shape[0], 256):
        chunk = flat[a : a + 256]
        g = np.abs(receptance(model, chunk, omega, Zs))
        lw = np.log(omega)
        for j, t in enumerate(chunk):
            idx = _local_max_indices(g[j])
            top = sorted(idx, key=lambda i, gj=g[j]: -gj[i])[:2]  # equal-peak designs: refine both
            if not refine:
                out[a + j] = g[j, top[0]]
            elif top[0] in (0, omega.size - 1):
                out[a + j] = Plant(model, t).peak(Zs).value
            else:
                best = 0.0
                for i in top:
                    c = lw[i]
                    r = optimize.minimize_scalar(
                        lambda u, t=t, c=c: -float(np.abs(receptance(model, t, np.exp([c + u]), Zs))[0]),
                        bounds=(lw[max(i - 1, 0)] - c, lw[min(i + 1, omega.size - 1)] - c),
                        method="bounded", options={"xatol": 1e-12})
                    best = max(best, -float(r.fun))
                out[a + j] = best
    return out.reshape(thetas.shape[:-1])
