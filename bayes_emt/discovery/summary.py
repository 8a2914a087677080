"""A diagnosis in the driver's terms: at most :data:`MAX_LINES` lines a loudspeaker engineer reads.

:func:`summary_lines` gives, in order: the recording and the time; the start and the final model with
their rms relative residual; the final fit's Thiele–Small values; each finding as its physics, the
band in Hz where it changes the fit and its effect on the Thiele–Small values; box terms when the final
model has a port (the port tuning fb [Hz], the box's Q, the driver's resonance in the box) or the
setup is a sealed box (the in-box resonance fc and Qtc); a ring ladder's coil as its inductance and
loss resistance at 100 Hz, 1 kHz and 10 kHz (the ladder's raw values stay in the JSON); the bands
left unexplained; the warnings that change a decision. The statistics behind each line (log
evidence, χ², standard errors, the candidates tried) are the verbose output's.

Thiele–Small values here follow the Thiele–Small convention: ``fs`` and ``Qms`` at the resonance of
the mechanical impedance with every stiffness term (:func:`~bayes_emt.models.derived.mechanical_resonance`:
under suspension creep they differ from the model's ``ω0/2π`` and ``1/(2ζ)``), ``Re = R0``,
``Qes = ωs Re / φ̄²`` with ``φ̄ = Bl/√Mms`` (Small 1972), ``Qts = Qms Qes/(Qms + Qes)``.
"""

from __future__ import annotations

import math

import numpy as np

from ..estimation.results import FitResult
from ..models import EDDY_PHYSICS, TERMS
from ..models.derived import mechanical_resonance

__all__ = ["summary_lines", "ts_values", "MAX_LINES", "DECISION_WORDS"]

#: the default output's line budget
MAX_LINES = 20
#: a warning holding one of these changes what the user does with the result (the rest: --verbose)
DECISION_WORDS = ("refused", "broken physics", "time budget", "cannot tell", "R0 moved", "resonance away",
                  "two drivers", "joint evidence", "not determined", "stopped after", "indistinguishable")
#: frequencies [Hz] at which a ring ladder's coil is summarised
COIL_HZ = (100.0, 1000.0, 10000.0)


def ts_values(fit: FitResult) -> dict[str, float]:
    """``{"fs" [Hz], "Re" [ohm], "Qms", "Qes", "Qts"}`` of ``fit`` (module docstring); ``{}`` when the
    model has no driver resonance."""
    m = fit.model
    if not all(n in m.names for n in ("zeta", "omega0", "phi", "R0")):
        return {}
    th = np.asarray(fit.theta, float)[None, :]
    ws, qms, _ = mechanical_resonance(m, th)
    ws, qms = float(ws[0]), float(qms[0])
    v = m.as_dict(fit.theta)
    qes = ws * v["R0"] / v["phi"] ** 2
    return {"fs": ws / (2 * math.pi), "Re": v["R0"], "Qms": qms, "Qes": qes, "Qts": qms * qes / (qms + qes)}


def _ts_words(ts: dict) -> str:
    return (f"fs {ts['fs']:.4g} Hz, Re {ts['Re']:.4g} ohm, Qms {ts['Qms']:.3g}, Qes {ts['Qes']:.3g}, "
            f"Qts {ts['Qts']:.3g}")


def _effect(moved: dict) -> str:
    """A finding's effect on the T/S values [%] from its ``moved`` record (the plant before and after
    it), the largest moves first; below 0.5 % left out."""
    def val(key, when):
        rec = moved.get(key)
        return None if not rec or rec.get(when) is None else float(rec[when])

    ch = []
    for k, key in (("fs", "fs_hz"), ("Re", "R0"), ("Qms", "Qms")):
        a, b = val(key, "before"), val(key, "after")
        if a and b is not None:
            ch.append((k, 100 * (b / a - 1)))
    q = [val(k, w) for w in ("before", "after") for k in ("fs_hz", "R0", "phi")]
    if all(x for x in q):  # Qes = ws Re / phi^2
        ch.append(("Qes", 100 * ((q[3] * q[4] / q[5] ** 2) / (q[0] * q[1] / q[2] ** 2) - 1)))
    ch = [(k, c) for k, c in ch if math.isfinite(c) and abs(c) >= 0.5]
    if not ch:
        return "T/S values move less than 0.5 %" if moved else ""
    ch.sort(key=lambda kc: -abs(kc[1]))
    return ", ".join(f"{k} {c:+.1f} %" for k, c in ch)


