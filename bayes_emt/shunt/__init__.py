"""Shunt damping design: shunted receptance and its H∞ norm, the H∞-optimal RC shunt,
closed-loop stability (threshold in Rs, poles, pole count), the digital realisation, and design
under uncertainty over posterior draws (:mod:`bayes_emt.shunt.robust`).

Two visible parts: the package root designs and evaluates one shunt for one parameter vector
(:mod:`.receptance`, :mod:`.stability`, :mod:`.design`, :mod:`.foster`, :mod:`.implementation`,
the reference); :mod:`bayes_emt.shunt.batch` is its vectorised copy over many draws (threshold,
peaks, per-draw optima), used by the robust design (:mod:`.draws`, :mod:`.risk`, :mod:`.saa`,
:mod:`.report`, :mod:`.robust`). :func:`robust_shunt` (:mod:`.from_posterior`) takes posteriors
as a user holds them. Every design carries its stability margin and the R0 uncertainty it is
compared with (:mod:`.safety`).
"""

from .batch.plant import SampledShunt
from .design import (
    ShuntDesign,
    ShuntEvaluation,
    ShuntWarning,
    closed_form_rc,
    design_rc_shunt,
    evaluate_rc_shunt,
    read_shunt_design,
)
from .draws import DrawGroup, mixture_weights, sample_mixture
from .foster import Foster, foster_realisation
from .from_posterior import RobustShuntResult, read_robust_shunt, robust_shunt
from .receptance import Peak, Plant, open_peak, rc_impedance, rc_peaks, receptance
from .robust import RobustShunt, design_robust_shunt
from .safety import MARGIN_CODE, MarginCheck, check_margin, r0_uncertainty
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
           "design_robust_shunt", "read_shunt_design", "robust_shunt", "RobustShuntResult",
           "read_robust_shunt", "MARGIN_CODE", "MarginCheck", "check_margin", "r0_uncertainty"]
