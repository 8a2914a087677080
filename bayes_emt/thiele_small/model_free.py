"""Model-free Thiele–Small values read off the impedance curve (Small's method), with their own
uncertainty: the field's check beside the model.

Small's method (R. H. Small, "Direct-radiator loudspeaker system analysis", JAES 20(5), 1972; the
same recipe in V. Dickason, *The Loudspeaker Design Cookbook*, and in the bench tools that print T/S
values straight from a sweep):

* fs: the resonance, where the phase of Z crosses zero going from + to − (interpolated linearly in
  phase against log f between the two grid points that bracket it); from |Z| alone, the vertex of
  the parabola through the three grid points around the maximum of |Z| against log f;
* Zmax: the maximum of |Z| at the resonance (the same parabola's vertex value) and
  ``r0 = Zmax / Re``;
* f1 < fs < f2: where ``|Z| = √r0 · Re`` (= √(Zmax Re)), on each side of the peak (interpolated in
  log |Z| against log f);
* ``Qms = fs √r0 / (f2 − f1)``, ``Qes = Qms / (r0 − 1)``, ``Qts = Qms Qes / (Qms + Qes)``;
* with a recording of the same driver with a mass Δm added to the cone: its resonance fs′ gives
  ``Mms = Δm / ((fs/fs′)² − 1)``, then ``Cms = 1 / ((2π fs)² Mms)`` and
  ``Bl = √(2π fs Mms Re / Qes)`` (several masses: the mean of their Mms per draw).

Re is not read off the curve: it is the caller's (the model's R0 with its interval, or an
ohmmeter reading), and the result says which (``re_source``).

Uncertainty (``ci90``: 5–95 % quantiles over ``n_draws`` resamplings, seeded): each draw

1. perturbs the curve within its own noise: relative Gaussian noise on |Z| and Gaussian noise on
   the phase, of the size the curve shows (the robust scatter of its second differences against
   log f: ``σ = 1.4826 · MAD(Δ²x) / √6``, which a smooth curve sampled on a fine grid leaves at
   the noise level);
2. draws Re from a Normal of the given standard deviation;
3. interpolates the crossings with one of two schemes chosen at random (linear, or a monotone
   cubic, PCHIP) so that a coarse frequency grid's interpolation ambiguity enters the interval;
4. locates fs (with phase) at the phase zero or at the |Z| peak, chosen at random: the two
   definitions the field uses differ by the coil's reactance at resonance, and that difference
   is part of what "model-free fs" can mean.

``value`` is the point estimate on the recorded curve (linear interpolation), not the draws'
median. The method is undefined, and :class:`ModelFreeUndefined` is raised with the reason, when
the band holds no resonance peak (no + to − phase crossing with |Z| above Re), when it holds two
or more comparable peaks (a vented box, a passive radiator, a second resonance), or when the
curve does not fall to √r0·Re on both sides of the peak within the band.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..estimation.dark_uncertainty import half_width_sd
from ..measurement import Measurement

__all__ = ["ModelFree", "ModelFreeUndefined", "model_free_ts", "resonance", "fs_definitions",
           "MODEL_FREE_METHOD", "SECOND_PEAK_FRACTION"]

#: a second + to − phase crossing whose |Z| prominence is at least this fraction of the main
#: peak's makes the curve a two-peak curve (vented box) on which Small's method is undefined
SECOND_PEAK_FRACTION = 0.2
#: a second peak counts within this factor of the main peak's frequency (either side)
SECOND_PEAK_SPAN = 5.0
#: the |Z| peak's vertex is fitted to the points within this fraction of the grid maximum
PEAK_TOP = 0.05

MODEL_FREE_METHOD = (
    "Small's method on the curve: fs at the phase zero (+ to -), Zmax at the |Z| peak, f1 and f2 where "
    "|Z| = sqrt(Zmax Re), Qms = fs sqrt(r0)/(f2 - f1), Qes = Qms/(r0 - 1); 90 % intervals from resampling "
    "the curve within its own noise (robust second-difference scatter), Re within its uncertainty, "
    "linear or monotone-cubic interpolation of the crossings, and fs at the phase zero or the |Z| peak")


class ModelFreeUndefined(ValueError):
    """Small's method does not apply to this curve (the message says why, in one line)."""


