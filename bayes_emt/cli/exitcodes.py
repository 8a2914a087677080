"""The one exit-status table of every ``bayes-emt`` command (shown at the end of each ``--help``).

======  =======================================================================================
status  meaning
======  =======================================================================================
0       the result was delivered, with or without warnings (warnings are printed and saved)
1       a result was delivered but is not to be trusted: a chain that did not meet its stopping
        rule, a time or step budget that cut the search short, an optimiser that did not
        converge, a broken final model, a failed step or recording
2       bad input: a file, option, unit or value the command refuses (one line names it);
        nothing was computed
130     interrupted by SIGINT (Ctrl-C); a sampler's checkpoint is kept intact
143     interrupted by SIGTERM
======  =======================================================================================

A command decides 0 or 1 with :func:`status`; 2 comes from the error handler of
:func:`bayes_emt.cli.main` (every :class:`ValueError`, :class:`OSError`, data-format error and
option error), 130/143 from its signal handler.
"""

from __future__ import annotations

__all__ = ["OK", "UNTRUSTED", "BAD_INPUT", "SIGINT", "SIGTERM", "EPILOG", "status"]

OK = 0
UNTRUSTED = 1
BAD_INPUT = 2
SIGINT = 130
SIGTERM = 143

EPILOG = """\
exit status:
  0    result delivered (with or without warnings)
  1    result delivered but not trustworthy (unconverged chain, budget cut, optimiser not
       converged, broken final model, failed step)
  2    bad input (file, option, unit or value refused; the message names it)
  130  interrupted (SIGINT, Ctrl-C); 143 terminated (SIGTERM)"""


def status(untrusted: bool) -> int:
    """The exit status of a command that delivered its result: 1 when ``untrusted``, else 0."""
    return UNTRUSTED if untrusted else OK
