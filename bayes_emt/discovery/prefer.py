"""Right physics before flexible physics: setups, patch terms, and where a finding acts.

Brynjarsdóttir & O'Hagan (2014): a flexible term absorbs whatever misfit a model leaves, the fit
improves and the physics gets worse. Discovery therefore treats the terms a registry class marks
``generic`` (:attr:`~bayes_emt.models.term.Term.generic`: an instrument step, a broad extra mode, an
extra coil section) and NL ring counts above the first rung of the eddy-current escalation as
**patches**, which must earn their place (:func:`patch_problem`, :func:`choose`):

* their added parameters are determined by the data (relative sd below ``MAX_REL_SE``);
* a step term (:attr:`~bayes_emt.models.term.Term.step_at`) needs evidence of its own: the measured
  points either side of the step frequency are discontinuous beyond the noise (:func:`step_evidence`);
* a mode term with :attr:`~bayes_emt.models.term.Term.narrow_when` is a patch only when broad (its
  fitted damping ratio at or above the limit); a narrow mode is physics;
* a patch is chosen over the best *physical* candidate for the same band only when its
  ``Δ log Z`` exceeds that candidate's by the **patch margin** (:func:`patch_margin`). Within that
  margin the data do not tell them apart and the physical one is kept (a warning says so);
* a patch named in one round whose added parameters move, in a later round's fit, by more than
  :data:`STABLE_SE` standard errors was absorbing what the later term explains: it is flagged, and
  dropped when the final model without it loses less than its margin (:func:`stability_review`).

**The patch margin grows with the record** (:func:`patch_margin`)::

    margin = ℓ · max(PATCH_MARGIN, ½ Δk ln N),   ℓ = (1 + ρ₁)/(1 − ρ₁) ≥ 1

with ``N`` the number of real data values (two per frequency), ``Δk`` the parameters the patch adds
beyond the physical candidate's, and ``ρ₁`` the lag-1 autocorrelation of the patch fit's normalised
residual over the points where it fits better than the physical candidate
(:func:`change_band` of the one against the other). Two reasons, both about a real recording's many
points. (i) ``½ ln N`` per extra parameter is the BIC price of a parameter (Schwarz 1978): the
Laplace evidence charges a patch's broad priors once, while ``Δ log Z`` itself grows like ``N``
times the per-point gain, so a fixed margin asks less and less of each point as the record grows;
the floor :data:`PATCH_MARGIN` (10 nats) keeps what it was for short records. (ii) ``Δ log Z``
counts every residual as independent. Where both candidates leave structured misfit (a real
recording's 2-5 %, not the 0.2-0.5 % noise), neighbouring residuals are correlated and the
likelihood overstates the information ``ℓ``-fold (the effective sample size of an AR(1) series,
``N (1 − ρ₁)/(1 + ρ₁)``): the margin is asked in independent data. White residuals (a patch that is
the truth) give ``ℓ ≈ 1``; a denser grid over the same structured misfit gives a larger ``ρ₁``, so the
margin scales with the record length where the misfit is structured and stays near the floor where
it is not. ``ρ₁`` is the residual the patch *leaves*, never the residual before it: an unexplained
instrument step makes the residual before it correlated by itself (ℓ 33-40 on an NL(5) plant with a
phase step 25 times the 0.2 % noise, against 1.00 once the step is fitted), so a margin from the
residual before would grow with the very evidence for the patch.

**Masked second effects.** When a patch leads a band, the best physical term is also paired with
every other physical candidate (a creep under a coil misfit gains nothing alone while the coil
misfit dominates the record), and the leading patch with the same partners, so the two compare on
the same footing (:func:`bayes_emt.discovery.name.rank_candidates`).

**A narrow mode** (a mode term with ``narrow_when`` fitted narrow) is physics, but a lumped driver
model has no place for it: its finding reads "narrow resonance at f Hz, Q ≈ …" with the band to
exclude when a lumped fit is wanted (:func:`narrow_mode_note`).

**Setups** (:data:`SETUPS`): a term declaring :attr:`~bayes_emt.models.term.Term.requires_setup` is
tried only in those setups (a port needs a vented box: never in free air, a sealed box or on a
shaker). With ``unknown`` a term may further need a data signature
(:attr:`~bayes_emt.models.term.Term.unknown_setup_needs`): ``"two_impedance_maxima"``
(:func:`two_impedance_maxima`): |Z|, smoothed over 5 points, has two interior local maxima within a
factor 10 in frequency of each other, each standing at least 10 % (0.1 in ln|Z|) above the minimum
between them — a vented box's two peaks around the port tuning.

**Where a finding acts** (:func:`change_band`): the points where adding the term lowers the squared
normalised residual, smoothed over 8 points; the band holds the central 90 % of that improvement.
Wider than two decades it is reported as broadband with its shape (where the change concentrates
and whether it grows or falls with frequency).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal, stats

from ..estimation.results import FitResult
from ..measurement import Measurement
from ..models import EDDY_PHYSICS, TERMS
from ..models.residual import relative_residual
from .candidates import RING_COUNTS

__all__ = [
    "SETUPS",
    "PATCH_MARGIN",
    "NEAR_TIE",
    "check_setup",
    "setup_excludes",
    "two_impedance_maxima",
    "is_patch",
    "step_evidence",
    "local_step",
    "local_step_fit",
    "change_band",
    "BROADBAND_DECADES",
    "choose",
    "patch_margin",
    "residual_correlation",
    "STABLE_SE",
    "unstable_patch_values",
    "stability_review",
    "narrow_mode_note",
]

SETUPS: tuple[str, ...] = ("free-air", "sealed", "vented", "shaker", "unknown")
#: nats by which a patch's Δ log Z must exceed the best physical candidate's for the same band. A
#: patch adds 2-3 parameters with broad priors whose Occam factor Laplace already charges; the margin
#: is prior odds of e^10 ≈ 2·10⁴ against a patch, the ``ln B > 10`` a real recording's structured
#: residual clears for almost any flexible term but that a patch clears over the physics only when
#: the physics cannot explain the band (Kass & Raftery's ``2 ln B > 10`` "very strong" doubled)
PATCH_MARGIN = 10.0
#: the largest lag-1 autocorrelation :func:`residual_correlation` uses (ℓ ≤ 199)
MAX_RHO = 0.99
#: a patch's added parameter moving between rounds by more than this many standard errors is unstable
STABLE_SE = 3.0
#: nats within which two candidates of the same kind count as tied (Kass & Raftery: "not worth more
#: than a bare mention"); the simpler one (fewer added parameters) is kept
NEAR_TIE = 1.0
#: a finding acting over more than this many decades is broadband
BROADBAND_DECADES = 2.0
#: a step needs this chi-square (2 dof: real and imaginary) of the local step estimate (p = 1e-4)
STEP_CHI2 = float(stats.chi2.ppf(1 - 1e-4, 2))
_STEP_HALF = 6  # points either side of a step in its local test
#: the local step fit's residual beyond the point noise at this tail probability (χ², its dof) means
#: the local curve is not a quadratic plus a step: the step is then judged against that residual
LACK_OF_FIT_P = 1e-3


def check_setup(setup: str) -> str:
    if setup not in SETUPS:
        raise ValueError(f"setup {setup!r}: choose one of {', '.join(SETUPS)}")
    return setup


def two_impedance_maxima(meas: Measurement) -> tuple[bool, str]:
    """Whether |Z| shows two maxima with a minimum between them (module docstring), and the words."""
    logz = np.log(np.abs(meas.Z))
    k = 5
    if logz.size < 3 * k:
        return False, "too few points for two impedance maxima"
    pad = np.pad(logz, k // 2, mode="edge")
    sm = np.median(np.lib.stride_tricks.sliding_window_view(pad, k), axis=-1)
    pk, prop = signal.find_peaks(sm, prominence=0.1)
    f = meas.f_hz
    pk = [int(i) for i in pk if 0 < i < sm.size - 1]
    for a in range(len(pk)):
        for b in range(a + 1, len(pk)):
            i, j = pk[a], pk[b]
            if f[j] / f[i] > 10.0:
                continue
            dip = i + int(np.argmin(sm[i : j + 1]))
            if min(sm[i], sm[j]) - sm[dip] >= 0.1:
                return True, (f"|Z| has maxima at {f[i]:.4g} and {f[j]:.4g} Hz with a minimum at "
                              f"{f[dip]:.4g} Hz between them")
    return False, "|Z| has no two maxima with a minimum between them (no vented-box signature)"


_SIGNATURES = {"two_impedance_maxima": two_impedance_maxima}


def setup_excludes(physics: str, setup: str, meas: Measurement) -> str | None:
    """Why ``physics`` is not tried in ``setup`` on ``meas`` (module docstring); ``None``: it is."""
    cls = TERMS.get(physics)
    if cls is None:
        return None
    if cls.requires_setup and setup not in cls.requires_setup:
        need = " or ".join(s for s in cls.requires_setup if s != "unknown")
        return f"{physics} needs a {need} setup, not {setup}"
    if setup == "unknown" and cls.unknown_setup_needs:
        ok, why = _SIGNATURES[cls.unknown_setup_needs](meas)
        if not ok:
            return f"{physics} not tried with the setup unknown: {why}"
    return None


def _terms(physics: str, fit: FitResult):
    ids = physics.split("+")
    return [t for t in fit.model.augmentations if t.id in ids]


def is_patch(physics: str, fit: FitResult) -> bool:
    """A generic patch (module docstring): a ``generic`` term not made physical by a narrow fitted
    width, or an NL rung above the eddy-current escalation's first."""
    if EDDY_PHYSICS in physics.split("+"):
        rings = getattr(fit.model, "rings", None)
        if rings is not None and rings > RING_COUNTS[0]:
            return True
        if physics == EDDY_PHYSICS:
            return False
    values = fit.model.as_dict(fit.theta)
    for t in _terms(physics, fit):
        if not t.generic:
            continue
        if t.narrow_when:
            name, limit = t.narrow_when
            if name in values and values[name] < limit:
                continue
        return True
    return False