@dataclass(frozen=True)
class ModelFree:
    """Model-free T/S values (module docstring).

    Attributes
    ----------
    parameters : ``{name: {"value", "ci90": [lo, hi], "unit"}}`` in SI (fs [Hz], Re [ohm], Zmax
        [ohm], f1, f2 [Hz], Qms, Qes, Qts, and with added masses Mms [kg], Cms [m/N], Bl [T m]).
    re_source : where Re came from (e.g. ``"model R0"``, ``"ohmmeter"``).
    inputs : the method in words, the curve's noise estimates, the draws and the seed.
    """

    parameters: dict
    re_source: str
    inputs: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> float:
        return self.parameters[name]["value"]

    def to_json_dict(self) -> dict:
        return {"parameters": self.parameters, "re_source": self.re_source, "inputs": self.inputs}


UNITS_MF = {"fs": "Hz", "Re": "ohm", "Zmax": "ohm", "f1": "Hz", "f2": "Hz", "Qms": "1", "Qes": "1",
            "Qts": "1", "Mms": "kg", "Cms": "m/N", "Bl": "T m"}


def _perturbed(mag: np.ndarray, ph: np.ndarray | None, s_m: float, s_p: float, rng: np.random.Generator):
    """``(|Z|, phase)`` resampled within the curve's noise: relative Gaussian noise ``s_m`` on |Z|,
    Gaussian noise ``s_p`` [rad] on the phase (None stays None)."""
    m2 = mag * np.exp(s_m * rng.standard_normal(mag.size))
    return m2, (None if ph is None else ph + s_p * rng.standard_normal(ph.size))


def _noise(x: np.ndarray, lf: np.ndarray) -> float:
    """Robust noise level of samples ``x`` on the abscissa ``lf``: second differences of a smooth
    curve vanish; of white noise of sd σ their sd is σ√6 (uniform spacing; the local spacing is
    nearly uniform on the grids benches write)."""
    if x.size < 5:
        return 0.0
    d2 = x[:-2] - 2 * x[1:-1] + x[2:]
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _crossing(x: np.ndarray, y: np.ndarray, level: float, i0: int, step: int, cubic: bool) -> float:
    """First abscissa from index ``i0`` walking by ``step`` where ``y`` falls to ``level``
    (interpolated); nan if it never does."""
    i = i0
    while 0 <= i + step < y.size:
        j = i + step
        if (y[i] - level) * (y[j] - level) <= 0 and y[i] != y[j]:
            a, b = (i, j) if i < j else (j, i)
            if cubic and a > 0 and b < y.size - 1:
                root = _pchip_root(x[a - 1:b + 2], y[a - 1:b + 2] - level)
                if root is not None:
                    return root
            t = (level - y[a]) / (y[b] - y[a])
            return float(x[a] + t * (x[b] - x[a]))
        i = j
    return float("nan")


def _pchip_root(xs: np.ndarray, ys: np.ndarray) -> float | None:
    """The smallest root in ``[xs[1], xs[2]]`` of the monotone piecewise-cubic Hermite
    interpolant (PCHIP: Fritsch & Carlson 1980, the weighted harmonic-mean slopes of scipy's
    ``PchipInterpolator``) through four points, or None. The same root as
    ``PchipInterpolator(xs, ys).roots()`` (within 1e-13 of the interval on 20 000 random cases) at a
    quarter of its cost: only the middle piece and its two interior slopes are built."""
    h = np.diff(xs)
    m = np.diff(ys) / h

    def slope(k):
        m0, m1, h0, h1 = m[k - 1], m[k], h[k - 1], h[k]
        if m0 == 0 or m1 == 0 or (m0 > 0) != (m1 > 0):
            return 0.0
        w1, w2 = 2 * h1 + h0, h1 + 2 * h0
        return (w1 + w2) / (w1 / m0 + w2 / m1)

    d1, d2, hh, mm = slope(1), slope(2), h[1], m[1]
    r = np.roots([(d1 + d2 - 2 * mm) / hh**2, (3 * mm - 2 * d1 - d2) / hh, d1, ys[1]])
    r = r[np.abs(r.imag) <= 1e-9 * hh].real
    r = r[(r >= -1e-12 * hh) & (r <= hh * (1 + 1e-12))]
    return None if r.size == 0 else float(xs[1] + min(max(float(np.min(r)), 0.0), hh))


