"""The physics catalogue: terms that add what a base model leaves out, one per module.

Each term is device physics or an instrument effect, enters the plant at its stage
(:mod:`bayes_emt.models.term`), declares its parameters with proper priors identical in every
model, its band class (where discovery looks for it), its signature, and proposes its own starting
values from the base fit's misfit (:meth:`~bayes_emt.models.term.Term.start`, a multi-start over the
frequency where it acts). ``eddy_current`` is not a term but an escalation of the coil model
(I → II → III/UD → NL(n), :data:`~bayes_emt.models.spec.EDDY_PHYSICS`).

A new term is one module here plus one entry in :data:`BUILTIN` (or, outside the package, a class
passed to :func:`~bayes_emt.models.registry.register_term` at run time).
"""

from .enclosure_port import EnclosurePort
from .lead_impedance import LeadImpedance
from .lr2 import LR2
from .measurement_artifact import MeasurementArtifact
from .parallel_driver import ParallelDriver
from .second_resonance import SecondResonance
from .semi_inductance import SemiInductance
from .suspension_creep import SuspensionCreep
from .thermal_drift import ThermalDrift
from .winding_capacitance import WindingCapacitance

__all__ = ["BUILTIN", "WindingCapacitance", "SecondResonance", "EnclosurePort", "SuspensionCreep",
           "ThermalDrift", "SemiInductance", "LR2", "LeadImpedance", "MeasurementArtifact",
           "ParallelDriver"]

#: the catalogue in registration order: within a band class, discovery tries candidates in this
#: order (a time budget cuts the last first)
BUILTIN = (SemiInductance, LR2, WindingCapacitance, LeadImpedance,  # coil
           SuspensionCreep, EnclosurePort, ParallelDriver,  # mechanical
           SecondResonance, MeasurementArtifact, ThermalDrift)  # anywhere