def step_evidence(meas: Measurement, current: FitResult, fit: FitResult, physics: str) -> str | None:
    """For a term that puts a step between two points (:attr:`~bayes_emt.models.term.Term.step_at`):
    ``None`` when the measured points are discontinuous there, else why not (:func:`local_step`)."""
    values = fit.model.as_dict(fit.theta)
    for t in _terms(physics, fit):
        if not t.step_at:
            continue
        fitted = [p for p in t.params.names if p != t.step_at]
        # the fitted step in ln Y: ln(1 + δ) + jψ for a gain-and-phase step (first two other params)
        target = complex(math.log1p(values[fitted[0]]), values[fitted[1]]) if len(fitted) >= 2 else None
        problem = local_step(meas, current, values[t.step_at], target, physics)
        if problem:
            return problem
    return None


def local_step_fit(meas: Measurement, current: FitResult, ws: float) -> tuple[complex, float] | None:
    """The local step estimate at ``ws`` [rad/s] in ``ln Y`` and its χ² (2 dof) against the point
    noise, or against the local fit's own scatter when the local fit leaves more than the noise (then
    the χ² of the same tail probability as its ``2 F(2, dof)``) (:func:`local_step`); ``None`` within
    ``_STEP_HALF`` points of the data's end."""
    k = int(np.searchsorted(meas.omega, ws))  # first point above the step
    h = _STEP_HALF
    if k < h or k > meas.n_points - h:
        return None
    sl = slice(k - h, k + h)
    with np.errstate(all="ignore"):
        Yc = current.model.bind(meas.omega).admittance(meas.omega, current.theta)
    lr = np.log(meas.Y[sl] / Yc[sl])
    x = np.log(meas.omega[sl] / ws)
    A = np.stack([np.ones_like(x), x, x * x, (np.arange(2 * h) >= h).astype(float)], axis=1)
    B = np.stack([lr.real, lr.imag], axis=1)
    coef, *_ = np.linalg.lstsq(A, B, rcond=None)
    step = complex(coef[3, 0], coef[3, 1])
    # point noise: second differences of the residual over the whole record
    with np.errstate(all="ignore"):
        rel = relative_residual(current.model, current.theta, meas)
    d2 = np.diff(np.stack([rel.real, rel.imag]), n=2, axis=-1)
    sig2 = float(1.4826 * np.median(np.abs(d2 - np.median(d2, axis=-1, keepdims=True))) / math.sqrt(6)) ** 2
    # ... or the local fit's own scatter when the local fit does not describe the points (its residual
    # beyond the point noise at p = LACK_OF_FIT_P): a smooth misfit the quadratic cannot follow (a
    # real curve's curvature over a sparse grid) leaves structured residual that a step fits in part;
    # against the global point noise alone any point of such a curve passed (dayton_LS10-44.zma from
    # NL(5): a "step" of chi2 3090 at 588.9 rad/s and 6796 at 3000 rad/s, where nothing jumps)
    dof = 2 * (A.shape[0] - A.shape[1])
    scatter = float(np.sum((B - A @ coef) ** 2)) / max(dof, 1)
    lack = scatter * dof / max(sig2, 1e-300) > stats.chi2.ppf(1 - LACK_OF_FIT_P, dof)
    var = float(np.linalg.pinv(A.T @ A)[3, 3]) * (scatter if lack else sig2)
    stat = abs(step) ** 2 / max(var, 1e-300)
    if lack:  # the variance estimated from dof values: 2 F(2, dof), as the chi2 of equal tail
        stat = float(stats.chi2.isf(stats.f.sf(stat / 2, 2, dof), 2))
    return step, stat