def _peaks(lf: np.ndarray, mag: np.ndarray, phase: np.ndarray | None) -> list[tuple[int, int | None]]:
    """``(grid index, crossing index)`` of every resonance candidate: the larger-|Z| end of each + to −
    phase crossing (and the crossing's left index), or, without phase, each local maximum of |Z|."""
    if phase is not None:
        idx = np.flatnonzero((phase[:-1] > 0) & (phase[1:] <= 0))
        return [(int(i if mag[i] >= mag[i + 1] else i + 1), int(i)) for i in idx]
    return [(int(i), None) for i in np.flatnonzero((mag[1:-1] > mag[:-2]) & (mag[1:-1] >= mag[2:])) + 1]


def _prominence(mag: np.ndarray, k: int) -> float:
    """Topographic prominence of |Z| at ``k`` [ohm]: its height above the higher of the two lowest
    points between it and the nearest higher point on each side (or the band's end). A point on the
    coil's inductive rise has none; each of a vented box's two peaks has its own."""
    left = np.flatnonzero(mag[:k] > mag[k])
    right = np.flatnonzero(mag[k + 1:] > mag[k])
    lo = int(left[-1]) if left.size else 0
    hi = k + 1 + int(right[0]) if right.size else mag.size - 1
    return float(mag[k] - max(mag[lo:k + 1].min(), mag[k:hi + 1].min()))


def _clusters(mag: np.ndarray, cands: list[tuple[int, int | None]], thr: float) -> list[list]:
    """Candidates grouped into peaks: neighbours belong to one peak unless |Z| dips between them by
    more than ``thr`` (relative) below the lower of the two (noise makes several crossings on one
    peak of a dense grid; a vented box's two peaks have a deep dip between them)."""
    groups: list[list] = []
    for k, c in sorted(cands):
        if groups:
            k0 = groups[-1][-1][0]
            if mag[k0:k + 1].min() >= (1 - thr) * min(mag[k0], mag[k]):
                groups[-1].append((k, c))
                continue
        groups.append([(k, c)])
    return groups


def _vertex(lf: np.ndarray, mag: np.ndarray, k: int) -> tuple[float, float]:
    """``(log f, |Z|)`` at the vertex of the least-squares parabola (|Z| against log f) through the
    contiguous points around the grid maximum ``k`` within :data:`PEAK_TOP` of it (at least three):
    the peak is symmetric in log f for a mass-spring-damper, and a wider window averages the noise
    that a three-point vertex would follow."""
    lo = hi = k
    while lo > 0 and mag[lo - 1] >= (1 - PEAK_TOP) * mag[k]:
        lo -= 1
    while hi < mag.size - 1 and mag[hi + 1] >= (1 - PEAK_TOP) * mag[k]:
        hi += 1
    lo, hi = max(min(lo, k - 1), 0), min(max(hi, k + 1), mag.size - 1)
    x, y = lf[lo:hi + 1] - lf[k], mag[lo:hi + 1]
    if x.size < 3:
        return float(lf[k]), float(mag[k])
    c2, c1, c0 = np.polyfit(x, y, 2)
    if c2 >= 0:  # not a maximum: keep the grid point
        return float(lf[k]), float(mag[k])
    xv = min(max(-c1 / (2 * c2), x[0]), x[-1])
    return float(lf[k] + xv), float(c0 + c1 * xv + c2 * xv * xv)


