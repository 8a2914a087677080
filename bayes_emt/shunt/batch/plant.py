"""Many parameter vectors of one model prepared for evaluating RC shunts: the stability threshold
in Rs of every draw at once (the batched counterpart of :func:`~bayes_emt.shunt.instability_threshold`).

**Threshold.** As in :mod:`bayes_emt.shunt.stability`: a closed-loop pole reaches the imaginary
axis at ``jω`` exactly when the loop impedance vanishes, ``Z(jω) + Zs(jω) = 0``, with ``Z`` the
terminal impedance. For the ideal shunt ``Zs = Rs + 1/(jω Cs)``; a sampled-data realisation
(:class:`SampledShunt`, eqs. 55–56) gives ``Zs = A(ω) + Rs B(ω)`` (Tustin-warped capacitor, zero-order
hold and ``d`` samples of computation delay: ``B = e^{−jωTd}(1 − e^{−jωT})/(jωT)``). Either way the
crossing condition is ``Im W(ω) = 0`` with ``W = (Z + A)/B`` (ideal: ``A = 1/(jωCs)``, ``B = 1``,
``Im W`` the loop reactance) and the crossing value is ``Rs = −Re W``; coming down from large Rs
stability is first lost at the largest crossing value, the threshold. ``Rs`` above it: stable.

``Z`` is computed once per draw on a shared log grid (:func:`terminal_impedance`, the one place
this feature asks the model for an impedance) and kept; a threshold for any ``Cs`` is then array
arithmetic: sign changes of ``Im W`` locate the crossings, a local cubic in ``log ω`` through four
grid points refines each (the grid is dense where crossings can bind: ``ω0/30 .. 30 ω0`` at
``Δ log ω ≈ 0.0057`` and ~0.1 % of ω0 across the motional resonance). The sampled-data form keeps
only the fundamental of the sampled loop (images at ``ω ± k 2π fs`` neglected, as
:mod:`bayes_emt.shunt.implementation` does for its attenuation) and looks below the Nyquist
frequency only; :func:`sampled_data_stable` is the exact check of a single draw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...models import Model
from ..receptance import Plant, open_peak

__all__ = ["terminal_impedance", "SampledShunt", "Crossings", "BatchPlant", "open_peaks"]

_CHUNK = 128  # draws per model call while filling the impedance cache
#: the shunted peaks are looked for within ``ω0/SPAN .. SPAN ω0``, the nominal design's grid
#: (:class:`~bayes_emt.shunt.Plant`). A loudspeaker's optimal shunt has Cs of farads and puts one of
#: its two equal peaks at the low end of that band (LS10-44, UD: 0.85 Hz for fs = 34 Hz); a narrower
#: window (it was ω0/20) missed that peak on every draw, so the batched Newton never settled and
#: every draw fell back to the one-at-a-time design.
SPAN = 40.0


def terminal_impedance(model: Model, s, thetas):
    """Terminal impedance ``Z(s)`` [Ω] seen by the shunt, ``(..., F)`` for ``thetas (..., k)``.

    The single place the robust design asks a model for the impedance its stability threshold is
    computed from (today the series impedance of eq. 47: coil + R0 + motional).
    """
    return model.impedance_s(s, thetas)


@dataclass(frozen=True)
class SampledShunt:
    """The digital realisation of an RC shunt (eqs. 55–56): sense resistor ``R_in`` [Ω], gains
    ``K_in``, ``K_out``, sample rate ``fs`` [Hz], computation delay ``delay_samples``.
    Defaults: the paper's Table 7 rig at 5 kHz, no delay."""

    R_in: float = 0.0996
    K_in: float = 99.23
    K_out: float = 0.9846
    fs: float = 5000.0
    delay_samples: int = 0

    def __post_init__(self):
        for name in ("R_in", "K_in", "K_out", "fs"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive, got {v!r}")
        if int(self.delay_samples) != self.delay_samples or self.delay_samples < 0:
            raise ValueError(f"delay must be >= 0 samples, got {self.delay_samples!r}")

    @property
    def nyquist(self) -> float:
        """Nyquist angular frequency ``π fs`` [rad/s]."""
        return math.pi * self.fs

    def affine(self, omega, Cs):
        """``(A, B)`` with the realised shunt impedance ``Zs(jω) = A + Rs B`` [Ω] (module docstring);
        ``omega`` [rad/s] ``(F,)``, ``Cs`` [F] scalar or ``(n, 1)``."""
        T = 1.0 / self.fs
        omega = np.asarray(omega, float)
        warped = (2.0 / T) * np.tan(omega * T / 2.0)
        zoh = (1 - np.exp(-1j * omega * T)) / (1j * omega * T)
        phase = np.exp(-1j * omega * T * self.delay_samples) * zoh
        return self.R_in + (-self.R_in + 1.0 / (1j * warped * Cs)) * phase, phase

    def to_json_dict(self) -> dict:
        return {"R_in": self.R_in, "K_in": self.K_in, "K_out": self.K_out, "fs": self.fs,
                "delay_samples": int(self.delay_samples)}


@dataclass(frozen=True)
class Crossings:
    """Stability thresholds of many draws for one shunt capacitance (module docstring).

    Attributes
    ----------
    threshold : ``(n,)`` the Rs [Ω] below which each draw's loop is unstable (−inf: never).
    omega_c : ``(n,)`` frequency [rad/s] of the binding crossing (NaN when there is none).
    omega_min, omega_max : ``(n,)`` lowest and highest crossing [rad/s] within ``ω0/SPAN .. SPAN ω0``
        (where the shunted peaks sit, the electrical resonance of a shunt of farads included; NaN
        when there is none).
    upper : ``(n,)`` sampled-data shunts: the Rs [Ω] above which the loop is unstable again
        (+inf for the ideal shunt, or when not asked for).
    """

    threshold: np.ndarray
    omega_c: np.ndarray
    omega_min: np.ndarray
    omega_max: np.ndarray
    upper: np.ndarray

    def stable(self, Rs) -> np.ndarray:
        """``(n,)`` whether ``Rs`` [Ω] lies strictly inside each draw's stable interval."""
        Rs = np.asarray(Rs, float)
        return (Rs > self.threshold) & (Rs < self.upper)


def open_peaks(model: Model, thetas) -> np.ndarray:
    """``(n,)`` the open-terminal H∞ norm of ``|m·G|`` [s²] per draw: the closed form
    (:func:`~bayes_emt.shunt.receptance.open_peak`) where the mechanics are plain, else the exact
    one-draw search :meth:`Plant.open_peak <bayes_emt.shunt.Plant.open_peak>` (a stiffness modifier
    such as creep, a motional load or a capacitance across the terminals changes the peak; the
    closed form made the batch's attenuation of a creep model −28.76 dB where the design's is
    −10.03 dB)."""
    thetas = np.atleast_2d(np.asarray(thetas, float))
    if model.plain_mechanics:
        return np.asarray(open_peak(model, thetas)[0], float)
    return np.array([Plant(model, t).open_peak().value for t in thetas], float)


def _threshold_grid(omega0, zeta):
    lo, hi = float(np.min(omega0)), float(np.max(omega0))
    half = min(40.0 * float(np.max(zeta)) + 0.01, 0.9)
    w = np.concatenate([np.geomspace(lo * 1e-5, lo / 30, 120), np.geomspace(lo / 30, hi * 30, 1400),
                        np.linspace(lo * (1 - half), hi * (1 + half), 600),
                        np.geomspace(hi * 30, hi * 1e6, 160)])
    w = np.unique(w)
    keep = np.r_[True, np.diff(np.log(w)) > 1e-7]
    return w[keep]


def _cubic_root(x4, re4, im4, k):
    """Refine a sign change of ``im`` between local points ``k`` and ``k+1`` (one per row) with
    cubics through the four points ``x4 (m, 4)`` (``log ω``); returns ``(x_root, re(x_root))``."""
    rows = np.arange(k.size)
    x0 = x4[rows, k]
    V = (x4 - x0[:, None])[..., None] ** np.arange(4)
    ci = np.linalg.solve(V, im4[..., None])[..., 0]
    cr = np.linalg.solve(V, re4[..., None])[..., 0]
    a, b = im4[rows, k], im4[rows, k + 1]
    h = x4[rows, k + 1] - x0
    t = h * a / (a - b)  # linear start
    for _ in range(6):
        p = ci[:, 0] + t * (ci[:, 1] + t * (ci[:, 2] + t * ci[:, 3]))
        dp = ci[:, 1] + t * (2 * ci[:, 2] + 3 * t * ci[:, 3])
        ok = dp != 0
        t = np.clip(t - np.where(ok, p / np.where(ok, dp, 1.0), 0.0), 0.0, h)
    return x0 + t, cr[:, 0] + t * (cr[:, 1] + t * (cr[:, 2] + t * cr[:, 3]))


class BatchPlant:
    """Draws ``thetas (n, k)`` of one model, with their terminal impedance cached for thresholds.

    Parameters
    ----------
    model : transducer model. thetas : ``(n, k)`` physical parameter vectors.
    sampled : the digital realisation whose delay enters every threshold (None: ideal shunt).
    peaks : compute the open-terminal peak (False: thresholds only; ``open_peak`` is NaN).
    """

    def __init__(self, model: Model, thetas, *, sampled: SampledShunt | None = None, peaks: bool = True):
        self.model = model
        self.thetas = np.atleast_2d(np.asarray(thetas, float))
        if self.thetas.shape[-1] != model.ndim or self.thetas.ndim != 2:
            raise ValueError(f"model {model.label} takes (n, {model.ndim}) parameter vectors, "
                             f"got shape {self.thetas.shape}")
        self.n = self.thetas.shape[0]
        self.sampled = sampled
        self.zeta, self.omega0, self.phi = (np.asarray(v, float) for v in model.mechanics(self.thetas))
        self.R0 = self.thetas[:, model.params.index("R0")]
        # the open-terminal peak (each attenuation's reference); not needed for thresholds alone
        self.open_peak = open_peaks(model, self.thetas) if peaks else np.full(self.n, np.nan)
        self.omega = _threshold_grid(self.omega0, self.zeta)
        self._x = np.log(self.omega)
        self._zr = np.empty((self.n, self.omega.size))
        self._zi = np.empty_like(self._zr)
        for a in range(0, self.n, _CHUNK):
            z = terminal_impedance(model, 1j * self.omega, self.thetas[a : a + _CHUNK])
            self._zr[a : a + _CHUNK], self._zi[a : a + _CHUNK] = z.real, z.imag
        self._y = self.omega * self._zi  # ω Im Z: the ideal loop reactance vanishes where it is 1/Cs
        self._inf = self._infinity_candidate()

    def _infinity_candidate(self):
        """``−Z(j∞)`` where the impedance stays bounded at high frequency (model II), 0 where it decays
        like ``1/s`` (a capacitance across the terminals: in the ideal loop any negative Rs is then
        unstable, a pole arriving from infinity), else −inf: as
        :func:`~bayes_emt.shunt.stability.instability_threshold`. The decaying case is left out for a
        sampled-data shunt, which has no gain at infinity."""
        z = terminal_impedance(self.model, 1j * np.max(self.omega0) * np.array([1e8, 1e10]), self.thetas)
        bounded = (np.abs(z[:, 1] - z[:, 0]) <= 1e-6 * np.abs(z[:, 1])) & (np.abs(z[:, 1].imag)
                                                                         <= 1e-6 * np.abs(z[:, 1]))
        decays = ~bounded & (np.abs(z[:, 1]) <= 0.02 * np.abs(z[:, 0])) & (self.sampled is None)
        return np.where(bounded, -z[:, 1].real, np.where(decays, 0.0, -np.inf))

    def subset(self, idx) -> BatchPlant:
        """The same plant restricted to draws ``idx`` (the cache is shared, not recomputed)."""
        new = object.__new__(BatchPlant)
        new.__dict__.update(self.__dict__)
        new.thetas = self.thetas[idx]
        new.n = new.thetas.shape[0]
        for name in ("zeta", "omega0", "phi", "R0", "open_peak", "_zr", "_zi", "_y", "_inf"):
            setattr(new, name, getattr(self, name)[idx])
        return new

    def crossings(self, Cs, idx=None, Rs=None) -> Crossings:
        """Thresholds of draws ``idx`` (default all) for ``Cs`` [F] (scalar or one per draw).

        ``Rs`` [Ω] (scalar or one per draw) matters for a sampled-data shunt only: its delay makes
        the loop unstable again at large positive Rs, so the stable set is an interval; the
        threshold is then the largest crossing value below ``Rs`` and ``upper`` the smallest above
        (without ``Rs``: the largest of all, as for the ideal shunt)."""
        rows_all = slice(None) if idx is None else np.asarray(idx)
        m = self.n if idx is None else rows_all.size
        Cs = np.broadcast_to(np.asarray(Cs, float), (m,))
        if not np.all((Cs > 0) & np.isfinite(Cs)):
            raise ValueError("Cs must be a positive capacitance [F]")
        omega0, inf = self.omega0[rows_all], self._inf[rows_all]
        if self.sampled is None:
            x, w = self._x, self.omega
            zr, zi = self._zr[rows_all], self._zi[rows_all]
            # Im W = Im Z − 1/(ω Cs) changes sign where ω Im Z crosses 1/Cs
            above = self._y[rows_all] > (1.0 / Cs)[:, None]
            r, c = np.nonzero(above[:, :-1] != above[:, 1:])
            a = zi[r, c] - 1.0 / (w[c] * Cs[r])
            b = zi[r, c + 1] - 1.0 / (w[c + 1] * Cs[r])
            ra, rb = zr[r, c], zr[r, c + 1]

            def local(rows, cols):
                return zr[rows, cols], zi[rows, cols] - 1.0 / (w[cols] * Cs[rows])
        else:
            cols = self.omega < self.sampled.nyquist
            x, w = self._x[cols], self.omega[cols]
            A, B = self.sampled.affine(w, Cs[:, None])
            W = (self._zr[rows_all][:, cols] + 1j * self._zi[rows_all][:, cols] + A) / B
            sign = np.signbit(W.imag)
            r, c = np.nonzero(sign[:, :-1] != sign[:, 1:])
            a, b, ra, rb = W.imag[r, c], W.imag[r, c + 1], W.real[r, c], W.real[r, c + 1]

            def local(rows, cols):
                return W.real[rows, cols], W.imag[rows, cols]
        frac = a / (a - b)
        cand = -(ra + frac * (rb - ra))
        upper = np.full(m, np.inf)
        lower_ok = np.ones(cand.size, bool)
        if self.sampled is not None and Rs is not None:
            ref = np.broadcast_to(np.asarray(Rs, float), (m,))[r]
            lower_ok = cand < ref
            np.minimum.at(upper, r[~lower_ok], cand[~lower_ok])
        best = np.full(m, -np.inf)
        np.maximum.at(best, r[lower_ok], cand[lower_ok])
        thr = np.array(inf, float, copy=True)
        omega_c = np.full(m, np.nan)
        has = np.flatnonzero(np.isfinite(best))
        if has.size:
            is_best = (cand == best[r]) & lower_ok
            first = np.full(m, -1)
            first[r[is_best][::-1]] = c[is_best][::-1]  # each row's binding crossing (ties: any)
            j = first[has]
            F = x.size
            win = np.clip(j - 1, 0, F - 4)[:, None] + np.arange(4)
            re4, im4 = local(has[:, None], win)
            xr, val = _cubic_root(x[win], re4, im4, j - win[:, 0])
            thr[has] = np.maximum(thr[has], -val)
            omega_c[has] = np.where(-val >= inf[has], np.exp(xr), np.nan)
        wc = np.exp(x[c] + (x[c + 1] - x[c]) * frac)
        near = (wc > omega0[r] / SPAN) & (wc < omega0[r] * SPAN)
        wmin, wmax = np.full(m, np.inf), np.full(m, -np.inf)
        np.minimum.at(wmin, r[near], wc[near])
        np.maximum.at(wmax, r[near], wc[near])
        wmin[~np.isfinite(wmin)] = np.nan
        wmax[~np.isfinite(wmax)] = np.nan
        return Crossings(thr, omega_c, wmin, wmax, upper)

    def threshold(self, Cs, idx=None, Rs=None) -> np.ndarray:
        """``(n,)`` Rs [Ω] below which each draw is unstable (:meth:`crossings`)."""
        return self.crossings(Cs, idx, Rs).threshold

    def margin(self, Rs, Cs, idx=None) -> np.ndarray:
        """Stability margin ``Rs − threshold`` [Ω] per draw: how far Rs, or equally R0, may drift
        down before the loop goes unstable (R0 enters ``Re Z`` additively at every frequency, so
        the crossing frequencies do not move with it)."""
        return np.asarray(Rs, float) - self.threshold(Cs, idx, Rs)