def local_step(meas: Measurement, current: FitResult, ws: float, target: complex | None,
               physics: str) -> str | None:
    """``None`` when the measured points are discontinuous at ``ws`` [rad/s], else why not. In
    ``ln(Y/Y_current)`` (the current fit removes the resonance's shape) over ``_STEP_HALF`` points
    either side, a quadratic in ln ω plus a step is fitted to each part; the step must have
    ``χ²₂ ≥`` :data:`STEP_CHI2` against the point noise (σ from second differences) and at least half
    the size of ``target`` (the step in ln Y the term proposes; ``None``: the local estimate) along
    its direction."""
    est = local_step_fit(meas, current, ws)
    if est is None:
        return (f"{physics}: its step at {ws / (2 * math.pi):.4g} Hz lies within {_STEP_HALF} points of "
                "the data's end")
    step, chi2 = est
    target = step if target is None else target
    along = (step * target.conjugate()).real / max(abs(target), 1e-300)
    if chi2 < STEP_CHI2 or along < 0.5 * abs(target):
        return (f"{physics}: no discontinuity between the measured points at "
                f"{ws / (2 * math.pi):.4g} Hz (local step {100 * abs(step):.2g} % vs the fitted "
                f"{100 * abs(target):.2g} %, chi2 {chi2:.3g} < {STEP_CHI2:.3g} needed): a smooth "
                "misfit, not an instrument step")
    return None


