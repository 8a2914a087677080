"""The default catalogue of parameters: SPEC §6 names, SI units, labels and proper priors.

Priors are identical for a name whatever the model, so that evidences of different models are
comparable (shared parameters' prior volumes cancel in a Bayes factor). The noise parameters every
likelihood appends (``sigma_rel``, ``sigma_abs`` and, when sampled, ``nu``) live here too.
"""

from __future__ import annotations

import re

from .priors import LogUniform, Prior, Uniform
from .spec import ParamSet, ParamSpec

__all__ = ["default_spec", "NOISE_PARAMS", "NU_SPEC", "noise_param_set"]

# Priors are proper, log-uniform over wide decade ranges that bracket every transducer from a
# 1 cm tweeter to the paper's 2 kg shaker, and identical for a name whatever the model, so that
# evidences of different models are comparable (shared parameters' prior volumes cancel).
_DEFAULTS: dict[str, tuple[str, str, Prior, str]] = {
    "zeta": ("1", r"$\zeta$", LogUniform(1e-5, 2.0), "mechanical damping ratio"),
    "omega0": ("rad/s", r"$\omega_0$", LogUniform(1e-1, 1e6), "mechanical natural angular frequency"),
    "phi": ("N/(A kg^0.5)", r"$\bar\varphi$", LogUniform(1e-3, 1e4),
            "mass-normalised electromechanical coupling phi/sqrt(m)"),
    "R0": ("ohm", r"$R_0$", LogUniform(1e-3, 1e4), "coil DC resistance"),
    "L0": ("H", r"$L_0$", LogUniform(1e-8, 1e1), "coil self-inductance"),
    "Rmu": ("ohm", r"$R_\mu$", LogUniform(1e-3, 1e5), "lumped eddy-current loss resistance"),
    "alpha": ("s", r"$\alpha$", LogUniform(1e-10, 1e2), "eddy-current diffusion time constant"),
    "beta": ("H s^-0.5", r"$\beta$", LogUniform(1e-6, 1e4), "semi-inductance scale"),
    "Lg": ("H", r"$L_g$", LogUniform(1e-9, 1e1), "air-gap inductance"),
    "Pg": ("H", r"$P_g$", LogUniform(1e-16, 1e-2), "air-gap permeance (per turn squared)"),
    "P": ("H", r"$P_{j}$", LogUniform(1e-16, 1e-2), "permeance of core ring j"),
    "R": ("ohm", r"$R_{j}$", LogUniform(1e-12, 1e2), "eddy-current resistance of core ring j"),
    # physical parameters separated by an added-mass pair (SPEC §3.4)
    "m": ("kg", r"$m$", LogUniform(1e-6, 1e4), "moving mass"),
    "c": ("N s/m", r"$c$", LogUniform(1e-9, 1e6), "mechanical viscous damping"),
    "k": ("N/m", r"$k$", LogUniform(1e-6, 1e10), "mechanical stiffness"),
    "phi_raw": ("N/A", r"$\varphi$", LogUniform(1e-6, 1e4), "electromechanical coupling (force factor Bl)"),
    # augmentations of the physics catalogue (SPEC §7); same prior whatever the base model
    "Cp": ("F", r"$C_p$", LogUniform(1e-13, 1e-5), "winding and lead capacitance across the terminals"),
    "zeta2": ("1", r"$\zeta_2$", LogUniform(1e-4, 2.0), "damping ratio of a second mechanical mode"),
    "omega2": ("rad/s", r"$\omega_2$", LogUniform(1e-1, 1e6), "natural angular frequency of a second mode"),
    "phi2": ("N/(A kg^0.5)", r"$\bar\varphi_2$", LogUniform(1e-3, 1e4),
             "mass-normalised coupling of a second mode"),
    "Lb": ("H", r"$L_b$", LogUniform(1e-9, 1e3),
           "box/port branch inductance (box stiffness seen through the motional branch)"),
    "omegab": ("rad/s", r"$\omega_b$", LogUniform(1e-1, 1e6), "port (Helmholtz) tuning angular frequency"),
    "zetab": ("1", r"$\zeta_b$", LogUniform(1e-4, 2.0), "damping ratio of the port/box resonance"),
    "lambda_creep": ("1", r"$\lambda_c$", Uniform(0.0, 0.5),
                     "suspension creep: compliance grows by lambda per e-fold of falling frequency"),
    "drift": ("1", r"$\delta_T$", Uniform(-0.1, 0.1),
              "relative change of R0 from the first to the last point of the sweep"),
    "K_semi": ("ohm s^n", r"$K$", LogUniform(1e-10, 1e4), "semi-inductance scale (Leach 1999)"),
    "n_semi": ("1", r"$n$", Uniform(0.0, 1.0), "semi-inductance exponent (0: resistor, 1: inductor)"),
    "L_lr2": ("H", r"$L_2$", LogUniform(1e-8, 1e1), "LR-2 coil: second inductance"),
    "R_lr2": ("ohm", r"$R_2$", LogUniform(1e-3, 1e5), "LR-2 coil: resistance shunting L_lr2"),
    "Rl": ("ohm", r"$R_l$", LogUniform(1e-5, 1e2), "lead and fixture resistance in series"),
    "Ll": ("H", r"$L_l$", LogUniform(1e-10, 1e-2), "lead and fixture inductance in series"),
    "omegas": ("rad/s", r"$\omega_s$", LogUniform(1e-1, 1e7),
               "angular frequency of an instrument range switch or calibration boundary"),
    "delta_s": ("1", r"$\delta_s$", Uniform(-0.5, 0.5),
                "relative magnitude step of the instrument above omegas"),
    "psi_s": ("rad", r"$\psi_s$", Uniform(-0.5, 0.5), "phase step of the instrument above omegas"),
}
_RING = re.compile(r"^([PR])([1-9]\d*)$")  # ring j = 1..n; "R0" is the coil, not a ring