def _physics_words(physics: str, model_spec: str = "") -> str:
    out = []
    for p in physics.split("+"):
        cls = TERMS.get(p)
        desc = getattr(cls, "description", "") if cls is not None else ""
        if p == EDDY_PHYSICS:
            coil = model_spec.split("+")[0]
            desc = "eddy currents in the pole piece" + (f", coil model {coil}" if coil else "")
        out.append(f"{p} ({desc.split(':')[0]})" if desc else p)
    return " + ".join(out)


def _hz(lo: float, hi: float) -> str:
    return f"{lo / (2 * math.pi):.3g}-{hi / (2 * math.pi):.3g} Hz"


def box_line(fit: FitResult, setup: str = "unknown") -> str:
    """The box terms of ``fit`` (module docstring), ``""`` without a box."""
    v = fit.model.as_dict(fit.theta)
    ts = ts_values(fit)
    # a term that takes part of the resonance (a port or passive radiator): its tuning and damping
    box = next((t for t in fit.model.augmentations if t.moves_resonance), None)
    if box is not None:
        w = next((n for n in box.params.names if n.startswith("omega")), None)
        z = next((n for n in box.params.names if n.startswith("zeta")), None)
        if w is not None and z is not None:
            peaks = _impedance_peaks(fit)
            pk = (", impedance peaks at " + " and ".join(f"{p:.3g}" for p in peaks) + " Hz") if peaks else ""
            fb, qb = v[w] / (2 * math.pi), 1 / (2 * v[z])
            return (f"vented box (final fit): fb {fb:.4g} Hz, Qb {qb:.3g} (box losses), the driver's "
                    f"resonance in the box {ts.get('fs', float('nan')):.4g} Hz{pk}")
    if setup == "sealed" and ts:
        return (f"sealed box (final fit): the driver's in-box resonance fc {ts['fs']:.4g} Hz, Qtc "
                f"{ts['Qts']:.3g} (free-air fs needs a free-air recording)")
    return ""


def _impedance_peaks(fit: FitResult) -> list[float]:
    """Local maxima of the final model's |Z| between 1 and 1000 Hz [Hz]."""
    om = 2 * math.pi * np.geomspace(1.0, 1000.0, 2000)
    with np.errstate(all="ignore"):
        z = np.abs(fit.model.impedance(om, fit.theta))
    i = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] > z[2:])) + 1
    return [float(om[k] / (2 * math.pi)) for k in i][:3]


def coil_line(fit: FitResult, f_range: tuple[float, float] | None = None) -> str:
    """A ring ladder (or any lossy coil model) as Le and loss resistance at :data:`COIL_HZ` (those
    inside ``f_range`` [Hz], the recording's band, when given: no extrapolation)."""
    m = fit.model
    if getattr(m, "rings", None) is None and not any(t.stage == "series" for t in m.augmentations):
        return ""
    hz = [f for f in COIL_HZ if f_range is None or f_range[0] <= f <= f_range[1]]
    if not hz:
        return ""
    om = 2 * math.pi * np.asarray(hz)
    with np.errstate(all="ignore"):
        zc = np.asarray(m.coil_impedance(om, np.asarray(fit.theta, float)[None, :]))[0]
    le = ", ".join(f"{1e3 * z.imag / w:.3g} mH" for z, w in zip(zc, om, strict=True))
    rl = ", ".join(f"{z.real:.3g} ohm" for z in zc)
    at = ", ".join(f"{f:g}" for f in hz)
    return f"coil (final fit) at {at} Hz: Le {le}; loss resistance {rl}"