def change_band(meas: Measurement, before: FitResult, after: FitResult, sigma_rel: float) -> dict:
    """Where adding a term changes the fit beyond the noise (module docstring): ``{"i_lo", "i_hi",
    "lo", "hi"}`` [index, rad/s], ``broadband``, ``decades`` and ``shape`` (words)."""
    with np.errstate(all="ignore"):
        rb = relative_residual(before.model, before.theta, meas)
        ra = relative_residual(after.model, after.theta, meas)
    gain = (np.abs(rb) ** 2 - np.abs(ra) ** 2) / max(sigma_rel, 1e-12) ** 2
    gain = np.where(np.isfinite(gain), gain, 0.0)
    L = min(8, gain.size)
    sm = np.convolve(gain, np.ones(L) / L, mode="same")
    pos = np.clip(sm, 0, None)
    n = meas.n_points
    if pos.sum() <= 0:
        i_lo, i_hi = 0, n - 1
    else:
        c = np.cumsum(pos) / pos.sum()
        i_lo = int(np.searchsorted(c, 0.05))
        i_hi = int(min(np.searchsorted(c, 0.95), n - 1))
    lo, hi = float(meas.omega[i_lo]), float(meas.omega[i_hi])
    dec = math.log10(hi / lo) if hi > lo else 0.0
    ipk = int(np.argmax(sm))
    shape = ""
    broadband = dec > BROADBAND_DECADES
    if broadband:
        # how the improvement spreads: its share per decade, low vs high half of the band
        mid = math.sqrt(lo * hi)
        low = float(pos[(meas.omega >= lo) & (meas.omega < mid)].sum())
        high = float(pos[(meas.omega >= mid) & (meas.omega <= hi)].sum())
        trend = ("grows with frequency" if high > 2 * low else "falls with frequency" if low > 2 * high
                 else "spread evenly")
        shape = (f"broadband: the fit changes beyond the noise over {dec:.1f} decades "
                 f"({lo / (2 * math.pi):.4g}-{hi / (2 * math.pi):.4g} Hz), most at "
                 f"{meas.f_hz[ipk]:.4g} Hz; the improvement {trend}")
    return {"i_lo": i_lo, "i_hi": i_hi, "lo": lo, "hi": hi, "decades": dec, "broadband": broadband,
            "shape": shape, "peak_hz": float(meas.f_hz[ipk])}


