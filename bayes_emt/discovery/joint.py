"""Joint evidence (issue 23): the physics a diagnosis names must explain a second recording too.

A diagnosis of recording A names terms; a second recording B of the same transducer (a known added
mass ``Δm`` [kg], or the same driver at another drive level or session: ``Δm`` ``None``) must need
them as well: the coil and the suspension do not change with a mass on the cone (an instrument step
of one session is what B should not need, and is then flagged). :func:`check_with` refits B with A's
final model and, for each finding, with that finding taken out (a term removed; for the eddy-current
escalation, the coil model it replaced), from A's final values (``ω0`` moved to B's resonance). The
finding's evidence gain on B is ``Δ log Z_B = log Z_B(final) − log Z_B(final without it)`` (the
Laplace screen of :mod:`bayes_emt.evidence`; when it fails on either side, both sides are taken by
Schwarz's approximation, the maximum log-likelihood less ``½ k ln N``, and the record says
``"method": "bic"``). A finding with
``Δ log Z_B <`` :data:`MIN_DELTA_LOG_Z` (the acceptance threshold of :mod:`.name`) is one only A
needs: it is **flagged** (a warning). With ``Δm`` the joint added-mass fit
(:func:`bayes_emt.added_mass.fit_added_mass`: one ``m, c, k, φ`` and one coil shared by both runs)
is run with A's baseline and final models; the record gives ``m``, ``Bl``, ``k``, ``R0`` and the
pair's consistency F-test for each, so one sees whether the named physics explains both recordings
in one fit.

A term B needs but A did not name is not looked for here: diagnose B for that.
"""

from __future__ import annotations

import dataclasses
import math

from ..added_mass import fit_added_mass
from ..errors import FitError
from ..estimation.checks import locate_resonance
from ..estimation.fitting import fit_admittance
from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, Model, parse_model_spec
from .name import MIN_DELTA_LOG_Z, log_evidence, max_log_likelihood

__all__ = ["check_with", "with_second_recordings", "model_without"]


def model_without(diag, i: int) -> Model:
    """The final model of ``diag`` with its finding ``i`` taken out: its terms removed, or for the
    eddy-current escalation the coil model before it (the previous finding's, or the baseline's)."""
    final = diag.final_fit.model
    f = diag.findings[i]
    ids = f.physics.split("+")
    m = final
    for t in final.augmentations:
        if t.id in ids:
            m = m.without(t)
    if EDDY_PHYSICS in ids:
        before = diag.findings[i - 1].model_spec if i > 0 else diag.baseline_fit.model.label
        coil = before.split("+")[0]
        m = parse_model_spec("+".join([coil, *[t.id for t in m.augmentations]]))
    return m


def _fit(meas: Measurement, model: Model, start: dict) -> FitResult:
    """The better (by χ²) of ``model``'s fits from ``start`` (when it names every parameter) and from
    the automatic initial estimate: a start carried over from the other recording may sit in
    another basin."""
    init = {k: v for k, v in start.items() if k in model.names}
    fits = []
    for kw in ([{"initial": init}] if len(init) == len(model.names) else []) + [{}]:
        try:
            fits.append(fit_admittance(meas, model, **kw))
        except (FitError, ValueError):
            continue
    if not fits:
        raise FitError(f"{meas.source}: {model.label} could not be fitted")
    return min(fits, key=lambda f: f.chi2)