def default_spec(name: str) -> ParamSpec:
    """The catalogue spec for ``name`` (``P3`` and ``R3`` resolve to the ring entries)."""
    key, j = name, None
    m = _RING.match(name)
    if m:
        key, j = m.group(1), int(m.group(2))
    if key not in _DEFAULTS:
        raise KeyError(f"no catalogue entry for parameter {name!r}")
    unit, label, prior, desc = _DEFAULTS[key]
    if j is not None:
        label = label.replace("{j}", f"{{{j}}}")
        desc = desc.replace("ring j", f"ring {j}")
    return ParamSpec(name, unit, label, prior, desc)


#: Noise parameters appended to every model's parameter vector (identical across models).
NOISE_PARAMS = ParamSet([
    ParamSpec("sigma_rel", "1", r"$\sigma_\mathrm{rel}$", LogUniform(1e-6, 1.0),
              "relative noise std of the real and imaginary parts (fraction of |Y|)"),
    ParamSpec("sigma_abs", "S", r"$\sigma_\mathrm{abs}$", LogUniform(1e-12, 1e2),
              "absolute noise floor: std of the real and imaginary parts"),
])

#: Student-t degrees of freedom, when sampled: log-uniform from Cauchy-like (1) to Gaussian-like (100).
NU_SPEC = ParamSpec("nu", "1", r"$\nu$", LogUniform(1.0, 100.0), "Student-t degrees of freedom")


def noise_param_set(kind: str = "gaussian", nu: float | None = 4.0) -> ParamSet:
    """The default noise parameters of a likelihood: :data:`NOISE_PARAMS`, plus :data:`NU_SPEC`
    for a Student-t likelihood whose ``nu`` is sampled (``nu=None``)."""
    return NOISE_PARAMS + ParamSet([NU_SPEC]) if kind == "student" and nu is None else NOISE_PARAMS
