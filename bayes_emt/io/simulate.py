"""Simulated measurements: any model, any parameters, relative complex Gaussian noise."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..measurement import Measurement
from ..models import Model

__all__ = ["simulate", "log_omega_grid"]


def log_omega_grid(omega_min: float = 1e1, omega_max: float = 1e5, points: int = 2000) -> np.ndarray:
    """``points`` log-spaced angular frequencies [rad/s] (the paper: 2000 over 1e1..1e5)."""
    if not (0 < omega_min < omega_max and np.isfinite(omega_max)):
        raise ValueError(f"need 0 < omega_min < omega_max, got {omega_min}, {omega_max}")
    if int(points) != points or points < 2:
        raise ValueError(f"points must be an integer >= 2, got {points!r}")
    return np.geomspace(omega_min, omega_max, int(points))


def simulate(model: Model, parameters: Mapping[str, float] | np.ndarray, omega=None, *,
             noise: float = 0.0, seed: int | None = None, source: str = "simulated") -> Measurement:
    """Simulate a measurement of ``model`` at ``parameters``.

    Noise model: ``Y_meas = Y (1 + noise (e_r + j e_i))`` with ``e_r, e_i`` independent standard
    normal, i.e. each of the real and imaginary parts of the *relative* error has standard
    deviation ``noise`` (0.002 = 0.2 %). The same seed gives the same data.
    """
    theta = (model.vector(parameters) if isinstance(parameters, Mapping)
             else np.asarray(parameters, float))
    if theta.shape != (model.ndim,):
        raise ValueError(f"model {model.label} needs {model.ndim} parameters, got shape {theta.shape}")
    if not np.all(model.params.in_support(theta)):
        bad = [spec.name for spec, v in zip(model.params, theta, strict=True)
               if not np.isfinite(spec.prior.logpdf(v))]
        raise ValueError(f"parameters outside their prior support: {bad}")
    if noise < 0 or not np.isfinite(noise):
        raise ValueError(f"noise must be a non-negative number, got {noise!r}")
    omega = log_omega_grid() if omega is None else np.asarray(omega, float)
    model = model.bind(omega)
    Y = model.admittance(omega, theta)
    if noise > 0:
        rng = np.random.default_rng(seed)
        Y = Y * (1.0 + noise * (rng.standard_normal(Y.shape) + 1j * rng.standard_normal(Y.shape)))
    meta = {"source": source, "simulated": True, "model": model.spec, "rings": model.rings,
            "n_turns": model.n_turns, "terms": [t.to_dict() for t in model.terms],
            "truth": model.as_dict(theta), "noise_rel": float(noise), "seed": seed}
    return Measurement(omega, Y, meta=meta)