def residual_correlation(meas: Measurement, fit: FitResult, i_lo: int = 0, i_hi: int | None = None) -> float:
    """``ℓ = (1 + ρ₁)/(1 − ρ₁)`` (module docstring), ``ρ₁`` the lag-1 autocorrelation of ``fit``'s
    relative residual over the points ``i_lo..i_hi`` (real and imaginary parts pooled, each part's
    mean removed), clipped to ``[0, MAX_RHO]``; 1 with fewer than 8 points."""
    i_hi = meas.n_points - 1 if i_hi is None else i_hi
    if i_hi - i_lo + 1 < 8:
        return 1.0
    with np.errstate(all="ignore"):
        r = relative_residual(fit.model, fit.theta, meas)[i_lo : i_hi + 1]
    num = den = 0.0
    for x in (r.real, r.imag):
        x = x[np.isfinite(x)]
        if x.size < 8:
            continue
        x = x - x.mean()
        num += float(x[1:] @ x[:-1])
        den += float(x @ x)
    rho = min(max(num / den, 0.0), MAX_RHO) if den > 0 else 0.0
    return (1.0 + rho) / (1.0 - rho)


def patch_margin(patch, phys, meas: Measurement | None = None) -> tuple[float, str]:
    """The nats by which candidate ``patch`` must beat the physical candidate ``phys`` (module
    docstring: ``ℓ · max(PATCH_MARGIN, ½ Δk ln N)``) and how it was made up. Without ``meas``
    ℓ = 1 (``N`` from the patch's fit)."""
    n_values = 2 * int(patch.fit.n_points)
    dk = max(patch.n_added - phys.n_added, 0)
    base = max(PATCH_MARGIN, 0.5 * dk * math.log(max(n_values, 2)))
    ell = 1.0
    if meas is not None:
        where = change_band(meas, phys.fit, patch.fit, 1.0)
        ell = residual_correlation(meas, patch.fit, where["i_lo"], where["i_hi"])
    words = f"{ell * base:.1f} nats = l {ell:.3g} x max({PATCH_MARGIN:g}, 1/2 x {dk} x ln {n_values})"
    return ell * base, words


