"""Shunt damping design: shunted receptance, H∞-optimal RC shunt, stability, realisation."""

from .design import ShuntDesign, ShuntEvaluation, closed_form_rc, design_rc_shunt, evaluate_rc_shunt
from .receptance import Plant, rc_impedance
from .stability import closed_loop_poles, instability_threshold

__all__ = ["ShuntDesign", "ShuntEvaluation", "closed_form_rc", "design_rc_shunt", "evaluate_rc_shunt",
           "Plant", "rc_impedance", "closed_loop_poles", "instability_threshold"]