def resonance(f_hz, abs_z, phase_rad=None, *, noise: float = 0.0, where: str = "curve") -> dict:
    """fs [Hz] (phase zero, else |Z| peak), Zmax [ohm] and the grid index of the single resonance
    peak of one curve; raises :class:`ModelFreeUndefined` for no peak or two comparable peaks.
    ``noise``: the relative noise of |Z| (candidates closer than max(2 %, 5 noise) are one peak)."""
    f = np.asarray(f_hz, float)
    mag = np.asarray(abs_z, float)
    ph = None if phase_rad is None else np.asarray(phase_rad, float)
    lf = np.log(f)
    cands = [(k, c) for k, c in _peaks(lf, mag, ph) if 0 < k < f.size - 1]
    if not cands:
        raise ModelFreeUndefined(f"{where}: no resonance peak in {f[0]:.4g}-{f[-1]:.4g} Hz (no + to - phase "
                                 "crossing with |Z| above its minimum): Small's method needs the peak inside "
                                 "the band")
    groups = _clusters(mag, cands, max(0.02, 5 * noise))
    heights = np.array([_prominence(mag, max((k for k, _ in g), key=lambda k: mag[k])) for g in groups])
    main_g = groups[int(np.argmax(heights))]
    f_main = f[max((k for k, _ in main_g), key=lambda k: mag[k])]
    # a second peak within a factor SECOND_PEAK_SPAN of the main one (a vented box, a passive
    # radiator); a bump far above it (cone break-up, noise on a coil's rise) is not one
    big = [g for g, h in zip(groups, heights, strict=True) if h >= SECOND_PEAK_FRACTION * heights.max()
           and 1 / SECOND_PEAK_SPAN <= f[g[0][0]] / f_main <= SECOND_PEAK_SPAN]
    if len(big) > 1:
        fl = ", ".join(f"{f[max(g, key=lambda kc: mag[kc[0]])[0]]:.4g}" for g in big)
        raise ModelFreeUndefined(f"{where}: {len(big)} resonance peaks (at {fl} Hz): a vented box, passive "
                                 "radiator or second resonance; Small's single-peak method is undefined here")
    main = max((k for k, _ in main_g), key=lambda k: mag[k])
    lv, zmax = _vertex(lf, mag, main)
    if ph is not None:
        # the phase zero of this peak nearest its |Z| vertex (noise can add crossings on a dense grid)
        i = min((c for _, c in main_g), key=lambda c: abs(lf[c] - lv))
        t = ph[i] / (ph[i] - ph[i + 1])
        fs = float(math.exp(lf[i] + t * (lf[i + 1] - lf[i])))
    else:
        fs = float(math.exp(lv))
    return {"fs": fs, "Zmax": max(zmax, float(mag[main])), "index": main}


def _small(f, mag, phase, re: float, cubic: bool, where: str, noise: float = 0.0) -> dict:
    r = resonance(f, mag, phase, noise=noise, where=where)
    fs, zmax, k = r["fs"], r["Zmax"], r["index"]
    if not zmax > re:
        raise ModelFreeUndefined(f"{where}: the peak |Z| {zmax:.4g} ohm is not above Re {re:.4g} ohm")
    r0 = zmax / re
    level = math.log(math.sqrt(r0) * re)
    lf, lm = np.log(f), np.log(mag)
    f1 = math.exp(_crossing(lf, lm, level, k, -1, cubic))
    f2 = math.exp(_crossing(lf, lm, level, k, +1, cubic))
    if not (math.isfinite(f1) and math.isfinite(f2)):
        raise ModelFreeUndefined(f"{where}: |Z| does not fall to sqrt(r0) Re = {math.exp(level):.4g} ohm on "
                                 f"both sides of the peak at {fs:.4g} Hz within {f[0]:.4g}-{f[-1]:.4g} Hz")
    qms = fs * math.sqrt(r0) / (f2 - f1)
    qes = qms / (r0 - 1)
    return {"fs": fs, "Re": re, "Zmax": zmax, "f1": f1, "f2": f2, "Qms": qms, "Qes": qes,
            "Qts": qms * qes / (qms + qes)}


