"""The source paper's published values (its Tables 1–7, B.8 and B.9), used as reference data in tests,
the bundled dataset and the demo. SI units; parameter names as in Physics and conventions. Never
used as a fit's answer."""

from __future__ import annotations

__all__ = ["PAPER_TABLES", "PAPER_SHUNTS", "PAPER_ADDED_MASS", "PAPER_PHYSICAL", "PAPER_N_TURNS",
           "PAPER_OMEGA_RANGE", "PAPER_POINTS"]

PAPER_N_TURNS = 480
PAPER_OMEGA_RANGE = (1e1, 1e5)  # rad/s
PAPER_POINTS = 2000

#: Tables 1-5 (model -> parameters).
PAPER_TABLES: dict[str, dict[str, float]] = {
    "I": {"zeta": 0.00847, "omega0": 50.8, "phi": 1.66, "R0": 2.57, "L0": 1.65e-3},
    "II": {"zeta": 0.00875, "omega0": 50.8, "phi": 1.69, "R0": 2.57, "L0": 1.97e-3, "Rmu": 2.95},
    "III": {"zeta": 0.00896, "omega0": 50.8, "phi": 1.71, "R0": 2.57, "alpha": 7.00e-5,
            "beta": 5.29e-1},
    "UD": {"zeta": 0.0100, "omega0": 50.8, "phi": 1.83, "R0": 2.57, "Lg": 7.86e-4,
           "alpha": 3.74e-4, "beta": 2.87e-1},
    "NL": {"zeta": 0.0109, "omega0": 50.8, "phi": 1.91, "R0": 2.56, "Pg": 3.43e-9,
           "P1": 4.09e-9, "P2": 3.84e-9, "P3": 3.73e-9, "P4": 4.77e-9, "P5": 4.28e-9,
           "R1": 2.91e-6, "R2": 1.43e-5, "R3": 5.37e-5, "R4": 1.90e-4, "R5": 8.33e-4},
}

#: Table 6: optimal RC shunt per model (Rs [ohm], Cs [F]); NL attenuation -24.7 dB.
PAPER_SHUNTS: dict[str, dict[str, float]] = {
    "I": {"Rs": -2.49, "Cs": 0.345},
    "II": {"Rs": -2.48, "Cs": 0.281},
    "III": {"Rs": -2.47, "Cs": 0.240},
    "UD": {"Rs": -2.43, "Cs": 0.135},
    "NL": {"Rs": -2.40, "Cs": 0.0814, "attenuation_db": -24.7},
}

#: Table B.8: NL fit with 0.645 kg removed.
PAPER_ADDED_MASS = {
    "delta_m": -0.645,
    "parameters": {"zeta": 0.00927, "omega0": 64.2, "phi": 2.26, "R0": 2.58, "Pg": 3.43e-9,
                   "P1": 4.16e-9, "P2": 3.84e-9, "P3": 3.73e-9, "P4": 4.78e-9, "P5": 4.28e-9,
                   "R1": 2.90e-6, "R2": 1.43e-5, "R3": 5.34e-5, "R4": 1.89e-4, "R5": 8.30e-4},
}

#: Table B.9: physical parameters.
PAPER_PHYSICAL = {"m": 1.73, "c": 1.92, "k": 4.47e3, "phi_raw": 2.51}