def summary_lines(d, setup: str = "unknown", max_lines: int = MAX_LINES,
                  f_range: tuple[float, float] | None = None) -> list[str]:
    """The default output of a diagnosis ``d`` (module docstring), at most ``max_lines`` lines;
    ``f_range`` the recording's band [Hz] (the coil is summarised inside it)."""
    fin = d.final_fit
    out = [f"start {d.baseline_model} (rms residual {100 * d.baseline_fit.rms_rel_residual:.3g} %) -> final "
           f"{d.final_model} ({100 * fin.rms_rel_residual:.3g} %)"]
    ts = ts_values(fin)
    if ts:
        out.append("Thiele-Small values of the final fit: " + _ts_words(ts))
    for i, f in enumerate(d.findings, 1):
        eff = _effect(f.parameters.get("moved") or {})
        where = "broadband, " if f.broadband else ""
        narrow = (" (a narrow resonance: see --verbose for the band to exclude)"
                  if "a narrow resonance at" in f.explanation else "")
        words = _physics_words(f.physics, f.model_spec)
        out.append(f"finding {i}: {words}, {where}{_hz(f.band.lo, f.band.hi)}"
                   + (f"; effect on T/S: {eff}" if eff else "") + narrow
                   + ("" if f.identifiable else "; its values are not determined by the data"))
    for line in (box_line(fin, setup), coil_line(fin, f_range)):
        if line:
            out.append(line)
    if not d.findings and not d.unexplained:
        out.append("no significant mismatch between the model and the recording")
    un = list(d.unexplained)
    for u in un[:3]:
        out.append("unexplained: " + u["description"])
    if len(un) > 3:
        out.append(f"unexplained: {len(un) - 3} more band(s) (--verbose)")
    for j in d.joint:
        out.extend(joint_lines(j))
    decisive = [w for w in d.warnings if any(k in w for k in DECISION_WORDS)
                and "within the margin a patch needs" not in w]
    room = max_lines - len(out) - 1
    for w in decisive[:max(room, 0)]:
        out.append("warning: " + w)
    rest = len(d.warnings) - min(len(decisive), max(room, 0))
    if rest > 0:
        out.append(f"{rest} more warning(s) and the statistics behind each line: --verbose or --json")
    return out[:max_lines]


def joint_lines(j: dict) -> list[str]:
    """One joint-evidence record (:mod:`.joint`) in one or two lines: the terms both recordings need,
    those flagged, the second recording's own diagnosis; the joint added-mass fit of the final model
    (moving mass, force factor) when a mass was given."""
    terms = j["terms"]
    if j.get("method") == "laplace-joint":  # one evidence of both recordings per finding
        parts = _joint_verdicts(terms)
    else:  # a record of the earlier check (the other recording's evidence alone)
        need = [t for t in terms if t.get("needed_by_other")]
        both = [t["physics"] for t in need if t.get("values_agree") is not False]
        other = [t["physics"] for t in need if t.get("values_agree") is False]
        flag = [t["physics"] for t in terms if t.get("needed_by_other") is False]
        parts = [f"needed by both: {', '.join(both) or 'none'}"]
        if other:
            parts.append(f"used with other values there (flagged): {', '.join(other)}")
        if flag:
            parts.append(f"not needed there (flagged): {', '.join(flag)}")
    sr = j.get("search")
    if sr:
        only = [t["physics"] for t in sr.get("only_other", ())]
        parts.append(f"its own diagnosis: {sr['baseline_model']} -> {sr['final_model']} "
                     f"({', '.join(sr['findings']) or 'no finding'})"
                     + (f", named only there: {', '.join(only)}" if only else ""))
    out = [f"joint evidence with {j['source']}: " + "; ".join(parts)]
    a = (j.get("added_mass") or {}).get("final")
    if a and "error" not in a:
        out.append(f"joint added-mass fit, final {a['model']}: m {a['m_kg']:.4g} kg, "
                   f"Bl {a['Bl_N_per_A']:.4g} "
                   f"N/A, k {a['k_N_per_m']:.4g} N/m, R0 {a['R0_ohm']:.4g} ohm, consistency p "
                   f"{a['consistency_p_value']:.3g}" + (" (F-test, a diagnostic: the verdicts are the "
                                                        "joint evidence's)" if j.get("method") else ""))
    return out


def _joint_verdicts(terms) -> list[str]:
    """The joint evidence's verdicts in words, each finding with its Δ log Z_joint [nats]."""
    groups: dict[str, list[str]] = {}
    for t in terms:
        d = t.get("delta_log_z_joint")
        groups.setdefault(t.get("verdict", "not judged"), []).append(
            t["physics"] + ("" if d is None else f" (joint delta log Z {d:+.1f} nats)"))
    words = {"shared, kept": "shared by both, kept",
             "flagged: not shared": "not shared (flagged: one recording's alone)",
             "flagged: other values": "used with other values there (flagged)",
             "not judged": "not judged (the joint evidence failed)"}
    parts = [f"{words.get(v, v)}: {', '.join(g)}" for v, g in groups.items()]
    return parts or ["no finding to check"]