def fs_definitions(meas: Measurement, *, use_phase: bool = True, n_draws: int = 100, seed: int = 0) -> dict:
    """The two model-free definitions of fs on one curve, each with its own uncertainty from the curve's
    noise alone: ``{"phase_zero": (value, u), "peak": (value, u)}`` [Hz] (``u`` the standard
    uncertainty of the resampled 90 % interval), the phase zero only with ``use_phase`` (a
    magnitude-only curve has no phase zero of its own).
    They differ by the coil's reactance at resonance: the field uses both (benches that fit a model
    land near the |Z| peak), so for the spread between methods they are two methods, not one
    method's noise. Raises :class:`ModelFreeUndefined` as :func:`resonance` does."""
    f, mag, ph = _curve(meas, use_phase and not meas.phase_absent)
    lf = np.log(f)
    s_m = _noise(np.log(mag), lf)
    s_p = 0.0 if ph is None else _noise(ph, lf)
    rng = np.random.default_rng([int(seed), 31])
    out = {}
    for name, phase in ([("phase_zero", ph)] if ph is not None else []) + [("peak", None)]:
        v0 = resonance(f, mag, phase, noise=s_m, where=meas.source)["fs"]
        draws = []
        for _ in range(n_draws):
            try:
                draws.append(resonance(f, *_perturbed(mag, phase, s_m, s_p, rng), noise=math.sqrt(2.0) * s_m,
                                       where=meas.source)["fs"])
            except ModelFreeUndefined:
                continue
        if len(draws) >= n_draws // 2:
            out[name] = (float(v0), half_width_sd(np.quantile(np.asarray(draws), [0.05, 0.95])))
    return out


def split_peak(f, mag, f1: float, f2: float, noise: float) -> list[float]:
    """Frequencies [Hz] of the local maxima of |Z| between f1 and f2 that stand out of the dip
    beside them by more than 2 % and by more than 5 noise levels (``noise``: relative): more than one
    means the resonance peak is split (a rocking mode, a surround resonance, a glitch in the sweep),
    and the method's single-peak picture is only approximate there."""
    f, mag = np.asarray(f, float), np.asarray(mag, float)
    band = np.flatnonzero((f >= f1) & (f <= f2))
    if band.size < 3:
        return []
    x = mag[band]
    tops = [i for i in range(1, x.size - 1) if x[i] > x[i - 1] and x[i] >= x[i + 1]]
    thr = max(0.02, 5 * noise)
    keep = []
    for j, i in enumerate(tops):
        lo = tops[j - 1] if j else 0
        hi = tops[j + 1] if j + 1 < len(tops) else x.size - 1
        dip = max(x[lo:i + 1].min(), x[i:hi + 1].min())  # prominence: against the higher neighbouring dip
        if x[i] / dip - 1 > thr:
            keep.append(float(f[band[i]]))
    return keep if len(keep) > 1 else []


def _curve(meas: Measurement, use_phase: bool):
    f = np.asarray(meas.f_hz, float)
    Z = np.asarray(meas.Z, complex)
    keep = np.concatenate([[True], np.diff(f) > 0])
    return f[keep], np.abs(Z[keep]), (np.angle(Z[keep]) if use_phase else None)


