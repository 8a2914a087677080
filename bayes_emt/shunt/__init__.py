"""Shunt damping design (SPEC §4): shunted receptance and its H∞ norm, the H∞-optimal RC shunt,
closed-loop stability (threshold in Rs, poles, pole count) and the digital realisation."""

from .design import (
    ShuntDesign,
    ShuntEvaluation,
    ShuntWarning,
    closed_form_rc,
    design_rc_shunt,
    evaluate_rc_shunt,
)
from .foster import Foster, foster_realisation
from .receptance import Peak, Plant, open_peak, rc_impedance, rc_peaks, receptance
from .stability import (
    StabilityReport,
    assess_stability,
    closed_loop_poles,
    count_unstable_poles,
    instability_threshold,
)

__all__ = ["ShuntDesign", "ShuntEvaluation", "ShuntWarning", "closed_form_rc", "design_rc_shunt",
           "evaluate_rc_shunt",
           "Foster", "foster_realisation", "Peak", "Plant", "open_peak", "rc_impedance", "rc_peaks",
           "receptance", "StabilityReport", "assess_stability", "closed_loop_poles",
           "count_unstable_poles", "instability_threshold"]
