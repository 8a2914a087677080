"""Shunt damping design (SPEC §4): shunted receptance and its H∞ norm, the H∞-optimal RC shunt,
closed-loop stability (threshold in Rs, poles, pole count), the digital realisation, and design
under uncertainty over posterior draws (:mod:`bayes_emt.shunt.robust`)."""

from .batch_plant import SampledShunt
from .design import (
    ShuntDesign,
    ShuntEvaluation,
    ShuntWarning,
    closed_form_rc,
    design_rc_shunt,
    evaluate_rc_shunt,
)
from .draws import DrawGroup, mixture_weights, sample_mixture
from .foster import Foster, foster_realisation
from .receptance import Peak, Plant, open_peak, rc_impedance, rc_peaks, receptance
from .robust import RobustShunt, design_robust_shunt
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
           "count_unstable_poles", "instability_threshold",
           "SampledShunt", "DrawGroup", "mixture_weights", "sample_mixture", "RobustShunt",
           "design_robust_shunt"]
