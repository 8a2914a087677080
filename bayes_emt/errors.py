"""Exception and warning classes (subclassing builtins, so callers may catch either)."""

__all__ = ["BayesEMTError", "DataFormatError", "IdentifiabilityWarning", "ConvergenceWarning",
           "FitError"]


class BayesEMTError(Exception):
    """Base class of this package's errors."""


class DataFormatError(BayesEMTError, ValueError):
    """A measurement file or array is malformed; the message names the file and line."""


class FitError(BayesEMTError, RuntimeError):
    """An estimate could not be computed (the message says which model and why)."""


class IdentifiabilityWarning(UserWarning):
    """The data cannot pin down some parameters (e.g. the band misses the resonance)."""


class ConvergenceWarning(UserWarning):
    """An iterative method stopped before meeting its convergence criterion."""