def choose(ranked, meas: Measurement | None = None) -> tuple[object | None, list[str]]:
    """The candidate a band gets (module docstring) and the notes saying what was weighed: among the
    accepted, the best physical one (a joint pair only when it beats the best single by
    :data:`PATCH_MARGIN`; within :data:`NEAR_TIE` the one adding fewer parameters), unless a patch
    beats it by the patch margin (:func:`patch_margin`; ``meas`` gives its residual correlation) or
    leads a physical one whose parameters the data do not determine (an undetermined physical term
    is no better an explanation); a patch alone when no physical candidate is accepted."""
    acc = [c for c in ranked if c.accepted]
    if not acc:
        return None, []
    notes: list[str] = []
    phys = [c for c in acc if not c.patch]
    pick = None
    if phys:
        pick = max(phys, key=lambda c: c.delta_log_z)
        singles = [c for c in phys if "+" not in c.physics]
        if "+" in pick.physics and singles:
            best_single = max(singles, key=lambda c: c.delta_log_z)
            if pick.delta_log_z - best_single.delta_log_z < PATCH_MARGIN:
                notes.append(
                    f"{pick.physics} jointly gains {pick.delta_log_z - best_single.delta_log_z:.1f} nats "
                    "over "
                    f"{best_single.physics} alone (< {PATCH_MARGIN:g}): the simpler one is kept")
                pick = best_single
        ties = [c for c in phys if c is not pick and c.physics != pick.physics
                and pick.delta_log_z - c.delta_log_z < NEAR_TIE]
        if ties:
            simplest = min([pick, *ties], key=lambda c: (c.n_added, -c.delta_log_z))
            notes.append(
                "the data cannot tell " + ", ".join(c.physics for c in [pick, *ties])
                + f" apart (within {NEAR_TIE:g} nat of log Z); the simplest, {simplest.physics}, is kept")
            pick = simplest
    patches = [c for c in acc if c.patch]
    if patches:
        bp = max(patches, key=lambda c: c.delta_log_z)
        if pick is None:
            notes.append(f"{bp.physics} is a generic patch named because no physical term explains the band")
            return bp, notes
        lead = bp.delta_log_z - pick.delta_log_z
        margin, how = patch_margin(bp, pick, meas) if lead > 0 else (PATCH_MARGIN, "")
        if lead > 0 and not pick.identifiable:
            notes.append(f"the patch {bp.physics} fits {lead:.1f} nats better than {pick.physics}, whose "
                         "parameters the data do not determine, while its own are determined: it is named")
            return bp, notes
        if lead >= margin:
            notes.append(f"the patch {bp.physics} beats the best physical term {pick.physics} by "
                         f"{lead:.1f} nats (>= the margin {how})")
            return bp, notes
        if lead > 0:
            notes.append(
                f"the patch {bp.physics} fits {lead:.1f} nats better than {pick.physics}, within the "
                f"margin a patch needs ({how}): the data cannot tell them apart, the physical "
                f"{pick.physics} is kept")
    return pick, notes


def unstable_patch_values(findings, fit: FitResult, se: float = STABLE_SE) -> dict:
    """``{physics: [words, ...]}`` of the patch findings (their explanation says "a generic patch")
    whose added parameters, as named, differ in ``fit`` (a later round's) by more than ``se`` of the
    standard errors they were named with (a parameter named without one is not judged). The later
    fit's own standard error does not excuse the move: a patch value the later fit no longer
    determines is the same symptom."""
    now = fit.model.as_dict(fit.theta)
    out: dict = {}
    for f in findings:
        if "a generic patch" not in f.explanation:
            continue
        for name, rec in (f.parameters.get("added") or {}).items():
            if name not in now or rec.get("stderr") is None:
                continue
            v0, s = float(rec["value"]), float(rec["stderr"])
            v1 = float(now[name])
            if s > 0 and abs(v1 - v0) > se * s:
                unit = "" if rec.get("unit") in (None, "1") else " " + rec["unit"]
                out.setdefault(f.physics, []).append(
                    f"{name} {v0:.4g} -> {v1:.4g}{unit} ({abs(v1 - v0) / s:.0f} standard errors)")
    return out