def model_free_ts(meas: Measurement, re: float | tuple[float, float], *, re_source: str = "given",
                  loaded: Sequence[tuple[Measurement, float]] = (), use_phase: bool = True,
                  n_draws: int = 400, seed: int = 0) -> ModelFree:
    """Small's model-free T/S values of ``meas`` (module docstring) with 90 % intervals.

    Parameters
    ----------
    meas : the free-air recording (only the band it holds is used: select it beforehand).
    re : Re [ohm], or ``(Re, sd)`` [ohm] (sd 0: exact).
    re_source : where Re comes from, in words (``"model R0"``, ``"ohmmeter"``).
    loaded : ``[(recording, delta_m_kg), ...]`` of the same driver with masses added (negative:
        removed): Mms, Cms, Bl.
    use_phase : locate fs at the phase zero (False: at the |Z| peak, for magnitude-only curves).
    n_draws, seed : resamplings for the intervals and their seed.

    Raises
    ------
    ModelFreeUndefined
        where Small's method is undefined (no peak, two peaks, the curve not falling to √r0·Re).
    """
    re_v, re_sd = (float(re), 0.0) if np.isscalar(re) else (float(re[0]), float(re[1]))
    if not (math.isfinite(re_v) and re_v > 0 and math.isfinite(re_sd) and re_sd >= 0):
        raise ValueError(f"re must be a positive number of ohms (with a non-negative sd), got {re!r}")
    if n_draws < 20:
        raise ValueError(f"n_draws must be at least 20 for 5-95 % quantiles, got {n_draws}")
    curves = [(meas, None)] + [(m, float(dm)) for m, dm in loaded]
    for i, (_, dm) in enumerate(curves[1:]):
        if not (math.isfinite(dm) and dm != 0):
            raise ValueError(f"loaded[{i}]: the added mass must be a non-zero number of kg (negative: "
                             f"removed), got {dm!r}")
    data = []
    for m, _ in curves:
        f, mag, ph = _curve(m, use_phase)
        lf = np.log(f)
        data.append((f, mag, ph, _noise(np.log(mag), lf), 0.0 if ph is None else _noise(ph, lf)))

    def evaluate(curves_xy, re_i, cubic, by_phase=True, inflate=1.0):
        # inflate: a resampled curve carries its own noise plus the added draw (sqrt 2 of it)
        curves_xy = [(f, m, p if by_phase else None) for f, m, p in curves_xy]
        (f, mag, ph), rest = curves_xy[0], curves_xy[1:]
        out = _small(f, mag, ph, re_i, cubic, meas.source, noise=inflate * data[0][3])
        if rest:
            mms = []
            for (fl, ml, pl), (mrec, dm), d in zip(rest, curves[1:], data[1:], strict=True):
                fs_l = resonance(fl, ml, pl, noise=inflate * d[3], where=mrec.source)["fs"]
                ratio = (out["fs"] / fs_l) ** 2 - 1
                if ratio * dm <= 0:
                    moved = "below" if dm > 0 else "above"
                    raise ModelFreeUndefined(f"{mrec.source}: its resonance {fs_l:.4g} Hz is not {moved} "
                                             f"free air's {out['fs']:.4g} Hz although {abs(dm):g} kg was "
                                             f"{'added' if dm > 0 else 'removed'}")
                mms.append(dm / ratio)
            ws = 2 * math.pi * out["fs"]
            m_ = float(np.mean(mms))
            out.update(Mms=m_, Cms=1.0 / (ws * ws * m_), Bl=math.sqrt(ws * m_ * out["Re"] / out["Qes"]))
        return out

    point = evaluate([(f, mag, ph) for f, mag, ph, _, _ in data], re_v, False)
    rng = np.random.default_rng(seed)
    draws: dict[str, list[float]] = {k: [] for k in point}
    failed, why = 0, ""
    for _ in range(n_draws):
        xy = [(f, *_perturbed(mag, ph, s_m, s_p, rng)) for f, mag, ph, s_m, s_p in data]
        re_i = re_v + re_sd * rng.standard_normal()
        try:
            v = evaluate(xy, re_i, bool(rng.integers(2)), bool(rng.integers(2)), math.sqrt(2.0))
        except (ModelFreeUndefined, ValueError, ZeroDivisionError) as exc:
            failed += 1
            why = why or str(exc).split(": ", 1)[-1]
            continue
        for k in draws:
            draws[k].append(v[k])
    if len(draws["fs"]) < n_draws // 2:
        raise ModelFreeUndefined(f"{meas.source}: Small's method fails on {failed} of {n_draws} resamplings "
                                 f"of the curve within its noise (e.g. {why}): the peak is not resolved "
                                 "above the noise; narrow the band")
    params = {}
    for k, v0 in point.items():
        lo, hi = np.quantile(np.asarray(draws[k]), [0.05, 0.95])
        params[k] = {"value": float(v0), "ci90": [float(lo), float(hi)], "unit": UNITS_MF[k]}
    f0, mag0, _, noise0, _ = data[0]
    notes = []
    split = split_peak(f0, mag0, point["f1"], point["f2"], noise0)
    if split:
        notes.append("split resonance peak: |Z| has maxima at " + ", ".join(f"{x:.4g}" for x in split)
                     + " Hz between f1 and f2 (a rocking mode, a surround resonance or a glitch in the "
                     "sweep): Small's single-peak values are approximate here")
    inputs = {"method": MODEL_FREE_METHOD, "notes": notes, "re_ohm": re_v, "re_sd_ohm": re_sd,
              "phase_used": bool(use_phase and data[0][2] is not None),
              "noise_log_abs_z": data[0][3], "noise_phase_rad": data[0][4], "n_draws": int(n_draws),
              "failed_draws": int(failed), "seed": int(seed), "source": meas.source,
              "loaded": [{"source": m.source, "delta_m_kg": dm} for m, dm in curves[1:]]}
    return ModelFree(parameters=params, re_source=re_source, inputs=inputs)
