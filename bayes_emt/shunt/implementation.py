"""Digital realisation of the RC shunt as a synthetic impedance (SPEC §4, eqs. 55–56).

``Zs(s) = R_in + R_in K_in K_out K(s)``: the current is sensed over ``R_in`` and amplified by
``K_in``, the controller ``K`` runs on a DSP at ``fs``, its output drives the terminals through
``K_out``. For an RC target ``K(s) = (Rs − R_in + 1/(Cs s)) / (R_in K_in K_out)`` (56),
discretised by the bilinear (Tustin) transform.

What the discretised controller achieves is evaluated two ways:

* **attenuation**: the equivalent shunt impedance seen at ``jω``,
  ``R_in + R_in K_in K_out K_d(e^{jωT}) e^{−jωT d} (1 − e^{−jωT})/(jωT)`` (zero-order hold and an
  optional computation delay of ``d`` samples), in the receptance (50);
* **stability**: the exact sampled-data loop. With the shunt closing the terminals,
  ``i = −P(s) v_out`` where ``P = 1/(Z + R_in)`` is the plant admittance seen by the amplifier;
  ``P`` is discretised with a zero-order hold and the loop
  ``1 + R_in K_in K_out z^−d K_d(z) P_d(z) = 0`` must have its roots inside the unit circle.
  Rational models are used as they are; for the Bessel models (III, UD) the plant is replaced
  by its uniform-ring rational approximation UL(80) (max relative error ≈ 1 % over
  10–1e5 rad/s at the paper's values, SPEC §2), which is said in the result.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import signal

from ..models import Model, build_model
from ..models.rational import foster_form
from .receptance import Plant
from .stability import is_rational

__all__ = ["Realisation", "controller_tf", "realise_rc_shunt"]

UL_APPROX_RINGS = 80


def controller_tf(Rs: float, Cs: float, R_in: float, K_in: float, K_out: float):
    """Continuous ``K(s)`` of (56) as ``(b, a)``, highest power first."""
    g = R_in * K_in * K_out
    return np.array([(Rs - R_in) * Cs, 1.0]) / (g * Cs), np.array([1.0, 0.0])


@dataclass(frozen=True)
class Realisation:
    """A discretised RC shunt controller and what it achieves.

    ``K_s``/``K_z``: continuous and discrete ``(b, a)`` coefficients (highest power first,
    ``z`` in ``K_z``); ``attenuation_db`` with the discrete controller (``attenuation_ideal_db`` with
    the ideal ``Zs``); ``stable`` and ``max_pole_abs`` (largest closed-loop ``|z|``) of the
    sampled-data loop; ``plant_used`` says which (approximate) plant the stability test used.
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
        d = asdict(self)
        d["K_s"] = {"b": [float(x) for x in self.K_s[0]], "a": [float(x) for x in self.K_s[1]]}
        d["K_z"] = {"b": [float(x) for x in self.K_z[0]], "a": [float(x) for x in self.K_z[1]]}
        return d


def _rational_plant(model: Model, theta):
    """``(model, theta, label)`` of a rational model equal or close to ``model``."""
    if is_rational(model):
        return model, np.asarray(theta, float), model.label
    p = model.as_dict(theta)
    ul = build_model("UL", rings=UL_APPROX_RINGS, n_turns=model.n_turns)
    vals = {k: p[k] for k in ("zeta", "omega0", "phi", "R0", "alpha", "beta")}
    vals["Lg"] = p.get("Lg", 0.0)
    return ul, np.array([vals[n] for n in ul.names]), f"UL({UL_APPROX_RINGS}) approximation of {model.label}"


def plant_state_space(model: Model, theta, R_in: float):
    """Continuous state space ``(A, B, C, D)`` from the amplifier voltage to the coil current,
    ``P(s) = 1/(Z(s) + R_in)``, built from the circuit: states ``x, v`` (mass-normalised
    displacement and velocity), the series current ``i`` and each parallel-RL section's inductor
    current. A model without series inductance (II, or III's approximation) gets a tiny one
    (1e-6 of its total inductance), which moves a pole far above any sampling rate used here."""
    zeta, omega0, phi = (float(v) for v in model.mechanics(theta))
    R0, G, Lk, tau = foster_form(model, theta)
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


def realise_rc_shunt(model: Model, theta, Rs: float, Cs: float, *, R_in: float = 0.0996,
                     K_in: float = 99.23, K_out: float = 0.9846, fs: float = 5000.0,
                     delay_samples: int = 0) -> Realisation:
    """Discretise the RC shunt controller and evaluate it (defaults: the paper's Table 7 rig)."""
    for name, v in (("R_in", R_in), ("K_in", K_in), ("K_out", K_out), ("fs", fs)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive, got {v!r}")
    if delay_samples < 0:
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
    rmodel, rtheta, used = _rational_plant(model, theta)
    poles = _discrete_loop_poles(rmodel, rtheta, R_in, K_in, K_out, bz, az, fs, delay_samples)
    maxabs = float(np.max(np.abs(poles)))
    stable = maxabs < 1.0
    return Realisation(R_in, K_in, K_out, fs, int(delay_samples), (b, a), (bz, az),
                       att if stable else float("nan"), ideal, bool(stable), maxabs, used)
