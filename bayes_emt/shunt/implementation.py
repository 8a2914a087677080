"""Digital realisation of the RC shunt as a synthetic impedance (the source paper's eqs. 55–56).

``Zs(s) = R_in + R_in K_in K_out K(s)``: the current is sensed over ``R_in`` and amplified by
``K_in``, the controller ``K`` runs on a DSP at ``fs``, its output drives the terminals through
``K_out``. For an RC target ``K(s) = (Rs − R_in + 1/(Cs s)) / (R_in K_in K_out)`` (56),
discretised by the bilinear (Tustin) transform.

What the discretised controller achieves is evaluated two ways:

* **attenuation**: the equivalent shunt impedance seen at ``jω``,
  ``R_in + R_in K_in K_out K_d(e^{jωT}) e^{−jωT d} (1 − e^{−jωT})/(jωT)`` (zero-order hold and an
  optional computation delay of ``d`` samples), in the receptance (50). This is the fundamental
  component of the sampled-data response; the aliased images at ``ω ± k·2π fs`` are neglected
  (the plant admittance there is ~1e-3 of its in-band value at the paper's 5 kHz);
* **stability**: the exact sampled-data loop. With the shunt closing the terminals,
  ``i = −P(s) v_out`` where ``P = 1/(Z + R_in)`` is the plant admittance seen by the amplifier;
  ``P`` is discretised with a zero-order hold and the loop
  ``1 + R_in K_in K_out z^−d K_d(z) P_d(z) = 0`` must have its roots inside the unit circle.
  The plant is the Foster realisation (:mod:`bayes_emt.shunt.foster`): exact for I, II, NL, UL;
  for III/UD 40 eddy-current modes plus a lumped tail, ``|ΔZe(s)| ≤ E |s|²`` (E ≈ 3e-14 Ω s² at
  Table 3's values: < 1e-6 Ω below 5 kHz), which the result names.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import signal

from ..models import Model
from .foster import foster_realisation
from .receptance import Plant

__all__ = ["Realisation", "controller_tf", "realise_rc_shunt", "plant_state_space", "sampled_loop_max_pole"]


def controller_tf(Rs: float, Cs: float, R_in: float, K_in: float, K_out: float):
    """Continuous controller of (56), ``K(s) = (Rs − R_in + 1/(Cs s)) / (R_in K_in K_out)``
    [dimensionless V/V], as ``(b, a)`` in powers of ``s``, highest first."""
    g = R_in * K_in * K_out
    return np.array([(Rs - R_in) * Cs, 1.0]) / (g * Cs), np.array([1.0, 0.0])


@dataclass(frozen=True)
class Realisation:
    """A discretised RC shunt controller and what it achieves.

    Attributes
    ----------
    R_in [Ω], K_in, K_out, fs [Hz], delay_samples : the rig (Table 7) and computation delay.
    K_s, K_z : continuous and discrete controller ``(b, a)`` (highest power first; ``K_z`` in ``z``,
        i.e. ``K(z) = (b0 + b1 z⁻¹)/(a0 + a1 z⁻¹)``, without the delay ``z^−d``).
    attenuation_db : with the discrete controller [dB] (+inf when the sampled-data loop is
        unstable); attenuation_ideal_db : with the ideal continuous ``Zs``.
    stable, max_pole_abs : the sampled-data loop, largest closed-loop ``|z|``.
    plant_used : the plant realisation the stability test used.
    """

    R_in: float
    K_in: float
    K_out: float
    fs: float
    delay_samples: int
    K_s: tuple
    K_z: tuple
    attenuation_db: float
    attenuation_ideal_db: float
    stable: bool
    max_pole_abs: float
    plant_used: str

    def to_json_dict(self) -> dict:
        d = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
             for k, v in asdict(self).items()}
        d["K_s"] = {"b": [float(x) for x in self.K_s[0]], "a": [float(x) for x in self.K_s[1]]}
        d["K_z"] = {"b": [float(x) for x in self.K_z[0]], "a": [float(x) for x in self.K_z[1]]}
        return d


def plant_state_space(model: Model, theta, R_in: float):
    """Continuous state space ``(A, B, C, D)`` from the amplifier voltage to the coil current,
    ``P(s) = 1/(Z(s) + R_in)``, built from the circuit: states ``x, v`` (mass-normalised
    displacement and velocity), the series current ``i`` and each parallel-RL section's inductor
    current (Foster realisation). A model without series inductance (II) gets a tiny one (1e-6 of
    its total inductance): its pole lies far above any sampling rate used here, and the current
    sampled just before the output updates is then the physical one."""
    zeta, omega0, phi = (float(v) for v in model.mechanics(theta))
    f = foster_realisation(model, theta)
    R0, G, Lk, tau = f.R0, f.G, f.L, f.tau
    G = max(G, 1e-6 * (G + float(np.sum(Lk))))
    n = Lk.size
    Rk = Lk / tau
    A = np.zeros((3 + n, 3 + n))
    A[0, 1] = 1.0
    A[1, 0], A[1, 1], A[1, 2] = -(omega0**2), -2 * zeta * omega0, phi
    A[2, 1] = -phi / G
    A[2, 2] = -(R0 + R_in + Rk.sum()) / G
    A[2, 3:] = Rk / G
    A[3:, 2] = 1.0 / tau
    A[3:, 3:] = np.diag(-1.0 / tau)
    B = np.zeros((3 + n, 1))
    B[2, 0] = 1.0 / G
    C = np.zeros((1, 3 + n))
    C[0, 2] = 1.0
    return A, B, C, np.zeros((1, 1))


def _discrete_loop_poles(model, theta, R_in, K_in, K_out, bz, az, fs, delay):
    """Eigenvalues of the sampled-data loop: ZOH plant, Tustin controller, ``delay`` samples."""
    Ad, Bd, Cd, _, _ = signal.cont2discrete(plant_state_space(model, theta, R_in), 1.0 / fs, method="zoh")
    Ak, Bk, Ck, Dk = signal.tf2ss(bz, az)
    g = R_in * K_in * K_out
    Ck, Dk = g * Ck, g * Dk
    if delay > 0:  # a shift register after the controller
        nk, d = Ak.shape[0], delay
        A2 = np.zeros((nk + d, nk + d))
        A2[:nk, :nk] = Ak
        A2[nk, :nk] = Ck[0]
        A2[nk + 1 :, nk : nk + d - 1] = np.eye(d - 1)
        B2 = np.vstack([Bk, Dk, np.zeros((d - 1, 1))])
        C2 = np.zeros((1, nk + d))
        C2[0, -1] = 1.0
        Ak, Bk, Ck, Dk = A2, B2, C2, np.zeros((1, 1))
    # u = -(Ck xc + Dk i), i = Cd x
    top = np.hstack([Ad - Bd @ Dk @ Cd, -Bd @ Ck])
    bottom = np.hstack([Bk @ Cd, Ak])
    return np.linalg.eigvals(np.vstack([top, bottom]))


def sampled_loop_max_pole(model: Model, theta, Rs: float, Cs: float, *, R_in: float = 0.0996,
                          K_in: float = 99.23, K_out: float = 0.9846, fs: float = 5000.0,
                          delay_samples: int = 0) -> float:
    """Largest closed-loop ``|z|`` of the exact sampled-data loop (ZOH plant, Tustin controller,
    ``delay_samples`` of delay; module docstring): the loop is stable when it is below 1. The
    stability part of :func:`realise_rc_shunt` alone (no attenuation), for checking many draws."""
    b, a = controller_tf(Rs, Cs, R_in, K_in, K_out)
    bz, az = signal.bilinear(b, a, fs)
    poles = _discrete_loop_poles(model, np.asarray(theta, float), R_in, K_in, K_out, np.atleast_1d(bz),
                                 np.atleast_1d(az), fs, int(delay_samples))
    return float(np.max(np.abs(poles)))


def realise_rc_shunt(model: Model, theta, Rs: float, Cs: float, *, R_in: float = 0.0996,
                     K_in: float = 99.23, K_out: float = 0.9846, fs: float = 5000.0,
                     delay_samples: int = 0) -> Realisation:
    """Discretise the RC shunt ``(Rs [Ω], Cs [F])`` by Tustin at ``fs`` [Hz] and evaluate what it
    achieves on the continuous plant (module docstring; defaults: the paper's Table 7 rig at 5 kHz).

    Raises
    ------
    ValueError
        For non-positive rig values, a negative delay, or a model without a Foster form.
    """
    for name, v in (("R_in", R_in), ("K_in", K_in), ("K_out", K_out), ("fs", fs)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive, got {v!r}")
    if int(delay_samples) != delay_samples or delay_samples < 0:
        raise ValueError(f"delay must be >= 0 samples, got {delay_samples}")
    b, a = controller_tf(Rs, Cs, R_in, K_in, K_out)
    bz, az = signal.bilinear(b, a, fs)
    bz, az = np.atleast_1d(bz), np.atleast_1d(az)
    T = 1.0 / fs
    g = R_in * K_in * K_out

    def zs_digital(s):
        z = np.exp(s * T)
        kd = np.polyval(bz, z) / np.polyval(az, z)
        zoh = (1 - np.exp(-s * T)) / (s * T)
        return R_in + g * kd * np.exp(-s * T * delay_samples) * zoh

    plant = Plant(model, theta)
    open_pk = plant.open_peak().value
    att = 20 * math.log10(plant.peak(zs_digital).value / open_pk)
    ideal = 20 * math.log10(plant.peak(lambda s: Rs + 1 / (Cs * s)).value / open_pk)
    poles = _discrete_loop_poles(model, theta, R_in, K_in, K_out, bz, az, fs, delay_samples)
    used = foster_realisation(model, theta).description
    maxabs = float(np.max(np.abs(poles)))
    stable = maxabs < 1.0
    return Realisation(R_in, K_in, K_out, fs, int(delay_samples), (b, a), (bz, az),
                       att if stable else math.inf, ideal, bool(stable), maxabs, used)
