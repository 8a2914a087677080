"""The vectorised copy of the nominal shunt design, over many posterior draws at once.

:mod:`bayes_emt.shunt` (the package root: :mod:`~bayes_emt.shunt.receptance`,
:mod:`~bayes_emt.shunt.stability`, :mod:`~bayes_emt.shunt.design`) designs and evaluates one shunt
for *one* parameter vector, to ~1e-9. This sub-package does the same arithmetic for every draw of a
posterior in one array pass, for :mod:`bayes_emt.shunt.robust`; each module names the nominal
function it mirrors:

=========================  ===============================================  ===========================
module                     batched counterpart of                           kept equal by
=========================  ===============================================  ===========================
:mod:`.plant`              :func:`~bayes_emt.shunt.instability_threshold`   tests/test_shunt_robust.py
:mod:`.peaks`              :meth:`Plant.peak <bayes_emt.shunt.Plant.peak>`  tests/test_shunt_robust.py
:mod:`.design`             :func:`~bayes_emt.shunt.design_rc_shunt`         tests/test_shunt_robust.py
=========================  ===============================================  ===========================

Why two forms and not one kernel: the nominal design loops over one vector with scalar root
finding and exact pole checks (it is the reference); the batched one shares frequency grids across
draws and solves all draws' equal-peak conditions by one Newton iteration, which is what makes 1000
draws affordable. Sharing one kernel would either slow the nominal design's exact path down or make
the reference depend on the approximations it checks. The batched path falls back to
:func:`~bayes_emt.shunt.design_rc_shunt` for any draw it cannot settle, and the tests compare the two
draw by draw.
"""

from .design import DrawOptima, design_draws
from .peaks import PeakBatch, rc_peaks_batch
from .plant import BatchPlant, Crossings, SampledShunt, terminal_impedance

__all__ = ["BatchPlant", "Crossings", "SampledShunt", "terminal_impedance", "PeakBatch", "rc_peaks_batch",
           "DrawOptima", "design_draws"]
