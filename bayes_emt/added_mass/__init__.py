"""Added-mass feature (paper, Appendix B): physical m, c, k, φ from a pair of recordings, by two fits, one
joint fit, or one joint posterior. Sits beside the other features, above the core."""

from .fit import PHYSICAL_NAMES, PHYSICAL_UNITS, AddedMassResult, JointModel, fit_added_mass

__all__ = ["PHYSICAL_NAMES", "PHYSICAL_UNITS", "AddedMassResult", "JointModel", "fit_added_mass"]
