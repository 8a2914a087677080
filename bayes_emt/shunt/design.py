"""H∞-optimal series RC shunt: ``Zs = Rs + 1/(Cs s)`` minimising ``‖G_RC‖∞`` of (50).

**Closed form (start).** Model I with ζ = 0 and net loop resistance ``R = R0 + Rs``:
``|m·G(jω)|² = (A² + R²ω²) / (B² + R²ω²(ω0² − ω²)²)`` with ``A = 1/Cs − L ω²``,
``B = (ω0² − ω²) A − φ̄² ω²``. Two frequencies are independent of R (Den Hartog's fixed points),
the roots in ``x = ω²`` of ``2(ω0² − x)(1/Cs − L x) = φ̄² x``, where ``|m·G| = 1/|ω0² − x|``. Equal
heights (``x_P + x_Q = 2ω0²``) give ``Cs = 2/(2 L ω0² − φ̄²)`` (Den Hartog 1956). A horizontal tangent at a
fixed point needs ``R² = (φ̄²/(2D)) (φ̄² x/(2D) + 2 L D + φ̄²)`` with ``D = ω0² − x``; as Den Hartog,
``R² = (R_P² + R_Q²)/2``, so ``Rs = R − R0``. For the other models the coil is replaced by its
equivalent series inductance and resistance at ω0, ``L = Im Zc(jω0)/ω0`` (the low-frequency
inductance while the eddy-current corners lie above ω0) and ``Rc = Re Zc(jω0)``: ``Rs = R − R0 − Rc``.

**Optimum.** (1) Nelder–Mead in ``(Rs, log Cs)`` on the log of the grid peak (parabolic
interpolation), any point at or below the stability threshold in Rs scoring +inf, from the closed
form. (2) The min-max problem is non-smooth where two peaks are equal, so Nelder–Mead stalls
slightly off the optimum there; it is polished as a smooth problem: with ``h_lo, h_hi`` the
heights of the peaks below/above the anti-resonance between them, ``log Cs*(Rs)`` solves
``h_lo = h_hi`` (Brent root) and ``h_lo(Rs, Cs*(Rs))`` is minimised over Rs (bounded Brent): the
equal-peak optimum to ~1e-9 in the peak ratio. A single-peak optimum (smooth) is polished by
Nelder–Mead on the refined peak. (3) The result is evaluated on the exact model.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import ClassVar

import numpy as np
from scipy import optimize

from .._json import strict_json
from .._record import register_kind
from ..errors import DataFormatError
from ..models import Model
from .minimax import minimax_polish
from .receptance import Plant, rc_impedance
from .records import design_summary, html_table, read_json_record
from .safety import check_margin
from .stability import StabilityReport, assess_stability, instability_threshold, threshold_grid

__all__ = ["ShuntDesign", "ShuntEvaluation", "ShuntWarning", "closed_form_rc", "design_rc_shunt",
           "evaluate_rc_shunt", "rc_optimum", "read_shunt_design", "design_from_json_dict"]


class ShuntWarning(UserWarning):
    """A shunt design is computed but means little (e.g. the plant has no resonance to damp)."""


@dataclass(frozen=True)
class ShuntEvaluation:
    """An RC shunt ``(Rs [Ω], Cs [F])`` evaluated on one model and parameter vector.

    Attributes
    ----------
    model : model label.
    Rs, Cs : the shunt [Ω], [F].
    attenuation_db : ``20 log10(‖G_RC‖∞/‖G_open‖∞)`` [dB]; +inf when the loop is unstable (the H∞
        norm of an unstable system is infinite).
    peak, peak_omega : ``‖m·G_RC‖∞`` on the imaginary axis [s²] (mass-normalised) and where [rad/s].
    peak_open, peak_open_omega : the same with open terminals.
    stable : all closed-loop poles in the open left half-plane (``stability_method`` says how).
    Rs_instability : the Rs [Ω] below which this Cs gives an unstable loop (exact crossing condition).
    stability_margin : ``Rs − Rs_instability`` [Ω]: how far Rs (or, equally, R0) may drift down.
    max_pole_real : rightmost closed-loop pole's real part [1/s] (None for models without a Foster form).
    min_damping_ratio : smallest ``−Re p/|p|`` over the closed-loop poles (None likewise).
    stability_method : how ``stable`` was decided.
    """

    model: str
    Rs: float
    Cs: float
    attenuation_db: float
    peak: float
    peak_omega: float
    peak_open: float
    peak_open_omega: float
    stable: bool
    Rs_instability: float
    stability_margin: float
    max_pole_real: float | None
    min_damping_ratio: float | None
    stability_method: str

    @property
    def stability_margin_ohm(self) -> float:
        """``Rs − Rs_instability`` [Ω] (the same as ``stability_margin``, named with its unit)."""
        return self.stability_margin

    def to_json_dict(self) -> dict:
        """Plain JSON types; non-finite numbers become null."""
        return strict_json({**asdict(self), "stability_margin_ohm": self.stability_margin_ohm})


@dataclass(frozen=True)
class ShuntDesign(ShuntEvaluation):
    """The H∞-optimal RC shunt for one model (all :class:`ShuntEvaluation` fields, plus):

    Attributes
    ----------
    closed_form : the fixed-point start ``{"Rs", "Cs", "attenuation_db", "L_eq", "R_eq"}``
        ([Ω], [F], [dB], equivalent coil inductance [H] and resistance [Ω] at ω0).
    peaks : the local maxima of ``|m·G_RC|`` at the optimum, ``[(omega [rad/s], value [s²]), ...]``.
    optimum : ``"equal peaks"`` or ``"single peak"``.
    info : optimiser record (evaluations, method, whether the polish succeeded).
    r0_uncertainty_ohm : the largest R0 half-width [Ω] the margin was compared with (``None``: none
        given); ``r0_uncertainty`` per source (:mod:`bayes_emt.shunt.safety`).
    warnings : ``({"code", "message"}, ...)``, e.g. ``stability_margin_below_uncertainty``.
    notes : plain notes (parts that need a synthetic impedance; no R0 uncertainty given).
    """

    closed_form: dict = field(default_factory=dict)
    peaks: tuple = ()
    optimum: str = ""
    info: dict = field(default_factory=dict)
    r0_uncertainty_ohm: float | None = None
    r0_uncertainty: dict = field(default_factory=dict)
    warnings: tuple = ()
    notes: tuple = ()

    kind: ClassVar[str] = "shunt_design"

    @property
    def R0(self) -> float:
        """The R0 [Ω] the design assumed."""
        return float(self.info.get("R0", math.nan))

    def to_json_dict(self) -> dict:
        """:meth:`ShuntEvaluation.to_json_dict` with ``"kind": "shunt_design"`` (``be.load`` reads it)."""
        return {"kind": self.kind, **super().to_json_dict()}

    @classmethod
    def from_json_dict(cls, rec: dict) -> ShuntDesign:
        return design_from_json_dict(rec)

    def __repr__(self) -> str:
        return (f"ShuntDesign({self.model}: Rs={self.Rs:.5g} ohm, Cs={self.Cs:.4g} F, "
                f"{self.attenuation_db:.2f} dB, margin {self.stability_margin_ohm:.3g} ohm"
                + (f", {len(self.warnings)} warning(s)" if self.warnings else "") + ")")

    def summary(self) -> str:
        """A plain-text table with units, then the warnings and notes."""
        return design_summary(self)

    def _repr_html_(self) -> str:
        return html_table(self.summary())

    def to_json(self) -> str:
        """Strict JSON (no NaN) of :meth:`to_json_dict`."""
        return json.dumps(self.to_json_dict(), indent=2, allow_nan=False)

    def save(self, path) -> None:
        """Write :meth:`to_json` atomically (read back with :func:`read_shunt_design`)."""
        from .._atomic import atomic_write_text

        atomic_write_text(path, self.to_json() + "\n")


def closed_form_rc(model: Model, theta) -> dict:
    """Fixed-point (Den Hartog-type) RC shunt (module docstring): ``{"Rs" [Ω], "Cs" [F], "L_eq" [H],
    "R_eq" [Ω]}``. Exact fixed-point design for model I with ζ = 0; a start otherwise."""
    theta = np.asarray(theta, float)
    _, omega0, phi = (float(v) for v in model.mechanics(theta))
    R0 = float(theta[model.params.index("R0")])
    zc = complex(model.electrical_impedance_s(np.array([1j * omega0]), theta)[0]) - R0
    L, Rc = zc.imag / omega0, zc.real
    den = 2 * L * omega0**2 - phi**2
    if not den > 0:
        raise ValueError(f"model {model.label}: the fixed-point closed form needs 2 L ω0² > φ̄² "
                         f"(L = {L:.4g} H, ω0 = {omega0:.4g} rad/s, φ̄ = {phi:.4g})")
    Cs = 2.0 / den
    root = math.sqrt(omega0**4 - omega0**2 / (Cs * L))
    r2 = []
    for x in (omega0**2 - root, omega0**2 + root):
        D = omega0**2 - x
        r2.append(phi**2 / (2 * D) * (phi**2 * x / (2 * D) + 2 * L * D + phi**2))
    R = math.sqrt(abs(0.5 * (r2[0] + r2[1])))
    return {"Rs": R - R0 - Rc, "Cs": Cs, "L_eq": L, "R_eq": Rc}


def evaluate_rc_shunt(model: Model, theta, Rs: float, Cs: float, *, plant: Plant | None = None,
                      grid=None, bandwidth: float | None = None) -> ShuntEvaluation:
    """Attenuation and stability of the RC shunt ``(Rs [Ω], Cs [F])`` on ``model`` at ``theta``
    (cross-model evaluation: a design from one model evaluated on another)."""
    theta = np.asarray(theta, float)
    plant = plant or Plant(model, theta)
    pk = plant.peak(lambda s: rc_impedance(s, Rs, Cs))
    op = plant.open_peak()
    rs_crit = float(instability_threshold(model, theta, Cs, grid=grid, bandwidth=bandwidth))
    if bandwidth is None:
        st = assess_stability(model, theta, Rs, Cs)
    else:
        st = StabilityReport(bool(Rs > rs_crit), int(Rs <= rs_crit), None, None,
                             f"no loop-reactance crossing below {bandwidth:.4g} rad/s (the ideal loop above "
                             "the shunt's bandwidth is not analysed)")
    att = 20 * math.log10(pk.value / op.value) if st.stable else math.inf
    return ShuntEvaluation(model.label, float(Rs), float(Cs), att, pk.value, pk.omega, op.value, op.omega,
                           st.stable, rs_crit, float(Rs - rs_crit), st.max_pole_real, st.min_damping_ratio,
                           st.method)


def _equal_peak_polish(plant: Plant, rs0: float, lcs0: float, split: float, width: float):
    """Minimise the common height of two balanced peaks (module docstring). Returns (Rs, log Cs, n)."""
    count = [0]
    cache = {"lcs": lcs0}

    def balance(lcs, rs):
        count[0] += 1
        lo, hi = plant.band_peaks(rs, math.exp(lcs), split)
        return math.log(lo.value) - math.log(hi.value)

    def cs_star(rs):
        c = cache["lcs"]
        step = 0.01
        f0 = balance(c, rs)
        for _ in range(12):
            c1 = c + (step if f0 > 0 else -step)  # larger Cs lowers the electrical tuning
            f1 = balance(c1, rs)
            if np.sign(f1) != np.sign(f0):
                a, b = sorted((c, c1))
                root = optimize.brentq(balance, a, b, args=(rs,), xtol=1e-14, rtol=1e-15)
                cache["lcs"] = root
                return root
            c, f0, step = c1, f1, 2 * step
        raise ArithmeticError("no balanced-peak capacitance found")

    def height(rs):
        lcs = cs_star(rs)
        lo, hi = plant.band_peaks(rs, math.exp(lcs), split)
        return math.log(max(lo.value, hi.value))

    a, b = rs0 - width, rs0 + width
    for _ in range(4):
        r = optimize.minimize_scalar(height, bounds=(a, b), method="bounded", options={"xatol": 1e-11})
        if min(r.x - a, b - r.x) > 1e-3 * width:
            break
        a, b = r.x - width, r.x + width  # optimum at an edge: recentre
    return float(r.x), cs_star(float(r.x)), count[0]


def _fallback_start(plant: Plant, model: Model, theta, L: float, grid, bandwidth) -> tuple[float, float]:
    """Start when the closed form does not exist (φ̄² ≥ 2 L ω0²): the coil tuned to ω0 by Cs,
    ``Cs = 1/(L ω0²)``, and the best Rs for it (bounded 1-D search above the stability threshold)."""
    cs = 1.0 / (L * plant.omega0**2)
    lo = float(instability_threshold(model, theta, cs, grid=grid, refine=False, bandwidth=bandwidth))
    if not math.isfinite(lo):
        lo = -plant.R0 - 1.0
    hi = lo + 2.0 * plant.R0 + 1.0
    r = optimize.minimize_scalar(lambda rs: math.log(plant.rc_peak_fast(rs, cs)),
                                 bounds=(lo + 1e-9 * (1 + abs(lo)), hi), method="bounded")
    return float(r.x), cs


def _polish(plant: Plant, model: Model, theta, grid, rs, lcs, rnet, lcs_max, info, bandwidth):
    """Polish a Nelder–Mead point: equal-peak solve where two peaks compete, else a smooth search."""
    def admissible(rs, lcs):
        return lcs <= lcs_max and rs > instability_threshold(model, theta, math.exp(lcs), grid=grid,
                                                              bandwidth=bandwidth,
                                                              refine=False)

    def smooth(x):
        if not admissible(x[0], x[1]):
            return np.inf
        return math.log(plant.peak(lambda s: rc_impedance(s, x[0], math.exp(x[1])), exact=False).value)

    info["nfev_polish"] = 0
    for _ in range(2):
        zs = lambda s, rs=rs, lcs=lcs: rc_impedance(s, rs, math.exp(lcs))  # noqa: E731
        top = sorted(sorted(plant.local_peaks(zs, exact=False), key=lambda p: -p.value)[:2],
                     key=lambda p: p.omega)
        if len(top) == 2 and min(top[0].value, top[1].value) > 0.9 * max(top[0].value, top[1].value):
            inside = (plant.omega > top[0].omega) & (plant.omega < top[1].omega)
            g = plant.grid_magnitude(zs)
            split = float(plant.omega[inside][np.argmin(g[inside])]) if inside.any() else plant.omega0
            try:
                rs_p, lcs_p, n = _equal_peak_polish(plant, rs, lcs, split, width=0.02 * rnet + 1e-6)
                info["nfev_polish"] += n
                if admissible(rs_p, lcs_p):
                    return rs_p, lcs_p
                info["polish"] = "equal-peak optimum inadmissible (unstable or Cs above its bound)"
            except (ArithmeticError, ValueError) as exc:
                info["polish"] = f"equal-peak polish failed ({exc})"
        with np.errstate(invalid="ignore"):  # inadmissible vertices score inf (inf - inf in the test)
            r2 = optimize.minimize(smooth, [rs, lcs], method="Nelder-Mead",
                                   options={"xatol": 1e-10, "fatol": 1e-14, "maxfev": 2000})
        info["nfev_polish"] += int(r2.nfev)
        if r2.fun <= smooth([rs, lcs]):
            rs, lcs = float(r2.x[0]), float(r2.x[1])
    return rs, lcs


#: relative step [of max(|threshold|, R0)] by which a design the search left on the unstable side of
#: the exact threshold is moved onto the stable side (doubled until the loop is stable)
BACKOFF = 1e-6
#: a design closer than this (relative, as BACKOFF) to the exact threshold is reported "at the stability
#: boundary"
BACKOFF_NEAR = 1e-4


def _stable_side(model, theta, rs, Cs, ev, plant, grid, bandwidth, info):
    """``(Rs, evaluation)``: ``ev`` when stable; otherwise Rs moved just above the exact threshold.

    The search constrains Rs by the threshold on its frequency grid (:func:`instability_threshold`
    without refinement, for speed); the evaluation refines it. Where the optimum lies close to the
    boundary the search can end between the two: on the SEAS E0018 UD+suspension_creep fit 2.5e-8 ohm
    past the exact threshold, an unstable design. Rs is then moved just above the exact threshold
    (:func:`design_rc_shunt` polishes again from there and keeps the better stable design; the margin
    check compares the margin with the R0 uncertainty), and ``info["stability_backoff"]`` says so."""
    if ev.stable or not math.isfinite(ev.Rs_instability):
        return rs, ev
    step = BACKOFF * max(abs(ev.Rs_instability), plant.R0)
    for _ in range(20):
        rs_b = ev.Rs_instability + step
        ev_b = evaluate_rc_shunt(model, theta, rs_b, Cs, plant=plant, grid=grid, bandwidth=bandwidth)
        if ev_b.stable:
            info["stability_backoff"] = (f"the search ended {ev.Rs_instability - rs:.3g} ohm past the exact "
                                         f"instability threshold; Rs moved to {step:.3g} ohm above it")
            return rs_b, ev_b
        step *= 2.0
    info["stability_backoff"] = ("the search ended past the exact instability threshold; no stable Rs "
                                 "found near it")
    return rs, ev


def _capacitive_threshold(model: Model, theta, grid) -> str | None:
    """The warning to give when the ideal loop's threshold is Rs = 0 from a capacitive terminal
    impedance at high frequency (a pole arriving from infinity), else ``None``."""
    z = model.impedance_s(1j * grid[0][-2:], theta)
    if abs(z[-1]) < abs(z[-2]) and float(instability_threshold(model, theta, 1.0, grid=grid)) >= 0.0:
        return (f"model {model.label}: the terminal impedance turns capacitive at high frequency, so in "
                "the ideal continuous-time loop any negative Rs is unstable (a real pole near 1/(|Rs| Cp) "
                "rad/s); give the realisation's bandwidth (bandwidth=..., shunt --bandwidth) or check the "
                "sampled-data realisation (shunt --implement)")
    return None


def design_rc_shunt(model: Model, theta, *, start: tuple[float, float] | None = None,
                    bandwidth: float | None = None, r0_uncertainty: dict | None = None) -> ShuntDesign:
    """The H∞-optimal RC shunt for ``model`` at ``theta`` (the source paper's eq. 50; module docstring).

    Cs is bounded above by ``Cs_max = 1e3/(L ω0²)`` (capacitive reactance at ω0 below 1e-3 of the
    coil's; the electrical resonance above ω0/32, inside the :class:`Plant` grid): a strongly
    coupled plant (``φ̄² ≥ 2 L ω0²``, no closed form) may be best damped by a pure negative
    resistance, and then the optimum sits at that bound (``optimum`` says so). A plant without a
    resonance (``ζ ≥ 1/√2``) gets a :class:`ShuntWarning`.

    Parameters
    ----------
    model : transducer model (any; the closed-form start uses its equivalent L and R at ω0).
    theta : physical parameter vector ``(k,)``.
    start : optional ``(Rs [Ω], Cs [F])`` start; default the fixed-point closed form.
    bandwidth : [rad/s] the shunt realisation's bandwidth for the stability constraint
        (:func:`~bayes_emt.shunt.stability.instability_threshold`); ``None``: the ideal loop. With a
        capacitance across the terminals the ideal loop is unstable for every negative Rs (a real pole
        near ``1/(|Rs| Cp)`` rad/s, far above any realisation's bandwidth): a :class:`ShuntWarning`
        says so and suggests giving the bandwidth.
    r0_uncertainty : optional R0 half-widths [Ω] by source
        (:func:`~bayes_emt.shunt.safety.r0_uncertainty`) the stability margin is compared with: a
        smaller margin gives the warning ``stability_margin_below_uncertainty``.

    Returns
    -------
    ShuntDesign
    """
    theta = np.asarray(theta, float)
    plant, grid, cf, rs, lcs, lcs_max, ev, info = _optimise(model, theta, start, bandwidth, warn=True)
    Cs = math.exp(lcs)
    final = plant.local_peaks(lambda s: rc_impedance(s, rs, Cs))
    hs = sorted((p.value for p in final), reverse=True)
    if ev.stability_margin < BACKOFF_NEAR * max(abs(ev.Rs_instability), plant.R0):
        optimum = "at the stability boundary"
    elif lcs > lcs_max - 1e-3:
        optimum = "Cs at its upper bound (a pure negative resistance does as well)"
    elif len(hs) > 1 and hs[1] > hs[0] * (1 - 1e-6):
        optimum = "equal peaks"
    else:
        optimum = "single peak"
    cf_att = math.nan
    if math.isfinite(cf["Cs"]):
        cf_att = evaluate_rc_shunt(model, theta, cf["Rs"], cf["Cs"], plant=plant, grid=grid,
                                   bandwidth=bandwidth).attenuation_db
    info["R0"] = plant.R0
    safety = check_margin(ev.Rs, ev.Cs, ev.Rs_instability, plant.R0, r0_uncertainty,
                          what=f"the {model.label} shunt")
    band = _below_band(plant, rs, Cs, final, ev)
    return ShuntDesign(**asdict(ev), closed_form={**cf, "attenuation_db": cf_att},
                       peaks=tuple((p.omega, p.value) for p in final), optimum=optimum, info=info,
                       r0_uncertainty_ohm=safety.r0_uncertainty_ohm, r0_uncertainty=safety.r0_uncertainty,
                       warnings=safety.warnings + band, notes=safety.notes)


def rc_optimum(model: Model, theta, *, start: tuple[float, float] | None = None,
               bandwidth: float | None = None) -> ShuntEvaluation:
    """The optimum of :func:`design_rc_shunt` (the same search, step for step: the same ``Rs``,
    ``Cs``, attenuation and stability margin) without the design's report: no closed form's
    evaluation, no peak list, no margin check against the R0 uncertainty, no look below the band.
    What the batched per-draw design (:func:`~bayes_emt.shunt.batch.design.design_draws`) hands a draw
    to when its Newton iteration cannot settle it."""
    theta = np.asarray(theta, float)
    return _optimise(model, theta, start, bandwidth, warn=False)[6]


def _optimise(model: Model, theta, start, bandwidth, *, warn: bool):
    """The search of :func:`design_rc_shunt`: ``(plant, grid, closed form, Rs, ln Cs, the bound on
    ln Cs, evaluation, info)``."""
    plant = Plant(model, theta)
    if warn and plant.zeta >= 1 / math.sqrt(2):
        warnings.warn(f"model {model.label}: ζ = {plant.zeta:.3g} ≥ 1/√2, the open-terminal receptance has "
                      "no resonant peak; there is nothing for a shunt to damp", ShuntWarning, stacklevel=3)
    grid = threshold_grid(model, theta)
    if warn and bandwidth is None and not model.plain_mechanics:
        cap = _capacitive_threshold(model, theta, grid)
        if cap is not None:
            warnings.warn(cap, ShuntWarning, stacklevel=3)
    zc = complex(plant.ze(np.array([plant.omega0]))[0]) - plant.R0
    L_eq = max(zc.imag / plant.omega0, 1e-300)
    lcs_max = math.log(1e3 / (L_eq * plant.omega0**2))
    try:
        cf = closed_form_rc(model, theta)
    except ValueError as exc:
        cf = {"Rs": math.nan, "Cs": math.nan, "L_eq": L_eq, "R_eq": zc.real, "note": str(exc)}
    if start is not None:
        rs0, cs0 = (float(v) for v in start)
    elif math.isfinite(cf["Cs"]):
        rs0, cs0 = cf["Rs"], cf["Cs"]
    else:
        rs0, cs0 = _fallback_start(plant, model, theta, L_eq, grid, bandwidth)
    nfev = [0]

    def objective(x):
        rs, lcs = x
        nfev[0] += 1
        if lcs > lcs_max or rs <= instability_threshold(model, theta, math.exp(lcs), grid=grid, refine=False,
                                                        bandwidth=bandwidth):
            return np.inf
        return math.log(plant.rc_peak_fast(rs, math.exp(lcs)))

    rnet = abs(plant.R0 + rs0 + zc.real) + 1e-3 * plant.R0
    x0 = np.array([rs0, min(math.log(cs0), lcs_max)])
    simplex = np.array([x0, x0 + [0.3 * rnet, 0.0], x0 + [0.0, -0.05]])
    with np.errstate(invalid="ignore"):  # inadmissible vertices score inf (inf - inf in the test)
        res = optimize.minimize(objective, x0, method="Nelder-Mead",
                                options={"initial_simplex": simplex, "xatol": 1e-7, "fatol": 1e-10,
                                         "maxiter": 2000, "maxfev": 4000})
    info = {"method": "Nelder-Mead (Rs, log Cs) on the grid peak, then polish", "nfev_nelder_mead": nfev[0],
            "start": {"Rs": rs0, "Cs": cs0}}
    rs, lcs = _polish(plant, model, theta, grid, float(res.x[0]), float(res.x[1]), rnet, lcs_max, info,
                      bandwidth)
    rs, lcs = minimax_polish(plant, model, theta, grid, rs, lcs, lcs_max, info, bandwidth)
    Cs = math.exp(lcs)
    ev = evaluate_rc_shunt(model, theta, rs, Cs, plant=plant, grid=grid, bandwidth=bandwidth)
    if not ev.stable:
        rs, ev = _stable_side(model, theta, rs, Cs, ev, plant, grid, bandwidth, info)
        if ev.stable:  # polish again from the stable side: an interior optimum may lie next to it
            rs2, lcs2 = _polish(plant, model, theta, grid, rs, lcs, rnet, lcs_max, {}, bandwidth)
            ev2 = evaluate_rc_shunt(model, theta, rs2, math.exp(lcs2), plant=plant, grid=grid,
                                    bandwidth=bandwidth)
            if ev2.stable and ev2.attenuation_db < ev.attenuation_db:
                rs, lcs, Cs, ev = rs2, lcs2, math.exp(lcs2), ev2
                info["stability_backoff"] += "; polished again from there"
    return plant, grid, cf, rs, lcs, lcs_max, ev, info


BELOW_BAND_CODE = "peak_below_design_band"


def _below_band(plant: Plant, rs: float, Cs: float, final, ev) -> tuple:
    """A warning when one of the design's peaks is the low end of the band it is optimised on
    (``ω0/40``, :class:`Plant`): the shunt's electrical resonance with the coil then lies below
    the band and the response there is higher than the attenuation says. It happens where the
    optimum puts Cs on its upper bound (a loudspeaker: Cs of farads), and below the band the
    receptance of any RC shunt returns to the static compliance ``1/ω0²`` at DC."""
    edge = plant.omega[0]
    if not any(abs(math.log(p.omega / edge)) < 1e-6 for p in final):
        return ()
    zs = lambda s: rc_impedance(s, rs, Cs)  # noqa: E731
    w = np.geomspace(plant.omega0 / 1e5, edge, 4000)
    g = np.abs(plant.receptance(w, zs))
    i = int(np.argmax(g))
    if not g[i] > ev.peak * (1 + 1e-6):
        return ()
    full = 20 * math.log10(g[i] / ev.peak_open)
    static = 20 * math.log10(1.0 / (plant.omega0**2 * ev.peak_open))
    return ({"code": BELOW_BAND_CODE, "message": (
        f"the optimum balances the driver's resonance against the low end of the design band "
        f"({edge / (2 * math.pi):.3g} Hz = f0/40): below it the shunt's electrical resonance "
        f"(Cs = {Cs:.4g} F with the coil) reaches {full:.2f} dB re the open peak at "
        f"{w[i] / (2 * math.pi):.3g} Hz, so over all "
        f"frequencies the attenuation is {full:.2f} dB, not {ev.attenuation_db:.2f} dB; no RC shunt goes "
        f"below the static compliance 1/omega0^2 ({static:.2f} dB here, the driver's Q limits it)")},)


def design_from_json_dict(rec: dict, *, where: str = "shunt design"):
    """A :class:`~bayes_emt.shunt.design.ShuntDesign` from its :meth:`to_json_dict` (nulls, the JSON
    form of non-finite numbers, read back as NaN, or +inf for an unstable design's attenuation)."""
    if not isinstance(rec, dict):
        raise DataFormatError(f"{where}: expected a JSON object")
    names = [f.name for f in fields(ShuntDesign)]
    missing = [n for n in names[:14] if n not in rec]
    if missing:
        raise DataFormatError(f"{where}: not a shunt design (missing {', '.join(missing)})")
    kw = {}
    for n in names:
        if n not in rec:
            continue
        v = rec[n]
        if v is None and n not in ("max_pole_real", "min_damping_ratio", "r0_uncertainty_ohm"):
            v = math.inf if n == "attenuation_db" and not rec.get("stable", True) else math.nan
        if n == "peaks":
            v = tuple(tuple(p) for p in v)
        elif n in ("warnings", "notes"):
            v = tuple(dict(w) if isinstance(w, dict) else w for w in v)
        kw[n] = v
    return ShuntDesign(**kw)


def read_shunt_design(path: str | Path):
    """Read a design written by :meth:`ShuntDesign.save` (or ``shunt --json``)."""
    return design_from_json_dict(read_json_record(path, "shunt design"), where=str(path))


register_kind(ShuntDesign)
