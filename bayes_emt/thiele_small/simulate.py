"""Simulated drivers of known T/S parameters: free air, added masses and a sealed test box, with
relative complex Gaussian noise (the coverage studies, tests and the benchmark use it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..measurement import Measurement
from ..models import parse_model_spec
from .relations import free_air, with_mass, with_sd

__all__ = ["SimulatedDriver", "simulate_driver", "DEFAULT_DRIVER"]

#: a 6.5" woofer with a semi-inductance (Leach) coil: Mms 14.9 g, fs 42 Hz, Qms 3, Bl 7 T m, Re 5.7 Ω
DEFAULT_DRIVER = {"m": 0.0149, "fs": 42.0, "Qms": 3.0, "Bl": 7.0, "R0": 5.7, "L0": 2e-4, "K_semi": 0.02,
                  "n_semi": 0.6, "lambda_creep": 0.05, "Lg": 4e-4, "alpha": 1.5e-4, "beta": 0.12}


@dataclass(frozen=True)
class SimulatedDriver:
    """Recordings and the true T/S values (relations of :mod:`~bayes_emt.thiele_small.relations`)."""

    spec: str
    free: Measurement
    loaded: tuple[tuple[Measurement, float], ...]
    box: tuple[Measurement, float] | None
    truth: dict[str, float]
    sd: float


def simulate_driver(spec: str = "I+semi_inductance", *, driver: dict | None = None,
                    deltas=(0.010, 0.020), box_volume: float | None = None, sd: float = 0.0133,
                    noise: float = 0.005, seed: int = 0, f_hz=(10.0, 2000.0), n_points: int = 2000,
                    rho: float = 1.18, c: float = 343.0) -> SimulatedDriver:
    """Free air, one recording per added mass ``deltas`` [kg] and optionally one in a sealed box of
    ``box_volume`` [m³] (its air spring adds ``ρ c² Sd²/Vb`` to the stiffness; mass, loss and
    creep unchanged), each with relative noise ``noise`` (complex Gaussian on Z, per part
    ``noise/√2``) on ``n_points`` log-spaced frequencies over ``f_hz``."""
    from ..added_mass.multi import MultiMassModel

    d = {**DEFAULT_DRIVER, **(driver or {})}
    model = parse_model_spec(spec)
    m = d["m"]
    k = m * (2 * math.pi * d["fs"]) ** 2
    phys = {"m": m, "c": 2 * math.pi * d["fs"] * m / d["Qms"], "k": k, "phi_raw": d["Bl"]}
    rng = np.random.default_rng(seed)
    omega = 2 * math.pi * np.geomspace(f_hz[0], f_hz[1], n_points)

    def record(theta, label):
        Z = 1.0 / model.admittance(omega, theta)
        e = (rng.standard_normal(Z.size) + 1j * rng.standard_normal(Z.size)) * noise / math.sqrt(2)
        return Measurement.from_impedance(omega, Z * (1 + e),
                                          meta={"source": f"simulated {label} (seed {seed})"})

    jm = MultiMassModel(model, tuple(deltas) if deltas else (1.0,))
    x = np.array([phys[n] if n in phys else d[n] for n in jm.names])
    thetas = jm.thetas(x)
    free = record(thetas[0], "free air")
    loaded = tuple((record(th, f"+{dm * 1e3:g} g"), float(dm))
                   for th, dm in zip(thetas[1:], deltas, strict=False))
    th0 = thetas[0][None, :]
    truth = free_air(model, th0)
    truth = with_sd(with_mass(truth, model, th0, m), sd, rho, c)
    box = None
    if box_volume is not None and "lambda_creep" in model.names:
        raise ValueError("a sealed box is simulated for models without creep only (the box's air spring is "
                         "not a LOG-creep stiffness)")
    if box_volume is not None:
        kb = rho * c * c * sd * sd / box_volume
        xb = x.copy()
        xb[jm.names.index("k")] = k + kb
        box = (record(jm.thetas(xb)[0], "sealed box"), float(box_volume))
    return SimulatedDriver(spec, free, loaded, box, {kk: float(v[0]) for kk, v in truth.items()}, sd)
