"""Is a shunt's stability margin larger than what is known about R0? And can its parts be built?

A negative-resistance shunt is stable only while ``Rs`` stays above the loop's instability
threshold ``Rs_instability``; R0 enters the terminal impedance additively, so the stability margin
``Rs − Rs_instability`` [Ω] is also how far the real R0 may lie *below* the R0 the design assumed
(:mod:`bayes_emt.shunt.robust`). A margin smaller than the uncertainty of R0 means the shunt may
drive the structure instead of damping it: :func:`check_margin` then gives a warning with code
``stability_margin_below_uncertainty``.

R0 uncertainty, as a half-width [Ω] per source (:func:`r0_uncertainty`; the largest is compared):

* ``fit_standard_error``: 1.645 × the least-squares fit's standard error of R0 (a 90 % half-width);
* ``posterior_interval``: half the posterior's 90 % interval of R0;
* ``total_interval``: the same with the R0 draws widened by the spread between the fit's R0 and the
  recording's low-frequency plateau (:mod:`bayes_emt.shunt.r0_spread`): the interval ``ts`` reports
  for Re, which says how far another bench's Re may lie;
* ``model_spread``: the largest difference between this design's R0 and the R0 of the other
  models given (adequate models disagree on R0 when they split the coil's loss differently);
* ``procedure_spread``: the difference between the fit procedures' R0 (``fit --json`` records it);
* ``ohmmeter_tolerance``: a DC measurement's tolerance, when given.

Extreme parts get a plain note: ``Cs > 1 F`` (no practical capacitor) and ``|Rs + R0| < 1 %`` of R0
(the negative resistance must cancel the coil's to better than 1 %) can only be realised as a
synthetic impedance (an active circuit: a negative-impedance converter, or a current-driving DSP
controller as in ``shunt --implement``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .._json import strict_json

__all__ = ["MarginCheck", "check_margin", "r0_uncertainty", "r0_uncertainty_of_files", "MARGIN_CODE", "Z90",
           "CS_EXTREME_F", "NET_R_EXTREME"]

MARGIN_CODE = "stability_margin_below_uncertainty"
Z90 = 1.6448536269514722  # standard-normal quantile of 0.95: a 90 % two-sided half-width in SE units
CS_EXTREME_F = 1.0  # [F]
NET_R_EXTREME = 0.01  # |Rs + R0| below this fraction of R0

_WHAT = {"fit_standard_error": "1.645 x the fit's standard error of R0 (90 %)",
         "posterior_interval": "half the posterior's 90 % interval of R0",
         "total_interval": ("half the 90 % interval of R0 with the spread between the fit's R0 and the "
                            "recording's low-frequency plateau"),
         "model_spread": "the largest R0 difference to the other models given",
         "procedure_spread": "the R0 difference between the fit procedures",
         "ohmmeter_tolerance": "the ohmmeter's tolerance"}


def r0_uncertainty(*, R0: float | None = None, stderr: float | None = None,
                   draws: Iterable[float] | None = None, models: Iterable[float] | None = None,
                   procedures: Iterable[float] | None = None, ohmmeter: float | None = None) -> dict:
    """The R0 uncertainty [Ω] per source (module docstring) from what is at hand; sources not
    given (or not finite) are left out.

    ``R0`` is the design's R0 [Ω] (needed for ``models`` and ``procedures``); ``stderr`` the fit's
    standard error [Ω]; ``draws`` posterior draws of R0 [Ω]; ``models`` the R0 [Ω] of other models;
    ``procedures`` the R0 [Ω] of other fit procedures; ``ohmmeter`` a tolerance [Ω] (≥ 0).
    """
    out = {}
    if stderr is not None and math.isfinite(float(stderr)):
        out["fit_standard_error"] = Z90 * abs(float(stderr))
    if draws is not None:
        d = np.asarray(list(draws), float)
        d = d[np.isfinite(d)]
        if d.size >= 2:
            q = np.quantile(d, [0.05, 0.95])
            out["posterior_interval"] = float(q[1] - q[0]) / 2
    for key, vals in (("model_spread", models), ("procedure_spread", procedures)):
        if vals is None or R0 is None:
            continue
        v = np.asarray(list(vals), float)
        v = v[np.isfinite(v)]
        if v.size:
            out[key] = float(np.max(np.abs(v - float(R0))))
    if ohmmeter is not None:
        tol = float(ohmmeter)
        if not (tol >= 0 and math.isfinite(tol)):
            raise ValueError(f"the ohmmeter tolerance must be a non-negative number of ohm, got {ohmmeter!r}")
        out["ohmmeter_tolerance"] = tol
    return out


def r0_uncertainty_of_files(params, *, others=(), ohmmeter: float | None = None) -> dict:
    """:func:`r0_uncertainty` from parameter files as ``fit --json`` writes them: the standard
    error and the procedures' R0 recorded in ``params`` (``stderr.R0``, ``R0_by_procedure``), the R0
    of each file in ``others`` (other models fitted to the same data), and an ohmmeter tolerance."""
    import json
    from pathlib import Path

    from ..io.paramfile import read_param_file

    model, theta = read_param_file(params)
    R0 = float(theta[model.params.index("R0")])
    try:
        rec = json.loads(Path(params).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        rec = {}
    se = (rec.get("stderr") or {}).get("R0") if isinstance(rec, dict) else None
    by = rec.get("R0_by_procedure") if isinstance(rec, dict) else None
    procs = [v for v in by.values() if isinstance(v, int | float)] if isinstance(by, dict) else None
    r0s = []
    for other in others:
        m2, th2 = read_param_file(other)
        if "R0" in m2.params.names:
            r0s.append(float(th2[m2.params.index("R0")]))
    return r0_uncertainty(R0=R0, stderr=se if isinstance(se, int | float) else None, models=r0s or None,
                          procedures=procs, ohmmeter=ohmmeter)


@dataclass(frozen=True)
class MarginCheck:
    """A shunt's stability margin against the R0 uncertainty, and notes on realising it.

    Attributes
    ----------
    stability_margin_ohm : ``Rs − Rs_instability`` [Ω] (how far R0 may lie below the design's).
    r0_uncertainty_ohm : the largest R0 half-width given [Ω] (``None``: none given).
    r0_uncertainty : half-width [Ω] per source (module docstring).
    warnings : ``({"code", "message"}, ...)``; ``stability_margin_below_uncertainty`` when the margin
        is smaller than ``r0_uncertainty_ohm``.
    notes : plain notes (extreme parts; no uncertainty given).
    """

    stability_margin_ohm: float
    r0_uncertainty_ohm: float | None
    r0_uncertainty: dict = field(default_factory=dict)
    warnings: tuple = ()
    notes: tuple = ()

    def to_json_dict(self) -> dict:
        return strict_json({"stability_margin_ohm": self.stability_margin_ohm,
                            "r0_uncertainty_ohm": self.r0_uncertainty_ohm,
                            "r0_uncertainty": dict(self.r0_uncertainty),
                            "warnings": [dict(w) for w in self.warnings], "notes": list(self.notes)})


def check_margin(Rs: float, Cs: float, Rs_instability: float, R0: float,
                 r0_sources: Mapping[str, float] | None = None, *, what: str = "the shunt") -> MarginCheck:
    """Compare ``Rs − Rs_instability`` [Ω] with the largest R0 half-width in ``r0_sources`` [Ω]
    (:func:`r0_uncertainty`), and note parts that need a synthetic impedance (module docstring)."""
    margin = float(Rs) - float(Rs_instability)
    sources = {k: float(v) for k, v in (r0_sources or {}).items()
               if v is not None and math.isfinite(float(v))}
    unc = max(sources.values()) if sources else None
    warns, notes = [], []
    if unc is not None and not margin > unc:
        key = max(sources, key=sources.get)
        pct = 100 * margin / abs(R0) if R0 else math.nan
        warns.append({"code": MARGIN_CODE, "message": (
            f"{what} (Rs = {Rs:.5g} ohm) is {margin:.4g} ohm ({pct:.2g} % of R0 = {R0:.4g} ohm) above the "
            f"instability threshold Rs = {Rs_instability:.5g} ohm, less than the R0 uncertainty "
            f"{unc:.4g} ohm ({_WHAT.get(key, key)}): if the real R0 is that much lower, the loop is "
            "unstable and the shunt drives the structure instead of damping it; use a shunt designed "
            "under uncertainty (shunt --posterior) or a less negative Rs")})
    elif unc is None and Rs < 0:
        notes.append(f"{what}: no R0 uncertainty given, so the stability margin {margin:.4g} ohm is "
                     "compared with nothing (give the fit's standard error, a posterior, other models' R0 "
                     "or an ohmmeter tolerance)")
    if math.isfinite(Cs) and Cs > CS_EXTREME_F:
        notes.append(f"Cs = {Cs:.4g} F is far beyond practical capacitors: realise it as a synthetic "
                     "impedance (an active circuit, e.g. a DSP-controlled current source, shunt --implement)")
    net = abs(Rs + R0)
    if R0 and net < NET_R_EXTREME * abs(R0):
        notes.append(f"|Rs + R0| = {net:.4g} ohm is {100 * net / abs(R0):.2g} % of R0 = {R0:.4g} ohm: the "
                     "negative resistance must cancel the coil's to better than 1 %, which only a synthetic "
                     "impedance (an active circuit with a calibrated R0 estimate) can do")
    return MarginCheck(margin, unc, sources, tuple(warns), tuple(notes))
