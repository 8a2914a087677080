"""Can the fitted model describe the data? Warnings a least-squares fit carries with its numbers.

A fit always returns numbers; this module says when they should not be trusted. It is pure: it
takes the model, the measurement, the estimate, its residuals and Jacobian, and returns
``{"code", "message"}`` records (:attr:`~bayes_emt.estimation.results.FitResult.warnings`):

``model_inadequate``
    The residuals are far above the noise level *and* structured along frequency (the model
    cannot follow the data there), or the estimate is physically impossible: ``R0`` above the
    smallest measured ``|Z|`` (``Re Z ≥ R0`` for the passive plant of eq. 47, so ``|Z| ≥ R0``),
    a mechanical ``Q = 1/(2ζ)`` below 0.5 or above 1e4, or ``ω0`` away from the impedance peak
    the data show. The message says where (band in Hz and rad/s) and what to try.
``parameter_at_bound``
    A parameter ends within 0.1 % of its prior support's width (in sampling space) of an edge.
``not_identifiable``
    The data do not determine some parameters: standard error larger than the value (log
    parameters: ``sd(log x) > 1``), or a rank-deficient Jacobian. Names them; for rings,
    suggests fewer.
``resonance_outside_data``
    The band shows no impedance peak, or the fitted ``ω0`` lies outside the measured band.

How "far above the noise" is decided without knowing the noise
---------------------------------------------------------------
The fit does not know the noise level, but noise and misfit differ in *structure*. With
``e_k = w_k (Y_fit − Y_k)/|Y_k|`` the relative residuals in frequency order (``w_k`` the
measurement's weights), measurement noise is rough (independent from point to point) and
misfit is smooth in log-frequency (the model's error is an analytic function of ω). So:

1. *Noise from the rough part.* Second differences ``d_k = e_{k+1} − 2 e_k + e_{k−1}`` remove
   any locally linear (smooth) component; for white noise of standard deviation σ per real and
   imaginary part, ``|d_k|²/(6σ²)`` is χ² with 2 degrees of freedom, whose median is ``2 ln 2``.
   The local noise level ``σ̂_k`` is ``sqrt(median |d|² / (12 ln 2))`` over a running window of
   ``W_σ = clip(n/10, 21, 201)`` points (a median, so a misfit that changes fast over a few
   points does not inflate it; local, so noise that grows with frequency is allowed for), and
   never below ``NOISE_FLOOR`` = 1e-6 (noise-free data: residuals are round-off and the
   optimiser's tolerance, not misfit).
2. *Misfit amplitude.* ``u_k = e_k/σ̂_k`` is white with unit variance per part when the model is
   adequate. ``ρ_k² = mean(|u|²)/2`` over a running window of ``W_s = clip(n/50, 5, 51)`` points
   is the local residual power in units of the noise: 1 for an adequate model.
3. *Structure.* A Wald–Wolfowitz runs test on the signs of ``Re u`` and ``Im u`` along
   frequency; their z-scores combined as ``z = (z_re + z_im)/√2`` (N(0, 1) for white residuals;
   strongly negative when residuals come in long same-sign stretches). The lag-1
   autocorrelation is reported too.

``model_inadequate`` fires when ``z ≤ −5`` **and** ``ρ_k ≥ 3`` somewhere (``RHO_CRIT``,
``Z_CRIT``): residuals three times the noise the data themselves show, in long same-sign
stretches. The band reported is where ``ρ_k ≥ 3``.

Calibration (``scripts/calibrate_adequacy.py --seeds 20``, stored in
``scripts/results/adequacy_calibration.jsonl``; 0.2 % relative complex noise on the paper's
2000-point grid unless said otherwise):

* adequate fits, the model that simulated the data: NL(5) at Table 5, UD at Table 4 and I at
  Table 1, 20 seeds each, plus the bundled dataset with NL(5) — 61 fits: ``max ρ_k`` 1.16–1.40,
  runs ``z`` −2.49…+2.50, ``model_inadequate`` fired 0 times (nor any other code);
* a driver in a vented box (``enclosure_port`` simulated; four
  loudspeaker-like parameter sets: fs 30–58 Hz, port 25–45 Hz, R0 3.3–6.8 Ω; noise 0.2, 0.5 and
  1 %) fitted with UD and NL(5) — 24 fits: ``max ρ_k`` 69–711, ``z`` −62.9…−52.8, fired 24 times
  (parameter_at_bound in 7 of them, not_identifiable in 12: the NL fits push R0 or rings to
  absurd values to bend towards the second peak);
* the control, the same four drivers in free air (exactly UD) fitted with UD at 0.2 and 1 %
  noise — 8 fits: ``max ρ_k`` 1.20–1.29, ``z`` −2.07…+1.21, never fired.

So the thresholds sit twice the null's largest ρ and five null standard deviations of ``z`` away,
and twenty times below the smallest misfit met. A smaller misfit can go unflagged, by design
("far above" the noise). On the real recordings of ``../shared/realdata``
(``scripts/realdata_table.py --messages``) every model gets ``model_inadequate``: their rough-part
noise is 0.002–0.2 % of |Y| while even the best fit, NL(5), leaves structured misfits of 0.5–3.8 %
of |Y| at its worst point (``max ρ_k`` 24–347), near the resonance (suspension creep, a second
mode) and in the coil's band. That is what the data say about these models, not a false alarm of
the detector; the message gives the numbers so a reader can judge whether a few per cent matter.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..measurement import Measurement
from ..models import Model
from ..models.residual import relative_residual

__all__ = ["ResidualStructure", "residual_structure", "assess_fit", "edges_reached", "relative_sd",
           "RHO_CRIT", "Z_CRIT", "AT_BOUND_FRAC",
           "Q_RANGE", "NOISE_FLOOR"]

RHO_CRIT = 3.0  #: local residual rms, in units of the local noise, that counts as "far above"
Z_CRIT = 5.0  #: runs-test z-score (negative) that counts as structure
AT_BOUND_FRAC = 1e-3  #: distance to a prior edge, as a fraction of the support's width (sampling space)
Q_RANGE = (0.5, 1e4)  #: plausible mechanical Q = 1/(2 zeta) of a transducer's resonance
#: smallest noise level assumed [fraction of |Y|]: no instrument resolves an impedance to 1 ppm, so
#: residuals below it (noise-free simulations: the optimiser's tolerance, round-off) are no misfit
NOISE_FLOOR = 1e-6
_MIN_POINTS = 20  #: fewer points: the residual tests are not attempted
_RING = re.compile(r"^[PR][1-9]\d*$")  # ring parameters P1..Pn, R1..Rn (R0 is the coil's resistance)


@dataclass(frozen=True)
class ResidualStructure:
    """Noise and structure of relative residuals along frequency (module docstring).

    Attributes
    ----------
    noise : (n,) local noise level σ̂_k per real/imaginary part [fraction of |Y|].
    rho : (n,) local residual rms in units of the local noise (1: white noise).
    runs_z : combined runs-test z-score of the signs of the real and imaginary parts.
    lag1 : lag-1 autocorrelation of the normalised residuals (0: white).
    rms : rms relative residual per part over all points [1].
    """

    noise: np.ndarray
    rho: np.ndarray
    runs_z: float
    lag1: float
    rms: float

    @property
    def rho_max(self) -> float:
        return float(np.max(self.rho))

    def structured(self) -> bool:
        """True when the residuals are far above the noise with structure (module docstring)."""
        return self.runs_z <= -Z_CRIT and self.rho_max >= RHO_CRIT


def _running(x: np.ndarray, width: int, fun) -> np.ndarray:
    """``fun`` over a centred window of ``width`` points (shrunk at the ends)."""
    half = width // 2
    pad = np.pad(x, half, mode="reflect") if x.size > half else np.pad(x, half, mode="edge")
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * half + 1)
    return fun(win, axis=-1)[: x.size]


def _runs_z(x: np.ndarray) -> float:
    """Wald–Wolfowitz runs test on the signs of ``x``: z-score of the number of runs."""
    s = x[x != 0] > 0
    n = s.size
    n1 = int(np.count_nonzero(s))
    n2 = n - n1
    if n1 == 0 or n2 == 0:
        return -math.inf if n > 1 else 0.0
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    mu = 2.0 * n1 * n2 / n + 1.0
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1.0))
    return (runs - mu) / math.sqrt(var) if var > 0 else 0.0


def residual_structure(e: np.ndarray) -> ResidualStructure:
    """Noise level, local misfit power and structure of complex relative residuals ``e`` (frequency
    order). Needs at least 5 points."""
    e = np.asarray(e, complex)
    n = e.size
    d2 = np.abs(e[2:] - 2 * e[1:-1] + e[:-2]) ** 2
    d2 = np.concatenate([d2[:1], d2, d2[-1:]])  # one value per point
    w_sigma = int(np.clip(n // 10, 21, 201))
    med = _running(d2, min(w_sigma, n - (n + 1) % 2), np.median)
    noise = np.sqrt(med / (12 * math.log(2)))
    noise = np.maximum(noise, NOISE_FLOOR)
    u = e / noise
    w_s = int(np.clip(n // 50, 5, 51))
    rho = np.sqrt(_running(np.abs(u) ** 2 / 2, w_s, np.mean))
    runs = (_runs_z(u.real) + _runs_z(u.imag)) / math.sqrt(2)
    uc = u - u.mean()
    den = float(np.sum(np.abs(uc) ** 2))
    lag1 = float(np.sum((uc[1:] * np.conj(uc[:-1])).real) / den) if den > 0 else 0.0
    return ResidualStructure(noise, rho, float(runs), lag1, float(np.sqrt(np.mean(np.abs(e) ** 2) / 2)))


def _band(omega: np.ndarray, mask: np.ndarray) -> str:
    """``'a–b Hz (c–d rad/s)'`` for the stretches of ``mask`` (gaps of under 1 % of the points
    closed; the three widest, in frequency order)."""
    idx = np.flatnonzero(mask)
    gap = max(2, omega.size // 100)
    cuts = np.flatnonzero(np.diff(idx) > gap)
    starts = np.r_[idx[0], idx[cuts + 1]]
    stops = np.r_[idx[cuts], idx[-1]]
    order = np.argsort(stops - starts, kind="stable")[::-1][:3]
    parts = []
    for j in sorted(order):
        lo, hi = omega[starts[j]], omega[stops[j]]
        parts.append(f"{lo / (2 * math.pi):.4g}–{hi / (2 * math.pi):.4g} Hz ({lo:.4g}–{hi:.4g} rad/s)")
    return ", ".join(parts)


def _advice(model: Model, theta: np.ndarray, omega: np.ndarray, where: np.ndarray) -> str:
    """What to try, given where the misfit is relative to the mechanical resonance."""
    if "omega0" not in model.names:
        return "try a richer model"
    w0 = float(theta[model.names.index("omega0")])
    lo, hi = float(omega[where].min()), float(omega[where].max())
    tips = []
    if lo < 10 * w0:
        tips.append("near the mechanical resonance: a second resonance (a vented box or passive "
                    "radiator: enclosure_port; a rocking or fixture mode: second_resonance) or "
                    "suspension creep; fit the driver in free air, or restrict the band")
    if hi > 3 * w0:
        tips.append("in the coil's band: a richer eddy-current model (UD, or NL with more rings), "
                    "semi-inductance or winding capacitance")
    return "; ".join(tips) or "try a richer model"


def _physical(model: Model, meas: Measurement, theta: np.ndarray, noise: float, resonance,
              info: dict) -> list[str]:
    """Reasons the estimate is physically impossible (empty when none)."""
    names, out = model.names, []
    p = dict(zip(names, theta, strict=True))
    absz = np.abs(meas.Z)
    i = int(np.argmin(absz))
    if "R0" in p and p["R0"] > absz[i] * (1 + max(5 * noise, 0.005)):
        f = meas.omega[i]
        out.append(f"R0 = {p['R0']:.4g} ohm exceeds the smallest measured |Z| = {absz[i]:.4g} ohm (at "
                   f"{f / (2 * math.pi):.4g} Hz, {f:.4g} rad/s), impossible for the passive plant "
                   "(Re Z >= R0)")
    if "zeta" in p and resonance is not None:
        q = 1 / (2 * p["zeta"])
        if not Q_RANGE[0] <= q <= Q_RANGE[1]:
            out.append(f"the mechanical Q = 1/(2 zeta) = {q:.3g} is outside {Q_RANGE[0]:g}..{Q_RANGE[1]:g} "
                       "although the data show a resonance peak")
    if info.get("resonance_mismatch") and resonance is not None and "omega0" in p:
        out.append(f"omega0 = {p['omega0']:.4g} rad/s ({p['omega0'] / (2 * math.pi):.4g} Hz) lies away "
                   f"from the impedance peak the data show at {resonance.omega:.4g} rad/s "
                   f"({resonance.omega / (2 * math.pi):.4g} Hz)")
    return out


def edges_reached(params, z, lo, hi) -> list[tuple[int, str]]:
    """``(index, "lower" | "upper")`` of each parameter of ``params`` whose sampling-space value ``z``
    lies within :data:`AT_BOUND_FRAC` of its support's width ``[lo, hi]`` of an edge (finite
    supports only): the rule of the ``parameter_at_bound`` warning."""
    out = []
    for i, (zi, a, b) in enumerate(zip(np.asarray(z, float), np.asarray(lo, float), np.asarray(hi, float),
                                       strict=True)):
        width = b - a
        if not np.isfinite(width):
            continue
        edge = "lower" if zi - a <= AT_BOUND_FRAC * width else "upper" if b - zi <= AT_BOUND_FRAC * width \
            else None
        if edge:
            out.append((i, edge))
    return out


def relative_sd(params, theta, cov_z) -> np.ndarray:
    """Each parameter's standard error relative to its value (``sd(log x)`` for log parameters) from
    the sampling-space covariance ``cov_z``: above 1 the data do not determine it (the rule of the
    ``not_identifiable`` warning)."""
    sd = np.sqrt(np.clip(np.diag(cov_z), 0, None))
    return np.array([s if spec.transform == "log" else s / max(abs(x), np.finfo(float).tiny)
                     for spec, x, s in zip(params, np.asarray(theta, float).ravel(), sd, strict=True)])


def _at_bound(model: Model, z: np.ndarray, lo: np.ndarray, hi: np.ndarray, theta) -> list[str]:
    out = []
    for i, edge in edges_reached(model.params, z, lo, hi):
        spec, x = model.params[i], theta[i]
        d = spec.prior.to_dict()
        support = f"{d.get('lower', float('nan')):g}..{d.get('upper', float('nan')):g}"
        out.append(f"{spec.name} = {x:.4g} {spec.unit} ({edge} edge of {support} {spec.unit})")
    return out


def _unidentified(model: Model, theta, cov_z, jacobian) -> tuple[list[str], str]:
    """Names of parameters the data do not determine, and why."""
    if cov_z is None:
        if jacobian is None:
            return [], ""
        _, sv, vt = np.linalg.svd(jacobian, full_matrices=False)
        null = vt[sv <= sv[0] * 1e-10]
        load = np.max(np.abs(null), axis=0) if null.size else np.zeros(model.ndim)
        names = [n for n, v in zip(model.names, load, strict=True) if v > 0.1]
        return names, "the Jacobian is rank-deficient (no standard errors)"
    sd = np.sqrt(np.clip(np.diag(cov_z), 0, None))
    names, worst = [], []
    for spec, x, s, rel in zip(model.params, theta, sd, relative_sd(model.params, theta, cov_z), strict=True):
        if rel > 1:
            names.append(spec.name)
            se = abs(x) * s if spec.transform == "log" else s
            worst.append(f"{spec.name} = {x:.3g} +- {se:.2g} {spec.unit}")
    return names, "standard error larger than the value: " + ", ".join(worst)


def assess_fit(model: Model, meas: Measurement, theta: np.ndarray, *, z: np.ndarray, bounds_z,
               cov_z: np.ndarray | None, jacobian: np.ndarray | None, resonance=None,
               info: dict | None = None) -> tuple[dict, ...]:
    """The warnings of a fit (module docstring).

    Parameters
    ----------
    model, meas, theta : the model, the data (rad/s, S) and the estimate (physical, SI).
    z, bounds_z : the estimate in sampling space and the prior support ``(lo, hi)`` there.
    cov_z : the estimate's covariance in sampling space, or ``None`` (rank-deficient Jacobian).
    jacobian : ``(2n, k)`` Jacobian of the stacked relative residuals in sampling space.
    resonance : :class:`~bayes_emt.estimation.checks.Resonance` the data show, or ``None``.
    info : the fit's ``info`` (``resonance_mismatch`` is read).

    Returns
    -------
    tuple of dict
        ``{"code", "message"}`` records, at most one per code.
    """
    info = info or {}
    theta = np.asarray(theta, float)
    out = []
    e = relative_residual(model, theta, meas)
    if meas.weights is not None:
        e = e * meas.weights
    rs = residual_structure(e) if meas.n_points >= _MIN_POINTS else None
    noise = float(np.median(rs.noise)) if rs is not None else 0.0
    why = []
    if rs is not None and rs.structured():
        above = rs.rho >= RHO_CRIT
        worst = rs.rho >= max(RHO_CRIT, rs.rho_max / 3)  # where the misfit is largest
        k = int(np.argmax(rs.rho))
        why.append(f"the residuals are up to {rs.rho_max:.3g} times the noise level the data show "
                   f"({100 * rs.noise[k]:.2g} % of |Y| there), in long same-sign stretches (runs test "
                   f"z = {rs.runs_z:.1f}, lag-1 correlation {rs.lag1:.2f}); above 3 times the noise in "
                   f"{_band(meas.omega, above)}, largest in {_band(meas.omega, worst)}, worst at "
                   f"{meas.f_hz[k]:.4g} Hz ({meas.omega[k]:.4g} rad/s) with {100 * abs(e[k]):.3g} % of |Y|; "
                   f"try: {_advice(model, theta, meas.omega, worst)}")
    why += _physical(model, meas, theta, noise, resonance, info)
    if why:
        out.append({"code": "model_inadequate",
                    "message": f"{model.label} cannot describe these data: " + "; ".join(why)})
    lo, hi = bounds_z
    edges = _at_bound(model, np.asarray(z, float), np.asarray(lo, float), np.asarray(hi, float), theta)
    if edges:
        out.append({"code": "parameter_at_bound",
                    "message": "at the edge of the prior support: " + ", ".join(edges)
                    + "; the data push it out of the physical range (a wrong model, or a prior too narrow)"})
    names, reason = _unidentified(model, theta, cov_z, jacobian)
    if names:
        rings = [n for n in names if _RING.match(n)] if model.rings is not None else []
        tip = (f"use fewer rings than {model.rings} (bayes-emt hankel chooses the count)" if rings
               else "measure a band where they act, or fix them from another source")
        out.append({"code": "not_identifiable",
                    "message": f"the data do not determine {', '.join(names)} ({reason}); {tip}"})
    band = f"{meas.f_hz[0]:.4g}–{meas.f_hz[-1]:.4g} Hz ({meas.omega[0]:.4g}–{meas.omega[-1]:.4g} rad/s)"
    if "omega0" in model.names:
        w0 = float(theta[model.names.index("omega0")])
        if resonance is None:
            out.append({"code": "resonance_outside_data",
                        "message": f"no mechanical resonance (impedance peak) in {band}: zeta, omega0 "
                                   "and phi are not identifiable; measure a band that contains the peak"})
        elif not meas.omega[0] <= w0 <= meas.omega[-1]:
            out.append({"code": "resonance_outside_data",
                        "message": f"the fitted omega0 = {w0:.4g} rad/s ({w0 / (2 * math.pi):.4g} Hz) lies "
                                   f"outside the measured band {band}"})
    return tuple(out)
