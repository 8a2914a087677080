"""The files of a run folder that the report reads (one place for their names).

A run folder is what ``bayes-emt demo --out DIR`` writes; any folder holding some of these files,
or the individual commands' outputs under any names (found by their recorded kind,
:mod:`.load`), can be reported on (``bayes-emt report DIR``). Every entry is optional: the report renders the
sections whose files exist and says plainly which steps were not run.

================================  =============================================================
file                              written by / content
================================  =============================================================
``run.json``                      the demo: data summary, steps run or skipped (and why), timing
``ts.json``                       ``ts --json`` (Thiele–Small parameters with intervals; else the
                                  report derives the free-air set from the best fit, no intervals)
``fits.json``                     ``{model: fit --json record}`` (parameters, stderr, units)
``hankel.json``                   NL ring count by Hankel singular values
``comparison.json``               ``compare --json`` (log Z per method, Bayes factors, scale)
``evidence.png``                  ``compare --plot`` bar chart
``posterior.json`` / ``.nc``      ``sample --json`` / ``--out`` (ArviZ DataTree)
``posterior_bode.png``            Bode plot with posterior bands (redrawn from ``.nc`` if absent)
``posterior_corner.png``          corner plot (redrawn from ``.nc`` if absent)
``residuals.png``                 relative residuals of every fit over frequency
``shunts.json``                   H∞-optimal RC shunt per model, each evaluated on the best fit
``robust_shunt.json``             ``shunt --posterior --json``
``shunt_robust_*.png``            ``shunt --posterior --plot`` (gain bands, distributions, boundary)
``diagnosis.json``                ``diagnose --json``
``diagnosis_residuals.png``       residuals of the diagnosed recording with the flagged bands
                                  (``diagnose --plot``, with ``diagnosis_bode.png``)
``diagnosis/*.png``               ``diagnose --plot`` figures
================================  =============================================================
"""

from __future__ import annotations

__all__ = ["RUN", "FITS", "HANKEL", "COMPARISON", "EVIDENCE_PNG", "POSTERIOR_JSON", "POSTERIOR_NC",
           "POSTERIOR_BODE", "POSTERIOR_CORNER", "RESIDUALS_PNG", "SHUNTS", "ROBUST", "ROBUST_PNGS",
           "DIAGNOSIS", "DIAGNOSIS_RESIDUALS", "DIAGNOSIS_DIR", "REPORT", "TS"]

RUN = "run.json"
TS = "ts.json"
FITS = "fits.json"
HANKEL = "hankel.json"
COMPARISON = "comparison.json"
EVIDENCE_PNG = "evidence.png"
POSTERIOR_JSON = "posterior.json"
POSTERIOR_NC = "posterior.nc"
POSTERIOR_BODE = "posterior_bode.png"
POSTERIOR_CORNER = "posterior_corner.png"
RESIDUALS_PNG = "residuals.png"
SHUNTS = "shunts.json"
ROBUST = "robust_shunt.json"
#: (file, caption) of the robust shunt's figures, in the order shown
ROBUST_PNGS = (("shunt_robust_gain.png", "gain of the nominal and robust shunts over the posterior draws"),
               ("shunt_robust_distributions.png",
                "distributions of Rs, Cs and the attenuation over the draws"),
               ("shunt_robust_boundary.png", "stability boundary in the (Rs, Cs) plane with the draws"))
DIAGNOSIS = "diagnosis.json"
DIAGNOSIS_RESIDUALS = "diagnosis_residuals.png"
DIAGNOSIS_DIR = "diagnosis"
REPORT = "report.html"
