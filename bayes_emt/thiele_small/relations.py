"""Thiele–Small parameters from the model's parameters (Small 1972), vectorised over draws.

Relations (R. H. Small, "Direct-radiator loudspeaker system analysis", JAES 20(5), 1972;
A. N. Thiele, "Loudspeakers in vented boxes", JAES 19, 1971), with ``φ̄² = Bl²/Mms``:

    Re = R0,   Qes = ωs Re / φ̄²  (= ωs Mms Re / Bl²),   Qts = Qms Qes / (Qms + Qes),
    Mms (added mass, a known Mms or Bl = φ̄ √Mms),   Cms = 1/(ωs² Mms),   Kms = 1/Cms,
    Rms = ωs Mms / Qms,   Vas = ρ c² Sd² Cms,   η0 = (4π²/c³) fs³ Vas / Qes,
    SPL(2.83 V, 1 m) = 10 log10(ρ c η0 P / (2π p_ref²)),  P = 2.83²/Re W, p_ref = 20 µPa
    (half-space radiation; 112.1 + 10 log10 η0 dB at 1 W with ρ = 1.18, c = 343),   EBP = fs/Qes.

Le: the coil's inductance at 1 kHz, ``Im Zc(j 2π 1 kHz) / (2π 1 kHz)`` [H], as data sheets quote it.

Frequency-dependent suspension (creep). With the LOG creep term the mechanical impedance is
``Zm(jω) = Rms + jω Mms + K(jω)/(jω)``, ``K(jω) = k / (1 + λ ln(ω0/jω))`` (Knudsen & Jensen,
"Low-frequency loudspeaker models that include suspension creep", JAES 41(1/2), 1993): the
stiffness is complex (a constant loss angle) and falls toward low frequency. The model's
``ω0 = √(k/m)`` and ``ζ`` then describe the reference stiffness and the viscous part of the loss
only, not the impedance peak. The T/S values follow the convention of the tools that fit LOG
creep (Klippel LPM, whose data sheets list the creep factor "Lambda s" beside fs and Qms, e.g.
https://www.kicker.com/app/tsparam/49ST9MR8.html; Speakerbench, whose advanced model uses the
Knudsen–Jensen LOG model with fs determined by the fit, https://speakerbench.com/doc/fit.html):

* fs is the resonance of the mechanical impedance: ``Im Zm(j 2π fs) = 0``, i.e.
  ``ωs² Mms = Re K(jωs)`` (the compliance taken at fs, Cms = 1/(ωs² Mms));
* Qms = ``ωs Mms / Re Zm(jωs)``: all mechanical loss at fs, the viscous ``Rms_visc = c`` plus the
  creep's ``Im K(jωs)/ωs``, as the impedance peak's width shows it; the viscous part alone,
  ``Qms_viscous = ωs Mms / c``, is reported beside it (Klippel's "Qms considering Rms only");
* the creep factor is reported both per e-fold (the model's λ) and per decade
  (``λ ln 10``, Knudsen–Jensen's and Klippel's log10 form).

Without creep all of this reduces to fs = ω0/2π and Qms = 1/(2ζ) exactly.
"""

from __future__ import annotations

import math

import numpy as np

from ..models import Model
from ..models.derived import mechanical_resonance

__all__ = ["UNITS", "DISPLAY", "NAMES", "mechanical_resonance", "free_air", "with_mass", "with_sd",
           "P_REF", "V_2_83"]

P_REF = 20e-6  # Pa
V_2_83 = 2.83  # V

#: JSON order and SI unit of every reported quantity
UNITS: dict[str, str] = {
    "fs": "Hz", "Re": "ohm", "Le": "H", "Qms": "1", "Qes": "1", "Qts": "1", "Bl": "T m", "Mms": "kg",
    "Cms": "m/N", "Kms": "N/m", "Rms": "kg/s", "Vas": "m^3", "eta0": "1", "SPL": "dB", "EBP": "Hz",
    "lambda_creep_decade": "1", "Qms_viscous": "1"}
NAMES = tuple(UNITS)

#: terminal units: (label, factor from SI)
DISPLAY: dict[str, tuple[str, float]] = {
    "fs": ("Hz", 1.0), "Re": ("Ω", 1.0), "Le": ("mH", 1e3), "Qms": ("", 1.0), "Qes": ("", 1.0),
    "Qts": ("", 1.0), "Bl": ("T·m", 1.0), "Mms": ("g", 1e3), "Cms": ("mm/N", 1e3), "Kms": ("N/mm", 1e-3),
    "Rms": ("kg/s", 1.0), "Vas": ("L", 1e3), "eta0": ("%", 100.0), "SPL": ("dB", 1.0), "EBP": ("Hz", 1.0),
    "lambda_creep_decade": ("/decade", 1.0), "Qms_viscous": ("", 1.0)}


def free_air(model: Model, theta) -> dict[str, np.ndarray]:
    """fs, Re, Le, Qms, Qes, Qts (and under creep the creep factor and Qms_viscous) per row."""
    theta = np.atleast_2d(np.asarray(theta, float))
    ws, qms, qv = mechanical_resonance(model, theta)
    r0 = theta[:, model.params.index("R0")]
    phi = theta[:, model.params.index("phi")]
    qes = ws * r0 / phi**2
    w1k = 2 * math.pi * 1000.0
    le = model.coil_impedance(np.array([w1k]), theta)[:, 0].imag / w1k
    out = {"fs": ws / (2 * math.pi), "Re": r0, "Le": le, "Qms": qms, "Qes": qes,
           "Qts": qms * qes / (qms + qes), "EBP": ws / (2 * math.pi) / qes}
    if "lambda_creep" in model.names:
        out["lambda_creep_decade"] = theta[:, model.params.index("lambda_creep")] * math.log(10.0)
        out["Qms_viscous"] = qv
    return out


def with_mass(ts: dict[str, np.ndarray], model: Model, theta, mms) -> dict[str, np.ndarray]:
    """Add Bl, Mms, Cms, Kms, Rms given the moving mass ``mms`` [kg] (per row or scalar)."""
    theta = np.atleast_2d(np.asarray(theta, float))
    phi = theta[:, model.params.index("phi")]
    mms = np.broadcast_to(np.asarray(mms, float), phi.shape)
    ws = 2 * math.pi * ts["fs"]
    cms = 1.0 / (ws * ws * mms)
    return {**ts, "Bl": phi * np.sqrt(mms), "Mms": np.array(mms), "Cms": cms, "Kms": 1.0 / cms,
            "Rms": ws * mms / ts["Qms"]}


def with_sd(ts: dict[str, np.ndarray], sd: float, rho: float, c: float) -> dict[str, np.ndarray]:
    """Add Vas, η0 and SPL at 2.83 V / 1 m from Sd [m²] and Cms (air density ρ [kg/m³], sound
    speed c [m/s])."""
    vas = rho * c * c * sd * sd * ts["Cms"]
    eta0 = 4 * math.pi**2 / c**3 * ts["fs"] ** 3 * vas / ts["Qes"]
    power = V_2_83**2 / ts["Re"]
    spl = 10 * np.log10(rho * c * eta0 * power / (2 * math.pi * P_REF**2))
    return {**ts, "Vas": vas, "eta0": eta0, "SPL": spl}