def stability_review(meas: Measurement, findings, fit: FitResult, log_z: float, refit, evidence):
    """After the last round: every patch finding whose values moved since it was named
    (:func:`unstable_patch_values`) is flagged; the final model without it is refitted
    (``refit(model, start_values) -> FitResult``, ``evidence(fit) -> log Z``) and the patch is
    dropped when the model loses less than :data:`PATCH_MARGIN` times the residual correlation ℓ of
    the final fit (the patch margin without the parameter charge: a patch whose values the rounds
    do not agree on must still be needed by the final model). An NL ring count has no term to drop:
    it is flagged only. Returns ``(findings, fit, log_z, warnings)``."""
    moved = unstable_patch_values(findings, fit)
    warn: list[str] = []
    findings = list(findings)
    for physics, what in moved.items():
        words = (f"{physics}: its values changed between rounds beyond {STABLE_SE:g} standard errors ("
                 + "; ".join(what) + "): the patch absorbed what a later term explains")
        ids = physics.split("+")
        m_without = fit.model
        for t in fit.model.augmentations:
            if t.id in ids and t.generic:
                m_without = m_without.without(t)
        if m_without is fit.model:
            warn.append(words + " (flagged; kept)")
            continue
        values = fit.model.as_dict(fit.theta)
        try:
            f0 = refit(m_without, {k: v for k, v in values.items() if k in m_without.names})
            lz0 = evidence(f0)
        except Exception as exc:  # noqa: BLE001 - a failed refit keeps the patch, flagged
            warn.append(words + f" (flagged, kept: the fit without it failed: {exc})")
            continue
        if not (math.isfinite(log_z) and math.isfinite(lz0)):
            warn.append(words + " (flagged, kept: the evidence with or without it could not be computed)")
            continue
        loss = log_z - lz0
        need = PATCH_MARGIN * residual_correlation(meas, fit)
        if loss < need:
            warn.append(words + f"; without it the final model loses {loss:.1f} nats (< {need:.1f}, the "
                        "patch margin): refused, dropped from the final model")
            findings = [f for f in findings if f.physics != physics]
            fit, log_z = f0, lz0
        else:
            warn.append(words + f"; the final model still needs it ({loss:.1f} nats >= {need:.1f}): kept, "
                        "flagged")
    return tuple(findings), fit, log_z, warn


def narrow_mode_note(physics: str, fit: FitResult) -> str:
    """For a finding of a mode term fitted narrow (``narrow_when``): "narrow resonance at f Hz, Q ≈ q"
    with the band ``f (1 ± 1.5/Q)`` to exclude when a lumped fit is wanted (below the driver's
    resonance ``ω0``, where no cone break-up or surround mode rings, a mounting, fixture or room
    resonance is named beside the driver's own); ``""`` otherwise."""
    values = fit.model.as_dict(fit.theta)
    for t in _terms(physics, fit):
        if not t.narrow_when:
            continue
        name, limit = t.narrow_when
        freq = next((p for p in t.params.names if p.startswith("omega")), None)
        if name not in values or freq is None or not values[name] < limit:
            continue
        f, q = values[freq] / (2 * math.pi), 1.0 / (2.0 * values[name])
        half = max(1.5 / q, 0.01)
        band = f"--exclude-band {f * (1 - half):.4g}:{f * (1 + half):.4g}"
        w0 = values.get("omega0")
        if w0 and values[freq] < w0:
            # below the driver's own resonance no cone or surround mode of the driver rings
            return (f"a narrow resonance at {f:.4g} Hz, Q ≈ {q:.3g}, below the driver's resonance "
                    f"({w0 / (2 * math.pi):.4g} Hz): not a cone break-up; a mounting, fixture or room "
                    "resonance is as likely as the driver's own, and a second recording (--also, e.g. "
                    "with a mass added) tells them apart; to fit the driver alone, exclude the band "
                    f"({band})")
        return (f"a narrow resonance at {f:.4g} Hz, Q ≈ {q:.3g}: if it is a cone break-up or a surround "
                "mode (an unmodelled narrow resonance of the lumped driver), exclude the band "
                f"({band}) rather than model it")
    return ""
