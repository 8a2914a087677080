"""The fitted impedance curve a T/S result carries, so that a figure of the fit (``ts --plot``, the
report's T/S section) can be drawn from the saved result alone, without the recording.

``curve`` (plain lists, JSON-ready; frequencies in Hz, |Z| in Ω, phase in degrees):

* ``f_hz``, ``data_abs_z_ohm``, ``data_phase_deg``: the free-air recording (at most
  :data:`MAX_POINTS` points, evenly spaced in log frequency, when it has more);
* ``fit_abs_z_ohm``, ``fit_phase_deg``: the posterior median of the model curve;
* ``band_abs_z_ohm``, ``band_phase_deg``: ``[lo, hi]`` lists, the central 90 % of the posterior
  predictive: each of :data:`N_DRAWS` parameter draws (posterior, or the fit's Gaussian
  approximation with ``fast``) plus one replicated measurement noise, complex Gaussian of relative
  scale ``rms/√2`` per real and imaginary part, ``rms`` the fit's rms relative residual (a plug-in
  noise level: the same for every draw);
* ``band``: those words; ``model``: the model spec; ``source``: the recording;
* ``bench``: the measuring program's own fit of the same curve when the file carries one
  (``{"f_hz", "abs_z_ohm", "label"}``, from the reader's ``meta["bench_fit"]["curve"]``, the label
  its ``meta["bench_fit"]["bench"]``, e.g. ``"DATS"``), else absent.
"""

from __future__ import annotations

import numpy as np

from ..measurement import Measurement

__all__ = ["fit_curve", "MAX_POINTS", "N_DRAWS", "BAND"]

MAX_POINTS = 400
N_DRAWS = 300
BAND = ("central 90 % of the posterior predictive: parameter draws plus measurement noise at the fit's "
        "rms relative residual")


def _thin(n: int, f: np.ndarray) -> np.ndarray:
    if n <= MAX_POINTS:
        return np.arange(n)
    target = np.geomspace(f[0], f[-1], MAX_POINTS)
    return np.unique(np.clip(np.searchsorted(f, target), 0, n - 1))


def _bench(meas: Measurement) -> dict | None:
    bench = meas.meta.get("bench_fit") if hasattr(meas.meta, "get") else None
    curve = bench.get("curve") if isinstance(bench, dict) else None
    if not isinstance(curve, dict):
        return None
    try:
        f = np.asarray(curve["f_hz"], float)
        z = np.asarray(curve["abs_z_ohm"], float)
    except (KeyError, TypeError, ValueError):
        return None
    if f.ndim != 1 or f.shape != z.shape or f.size < 2:
        return None
    keep = _thin(f.size, f)
    label = str(bench.get("bench") or bench.get("label") or "bench")
    return {"f_hz": f[keep].tolist(), "abs_z_ohm": z[keep].tolist(), "label": label}


def fit_curve(model, theta, meas: Measurement, rms_rel: float, seed: int) -> dict:
    """The ``curve`` record (module docstring) of ``model`` at parameter draws ``theta (n, k)`` on
    ``meas``; ``rms_rel`` is the fit's rms relative residual."""
    rng = np.random.default_rng(seed)
    theta = np.atleast_2d(np.asarray(theta, float))
    if theta.shape[0] > N_DRAWS:
        theta = theta[rng.choice(theta.shape[0], N_DRAWS, replace=False)]
    idx = _thin(meas.n_points, meas.f_hz)
    omega, f = meas.omega[idx], meas.f_hz[idx]
    zm = 1.0 / model.admittance(omega, theta)
    sigma = float(rms_rel) / np.sqrt(2.0) if np.isfinite(rms_rel) else 0.0
    zp = zm * (1.0 + sigma * (rng.standard_normal(zm.shape) + 1j * rng.standard_normal(zm.shape)))
    zmed = np.median(zm.real, axis=0) + 1j * np.median(zm.imag, axis=0)
    zd = meas.Z[idx]

    def q(x):
        lo, hi = np.quantile(x, [0.05, 0.95], axis=0)
        return [lo.tolist(), hi.tolist()]

    out = {"f_hz": f.tolist(), "data_abs_z_ohm": np.abs(zd).tolist(),
           "data_phase_deg": np.degrees(np.angle(zd)).tolist(), "fit_abs_z_ohm": np.abs(zmed).tolist(),
           "fit_phase_deg": np.degrees(np.angle(zmed)).tolist(), "band_abs_z_ohm": q(np.abs(zp)),
           "band_phase_deg": q(np.degrees(np.angle(zp))), "band": BAND, "model": model.label,
           "source": meas.source, "rms_rel_residual": float(rms_rel), "n_draws": int(theta.shape[0])}
    bench = _bench(meas)
    if bench is not None:
        out["bench"] = bench
    return out