def check_with(diag, other: Measurement, delta_m: float | None = None, *, meas: Measurement | None = None
               ) -> dict:
    """The joint-evidence record of ``diag`` (of ``meas``) against ``other`` (module docstring):
    ``{"source", "delta_m_kg", "final_model", "log_z_final" [nats], "terms": [{"physics",
    "delta_log_evidence_other" [nats], "needed_by_other", "model_without", "note"}], "flagged":
    [physics], "added_mass": {...} (with ``delta_m`` and ``meas``)}``."""
    if delta_m is not None and not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"--also {other.source}: the added mass must be a non-zero number of kg, "
                         f"got {delta_m!r}")
    final = diag.final_fit.model
    start = final.as_dict(diag.final_fit.theta)
    res = locate_resonance(other)
    if res is not None and "omega0" in start:
        start["omega0"] = float(res.omega)
    fb = _fit(other, final, start)
    lz = log_evidence(other, fb)
    start_b = fb.model.as_dict(fb.theta)
    n_values = 2 * other.n_points

    def bic(f: FitResult) -> float:  # Schwarz: max log-likelihood - k/2 ln N
        return max_log_likelihood(other, f) - 0.5 * f.model.ndim * math.log(n_values)

    method = "laplace" if math.isfinite(lz) else "bic"
    terms, flagged = [], []
    for i, f in enumerate(diag.findings):
        m0 = model_without(diag, i)
        try:
            f0 = _fit(other, m0, start_b)
            lz0 = log_evidence(other, f0) if method == "laplace" else math.nan
            how = method
            if not math.isfinite(lz0):  # the Laplace screen failed: both sides by BIC
                lz_with, lz0, how = bic(fb), bic(f0), "bic"
            else:
                lz_with = lz
        except (FitError, ValueError) as exc:
            terms.append({"physics": f.physics, "delta_log_evidence_other": None, "needed_by_other": None,
                          "model_without": m0.label, "note": f"the fit without it failed: {exc}"})
            continue
        d = lz_with - lz0 if math.isfinite(lz_with) and math.isfinite(lz0) else float("nan")
        needed = bool(d >= MIN_DELTA_LOG_Z) if math.isfinite(d) else None
        note = (f"{other.source} needs it too (log Z {d:+.1f} nats with it)" if needed
                else f"{other.source} does not need it (log Z {d:+.1f} nats with it, < {MIN_DELTA_LOG_Z:g}): "
                     "a term only one recording needs" if needed is False
                else "the evidence on the second recording failed")
        if needed is False:
            flagged.append(f.physics)
        terms.append({"physics": f.physics, "delta_log_evidence_other": d if math.isfinite(d) else None,
                      "needed_by_other": needed, "model_without": m0.label, "note": note, "method": how})
    rec = {"source": str(other.source), "delta_m_kg": delta_m, "final_model": final.label,
           "rms_rel_residual_other": fb.rms_rel_residual,
           "log_z_final": lz if math.isfinite(lz) else None, "terms": terms, "flagged": flagged}
    if delta_m is not None and meas is not None:
        rec["added_mass"] = {}
        for which, fit in (("baseline", diag.baseline_fit), ("final", diag.final_fit)):
            try:
                r = fit_added_mass(meas, other, float(delta_m), fit.model, base_fit=fit,
                                   loaded_fit=fb if which == "final" else None)
            except (FitError, ValueError) as exc:
                rec["added_mass"][which] = {"model": fit.model.label, "error": str(exc)}
                continue
            rec["added_mass"][which] = {
                "model": fit.model.label, "m_kg": r.values["m"], "Bl_N_per_A": r.values["phi_raw"],
                "k_N_per_m": r.values["k"], "R0_ohm": r.values.get("R0"),
                "consistency_p_value": r.consistency["p_value"], "consistency_F": r.consistency["F"],
                "rms_rel_residual": list(r.rms_rel_residual)}
    return rec


def with_second_recordings(diag, meas: Measurement, also) -> object:
    """``diag`` with the joint-evidence records of ``also`` (``[(recording, delta_m_kg or None), ...]``)
    in its ``joint`` field and a warning per flagged finding."""
    recs, warn = [], list(diag.warnings)
    for other, dm in also:
        rec = check_with(diag, other, dm, meas=meas)
        recs.append(rec)
        for t in rec["terms"]:
            if t["needed_by_other"] is False:
                warn.append(f"{t['physics']}: {t['note']} (joint evidence)")
    return dataclasses.replace(diag, joint=tuple(recs), warnings=tuple(warn))
