"""A driver in a vented box, simulated for the adequacy tests (a local helper: not a catalogue term).

SPEC §7 ``enclosure_port``: the box compliance and the port's air mass add a series L–C–R branch
to the motional admittance,

    1/Zmot ← 1/Zmot + (s/Lb) / (s² + 2 ζb ωb s + ωb²),        Zmot = φ̄² s / (s² + 2 ζ ω0 s + ω0²),

so ``Z = Zc(s) + R0 + Zmot'(s)`` shows two impedance peaks with a minimum near the port tuning
ωb between them. In the impedance analogy the driver's suspension compliance is the inductance
``Lces = φ̄²/ω0²``; the box's, ``Lb = Lces/α`` with ``α = Vas/Vb`` the compliance ratio (1–3 for
usual alignments), and ``ζb = 1/(2 Qb)`` with box losses ``Qb`` of 5–15.

The parameter sets are loudspeaker-like (Bl 6–15 N/A, Mms 15–60 g, so φ̄ = Bl/√Mms 40–90 N/(A
kg^½); fs 30–60 Hz; Qms 3–8; R0 3–7 Ω; a UD coil of about 0.5–1.5 mH) and the tunings 25–45 Hz.
"""

from __future__ import annotations

import math

import numpy as np

from bayes_emt import build_model
from bayes_emt.measurement import Measurement

#: (driver UD parameters, port tuning fb [Hz], compliance ratio alpha, box Q) per case
VENTED_CASES = [
    ({"zeta": 1 / (2 * 4.0), "omega0": 2 * math.pi * 35, "phi": 10 / math.sqrt(0.045), "R0": 5.6,
      "Lg": 4e-4, "alpha": 1.5e-4, "beta": 0.12}, 30.0, 2.0, 7.0),
    ({"zeta": 1 / (2 * 6.0), "omega0": 2 * math.pi * 50, "phi": 7 / math.sqrt(0.02), "R0": 3.3,
      "Lg": 2e-4, "alpha": 8e-5, "beta": 0.08}, 42.0, 1.5, 10.0),
    ({"zeta": 1 / (2 * 3.0), "omega0": 2 * math.pi * 58, "phi": 14 / math.sqrt(0.06), "R0": 6.8,
      "Lg": 6e-4, "alpha": 2e-4, "beta": 0.2}, 45.0, 2.5, 5.0),
    ({"zeta": 1 / (2 * 8.0), "omega0": 2 * math.pi * 30, "phi": 8 / math.sqrt(0.03), "R0": 4.2,
      "Lg": 3e-4, "alpha": 1e-4, "beta": 0.1}, 25.0, 1.2, 12.0),
]


def vented_box_impedance(omega, driver: dict, fb_hz: float, alpha: float, qb: float) -> np.ndarray:
    """Terminal impedance [ohm] of a UD driver in a vented box tuned to ``fb_hz`` (module docstring)."""
    model = build_model("UD")
    theta = model.vector(driver)
    s = 1j * np.asarray(omega, float)
    zc_r0 = model.electrical_impedance_s(s, theta)
    z, w0, phi = driver["zeta"], driver["omega0"], driver["phi"]
    y_mot = (s * s + 2 * z * w0 * s + w0 * w0) / (phi * phi * s)
    lb = phi * phi / (w0 * w0) / alpha
    wb, zb = 2 * math.pi * fb_hz, 1 / (2 * qb)
    y_box = (s / lb) / (s * s + 2 * zb * wb * s + wb * wb)
    return zc_r0 + 1 / (y_mot + y_box)


def simulate_vented_box(case: int, *, noise: float, seed: int, omega=None, port: bool = True) -> Measurement:
    """Case ``case`` of :data:`VENTED_CASES` on ``omega`` (default 2000 log points over 2π·10 Hz ..
    2π·20 kHz) with the simulator's relative complex Gaussian noise; ``port=False``: the same
    driver in free air (the control)."""
    driver, fb, alpha, qb = VENTED_CASES[case]
    omega = np.geomspace(2 * math.pi * 10, 2 * math.pi * 2e4, 2000) if omega is None else np.asarray(omega)
    if port:
        Z = vented_box_impedance(omega, driver, fb, alpha, qb)
    else:
        model = build_model("UD")
        Z = model.impedance(omega, model.vector(driver))
    rng = np.random.default_rng(seed)
    Y = (1 / Z) * (1 + noise * (rng.standard_normal(Z.shape) + 1j * rng.standard_normal(Z.shape)))
    return Measurement(omega, Y, meta={"source": f"vented box case {case}" if port else f"driver {case}",
                                       "noise_rel": noise, "seed": seed})


def simulate_parallel_vented(*, noise: float, seed: int, omega=None) -> Measurement:
    """Two drivers of the same type wired in parallel in one vented box (each loading its half of the
    box: the compliance ratio doubled), simulated as the parallel connection of the two terminal
    impedances: case 1's driver and a second sample whose fs is 12 % higher, Qms 35 % lower and coil
    10 % larger (sample spread of one driver type; the same Bl and moving mass, so the same box branch
    in each half), port tuned to 42 Hz. One lumped driver cannot
    hold two mechanical resonances: the curve has three impedance peaks' worth of structure."""
    driver, fb, alpha, qb = VENTED_CASES[1]
    other = {**driver, "omega0": driver["omega0"] * 1.12, "zeta": driver["zeta"] / 0.65,
             "R0": driver["R0"] * 1.1, "Lg": driver["Lg"] * 1.1, "beta": driver["beta"] * 1.1}
    omega = np.geomspace(2 * math.pi * 10, 2 * math.pi * 2e4, 2000) if omega is None else np.asarray(omega)
    # the compliance ratio is Vas/Vb and Vas is proportional to the suspension's compliance: the
    # stiffer sample sees the same box half as a smaller ratio (the box branch Lb = Bl² Vb/(ρ c² Sd²)
    # is the same for both drivers, whatever their suspensions)
    za = vented_box_impedance(omega, driver, fb, 2 * alpha, qb)
    zb = vented_box_impedance(omega, other, fb, 2 * alpha * (driver["omega0"] / other["omega0"]) ** 2, qb)
    Z = za * zb / (za + zb)
    rng = np.random.default_rng(seed)
    Y = (1 / Z) * (1 + noise * (rng.standard_normal(Z.shape) + 1j * rng.standard_normal(Z.shape)))
    return Measurement(omega, Y, meta={"source": "two drivers in parallel in a vented box",
                                       "noise_rel": noise, "seed": seed})
