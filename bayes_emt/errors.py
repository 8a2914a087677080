"""Exception and warning classes (subclassing builtins, so callers may catch either)."""

import signal as _signal

__all__ = ["BayesEMTError", "DataFormatError", "IdentifiabilityWarning", "ConvergenceWarning",
           "FitError", "CheckpointError", "Interrupted", "PriorConflictWarning"]


class BayesEMTError(Exception):
    """Base class of this package's errors."""


class DataFormatError(BayesEMTError, ValueError):
    """A measurement file or array is malformed; the message names the file and line."""


class FitError(BayesEMTError, RuntimeError):
    """An estimate could not be computed (the message says which model and why)."""


class CheckpointError(BayesEMTError, OSError):
    """A sampler checkpoint that cannot be used: in use by another run, corrupted, truncated, or a
    write that failed (full disk); the message names the file. ``errno`` is set when one applies
    (``ENOSPC``, ``EACCES``, ``EBUSY``)."""

    def __init__(self, message: str, errno: int | None = None):
        super().__init__(message)
        self.args = (message,)
        self.errno = errno

    def __str__(self) -> str:  # OSError would print "[Errno ...]" around it
        return str(self.args[0]) if self.args else ""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM received (a ``KeyboardInterrupt``, so code catching that still works).
    ``signum`` is the signal; the message says what was kept (e.g. the checkpoint to resume)."""

    def __init__(self, signum: int = _signal.SIGINT, message: str | None = None):
        self.signum = int(signum)
        #: whether the message already says what was kept (a bare signal's does not)
        self.reported = message is not None
        super().__init__(message or f"interrupted ({_signal.Signals(self.signum).name})")

    @property
    def exit_code(self) -> int:
        """The shell's convention: 128 + the signal number (130 for SIGINT, 143 for SIGTERM)."""
        return 128 + self.signum


class IdentifiabilityWarning(UserWarning):
    """The data cannot pin down some parameters (e.g. the band misses the resonance)."""


class ConvergenceWarning(UserWarning):
    """An iterative method stopped before meeting its convergence criterion."""


class PriorConflictWarning(UserWarning):
    """The posterior of some parameter lies in the far tail of its prior (the prior contradicts the
    data); the message names the parameters."""
