"""The physics catalogue (SPEC §7): terms that add what a base model leaves out.

Each term is device physics or an instrument effect, enters the plant at its stage
(:mod:`bayes_emt.models.term`), has proper priors identical in every model
(:mod:`bayes_emt.params.defaults`), and proposes its own starting values from the base fit's
misfit (:meth:`~bayes_emt.models.term.Term.start`, a multi-start over the frequency where it acts).
``eddy_current`` is not a term but an escalation of the coil model (I → II → III/UD → NL(n)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from . import terms as T
from .term import FosterPart, StartContext, Term, col, specs

__all__ = ["WindingCapacitance", "SecondResonance", "EnclosurePort", "SuspensionCreep", "ThermalDrift",
           "SemiInductance", "LR2", "LeadImpedance", "MeasurementArtifact"]


def _clip(name_prior, x):
    """``x`` moved strictly inside a prior's support."""
    lo, hi = name_prior.lower, name_prior.upper
    span = (hi - lo) if np.isfinite(hi - lo) else 1.0
    if lo > 0 and np.isfinite(hi):  # decade-spanning: clip in log
        return float(np.exp(np.clip(np.log(x), np.log(lo) + 1e-6, np.log(hi) - 1e-6)))
    return float(np.clip(x, lo + 1e-6 * span, hi - 1e-6 * span))


def _top(ctx: StartContext, fraction: float = 0.15) -> np.ndarray:
    """Mask of the top ``fraction`` of the band (in log frequency)."""
    m = ctx.in_band()
    w = ctx.omega[m]
    lw = np.log(w)
    cut = lw[-1] - fraction * (lw[-1] - lw[0])
    out = np.zeros_like(m)
    out[np.flatnonzero(m)[lw >= cut]] = True
    return out


def _peaks(x: np.ndarray, n: int, prominence: float = 0.0) -> np.ndarray:
    """Indices of the ``n`` most prominent interior local maxima of ``x`` (most prominent first);
    with ``prominence`` > 0 only those standing out by that much (noise bumps do not)."""
    i, props = signal.find_peaks(x, prominence=prominence)
    return i[np.argsort(-props["prominences"], kind="stable")][:n]


def _smooth(x: np.ndarray, k: int = 5) -> np.ndarray:
    if x.size < k:
        return x
    pad = np.pad(x, k // 2, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(pad, k), axis=-1)


@dataclass(frozen=True)
class WindingCapacitance(Term):
    """``Y ← Y + s Cp``: inter-turn and lead capacitance across the terminals."""

    id = "winding_capacitance"
    stage = "parallel"
    augmentation = True
    physics = "winding_capacitance"
    description = "inter-turn and lead capacitance across the terminals"
    signature = ("|Z| falls and the phase turns negative at the top of the band; self-resonance at "
                 "1/sqrt(L Cp)")

    @classmethod
    def default_params(cls):
        return specs("Cp")

    def evaluate(self, s, v, other):
        return s * col(v, 0)

    def jw_rational(self, v):
        return T.inductance_polynomials(v[:, 0])  # the admittance Cp s

    def start(self, ctx):
        prior = self.params["Cp"].prior
        top = _top(ctx)
        dy = (ctx.Y - ctx.Y_base)[top]
        est = float(np.median(dy.imag / ctx.omega[top]))
        # the capacitive admittance at the top of the band as a fraction of |Y| there
        ref = float(np.median(np.abs(ctx.Y[top]) / ctx.omega[top]))
        out = [est] if est > 0 else []
        out += [f * ref for f in (0.03, 0.3)]
        return [{"Cp": _clip(prior, c)} for c in out]


@dataclass(frozen=True)
class SecondResonance(Term):
    """``Z ← Z + φ2² s/(s² + 2 ζ2 ω2 s + ω2²)``: another mechanical mode (rocking, cone, fixture)."""

    id = "second_resonance"
    augmentation = True
    physics = "second_resonance"
    description = "another mechanical mode in series (rocking, cone break-up or fixture mode)"
    signature = "a narrow peak and phase swing of width about 2 zeta2 omega2 at omega2"

    @classmethod
    def default_params(cls):
        return specs("zeta2", "omega2", "phi2")

    def evaluate(self, s, v, other):
        z, w, p = col(v, 0), col(v, 1), col(v, 2)
        return p * p * s / (s * s + 2.0 * z * w * s + w * w)

    def jw_rational(self, v):
        return T.motional_polynomials(v[:, 0], v[:, 1], v[:, 2])  # the same form as eq. 47's branch

    def start(self, ctx):
        pz, pw, pp = (self.params[n].prior for n in ("zeta2", "omega2", "phi2"))
        m = ctx.in_band()
        w = ctx.omega[m]
        dz = _smooth((ctx.Z - ctx.Z_base).real[m])
        out = []
        for i in _peaks(dz, 3, prominence=0.0):
            h = dz[i]
            if h <= 0:
                continue
            half = dz > 0.5 * h
            lo = i
            while lo > 0 and half[lo - 1]:
                lo -= 1
            hi = i
            while hi < dz.size - 1 and half[hi + 1]:
                hi += 1
            zeta = max((w[hi] - w[lo]) / (2.0 * w[i]), 2e-3)
            out.append({"zeta2": _clip(pz, zeta), "omega2": _clip(pw, w[i]),
                        "phi2": _clip(pp, np.sqrt(h * 2 * zeta * w[i]))})
        # and a coarse grid over the band: a weak mode anywhere
        zref = float(np.median(np.abs(ctx.Z[m])))
        for wg in np.geomspace(w[0], w[-1], 8)[1:-1]:
            zeta = 0.05
            out.append({"zeta2": zeta, "omega2": _clip(pw, wg),
                        "phi2": _clip(pp, np.sqrt(0.02 * zref * 2 * zeta * wg))})
        return out


@dataclass(frozen=True)
class EnclosurePort(Term):
    """``1/Z_mot ← 1/Z_mot + (s/Lb)/(s² + 2 ζb ωb s + ωb²)``: a vented box or passive radiator."""

    id = "enclosure_port"
    stage = "motional_parallel"
    augmentation = True
    physics = "enclosure_port"
    description = ("vented box or passive radiator: box compliance and port mass coupled to the driver's "
                   "motional branch")
    signature = "two impedance peaks with a minimum near the port tuning omegab between them"

    @classmethod
    def default_params(cls):
        return specs("Lb", "omegab", "zetab")

    def evaluate(self, s, v, other):
        L, w, z = col(v, 0), col(v, 1), col(v, 2)
        return (s / L) / (s * s + 2.0 * z * w * s + w * w)

    #: port tuning over the driver's resonance a vented box or passive radiator realises
    TUNING_RANGE = (0.3, 3.0)

    def implausible(self, values):
        ratio = values["omegab"] / values["omega0"]
        lo, hi = self.TUNING_RANGE
        if not lo <= ratio <= hi:
            return (f"port tuning omegab = {values['omegab']:.4g} rad/s is {ratio:.3g} x the driver's "
                    f"resonance (a box realises {lo:g}-{hi:g} x): another mode, not a port")
        return None

    def start(self, ctx):
        pL, pw, pz = (self.params[n].prior for n in ("Lb", "omegab", "zetab"))
        zeta0, w0, phi = ctx.base["zeta"], ctx.base["omega0"], ctx.base["phi"]
        logz = _smooth(np.log(np.abs(ctx.Z)))
        pk = np.sort(_peaks(logz, 2, prominence=0.02))
        plans = []
        if pk.size == 2:
            # a vented box: two peaks f_L, f_H with the port tuning at the minimum between them;
            # the driver's own resonance obeys f_L f_H = f_s f_b (Thiele)
            i = pk[0] + int(np.argmin(logz[pk[0] : pk[1] + 1]))
            wb = ctx.omega[i]
            ws = ctx.omega[pk[0]] * ctx.omega[pk[1]] / wb
            plans.append((wb, ws))
        for f in (0.6, 0.8, 1.25):
            plans.append((f * w0, w0))
        out = []
        for wb, ws in plans:
            L_mot = phi * phi / (ws * ws)  # the motional branch's inductance (per-mass units)
            for ratio in (1.0, 3.0):  # box stiffness over suspension stiffness
                out.append({"Lb": _clip(pL, L_mot / ratio), "omegab": _clip(pw, wb), "zetab": _clip(pz, 0.1),
                            "omega0": float(ws), "zeta": float(zeta0)})
        return out


@dataclass(frozen=True)
class SuspensionCreep(Term):
    """LOG creep (Knudsen & Jensen 1993): compliance ``C(s) = C0 [1 + λ ln(ω0/s)]``, so the
    stiffness ``ω0² → ω0²/(1 + λ ln(ω0/s))`` (``s = jω``: the compliance grows by λ per e-fold of
    falling frequency with a constant loss angle, the Kramers–Kronig-consistent form). The reference
    frequency is ``ω0`` itself, so ``ω0`` keeps meaning the stiffness at the resonance and no
    parameter is added besides ``λ``."""

    id = "suspension_creep"
    stage = "stiffness"
    augmentation = True
    physics = "suspension_creep"
    needs = ("omega0",)
    description = "viscoelastic suspension: stiffness falls toward low frequency (LOG creep)"
    signature = ("a low-frequency residual trend below the resonance; the resonance shape (Qms) off in "
                 "both parts")

    @classmethod
    def default_params(cls):
        return specs("lambda_creep")

    def evaluate(self, s, v, other):
        return 1.0 / (1.0 + col(v, 0) * np.log(other["omega0"] / s))

    def start(self, ctx):
        return [{"lambda_creep": lam} for lam in (0.03, 0.08, 0.2)]


@dataclass(frozen=True)
class ThermalDrift(Term):
    """``R0 → R0 (1 + δ t_k)`` with ``t_k ∈ [0, 1]`` the position of point k in the sweep order:
    the coil warming (or the room) during the measurement. ``t`` is computed from the frequency,
    the sweep's first and last frequencies and its spacing (log or linear), bound to the data
    (:meth:`bind`). Not device physics: the shunt design ignores it."""

    omega_first: float | None = None
    omega_last: float | None = None
    spacing: str = "log"
    id = "thermal_drift"
    augmentation = True
    device = False
    physics = "thermal_drift"
    needs = ("R0",)
    description = "coil resistance changing during the sweep (warming, room temperature)"
    signature = "a real-part residual that trends along the sweep order, not with frequency physics"

    def __post_init__(self):
        if self.spacing not in ("log", "linear"):
            raise ValueError(f"thermal_drift spacing must be 'log' or 'linear', got {self.spacing!r}")

    @classmethod
    def default_params(cls, **config):
        return specs("drift")

    def bind(self, omega):
        if self.omega_first is not None:
            return self
        omega = np.asarray(omega, float)

        def spread(x):  # coefficient of variation of the steps
            return float(np.std(x) / abs(np.mean(x)))

        # a linear sweep has equal steps in omega, a log sweep in log omega
        spacing = "linear" if spread(np.diff(omega)) < spread(np.diff(np.log(omega))) else "log"
        return type(self)(self.params, float(omega[0]), float(omega[-1]), spacing)

    def position(self, omega):
        """``t`` of each angular frequency [rad/s] in the sweep order (0 first, 1 last)."""
        if self.omega_first is None:
            raise ValueError("thermal_drift is not bound to a sweep: call Model.bind(omega) first")
        a, b = self.omega_first, self.omega_last
        if self.spacing == "log":
            t = (np.log(omega) - np.log(a)) / (np.log(b) - np.log(a))
        else:
            t = (omega - a) / (b - a)
        return np.clip(t, 0.0, 1.0)

    def evaluate(self, s, v, other):
        return other["R0"] * col(v, 0) * self.position(np.abs(s))

    def start(self, ctx):
        t = self.bind(ctx.omega).position(ctx.omega)
        dz = (ctx.Z - ctx.Z_base).real
        est = float(np.sum(dz * t) / np.sum(t * t)) / ctx.base["R0"]
        prior = self.params["drift"].prior
        return [{"drift": _clip(prior, d)} for d in (est, 0.01, -0.01)]


@dataclass(frozen=True)
class SemiInductance(Term):
    """``Z ← Z + K s^n`` (Leach 1999): the loudspeaker world's lossy inductance."""

    id = "semi_inductance"
    augmentation = True
    coil = True
    physics = "semi_inductance"
    description = "lossy coil inductance K s^n (Leach 1999), 0 < n < 1"
    signature = "|Z| rising as omega^n with a phase near n·90° at high frequency"

    @classmethod
    def default_params(cls):
        return specs("K_semi", "n_semi")

    def evaluate(self, s, v, other):
        return col(v, 0) * np.exp(col(v, 1) * np.log(s))

    def start(self, ctx):
        pK, pn = self.params["K_semi"].prior, self.params["n_semi"].prior
        top = _top(ctx, 0.3)
        dz = (ctx.Z - ctx.Z_base)[top]
        w = ctx.omega[top]
        out = []
        ph = np.angle(dz)
        good = (ph > 0) & (ph < np.pi / 2)
        if np.count_nonzero(good) >= 3:
            n = float(np.clip(np.median(ph[good]) / (np.pi / 2), 0.05, 0.95))
            out.append((n, float(np.median(np.abs(dz[good]) / w[good] ** n))))
        zref = float(np.median(np.abs(ctx.Z[top])))
        for n in (0.3, 0.5, 0.7):
            out.append((n, 0.1 * zref / float(np.median(w)) ** n))
        return [{"K_semi": _clip(pK, K), "n_semi": _clip(pn, n)} for n, K in out]


@dataclass(frozen=True)
class LR2(Term):
    """LR-2 coil (Klippel): ``Zc = s Le + R2 s L2/(R2 + s L2)``, with ``Le`` the base coil's own
    inductance; this term adds the ``R2 ‖ L2`` section (parameters ``L_lr2``, ``R_lr2``: ring
    resistances of NL are already called ``R1..Rn``)."""

    id = "lr2"
    augmentation = True
    coil = True
    physics = "lr2"
    description = "LR-2 coil: a second inductance L2 shunted by R2 in series with the coil"
    signature = "same band as eddy currents: excess real part and phase deficit rising with frequency"

    @classmethod
    def default_params(cls):
        return specs("L_lr2", "R_lr2")

    def evaluate(self, s, v, other):
        L, R = col(v, 0), col(v, 1)
        return R * L * s / (R + L * s)

    def jw_rational(self, v):
        return T.lossy_inductance_polynomials(v[:, 0], v[:, 1])  # model II's form

    def foster(self, v, sections):
        return FosterPart(L=np.array([v[0]]), tau=np.array([v[0] / v[1]]))

    def start(self, ctx):
        pL, pR = self.params["L_lr2"].prior, self.params["R_lr2"].prior
        m = ctx.in_band()
        w = ctx.omega[m]
        dz = (ctx.Z - ctx.Z_base)[m]
        s = 1j * w
        out = []
        for tau in np.geomspace(0.3 / w[-1], 3.0 / w[0], 7):
            e = s / (1 + tau * s)
            c = float(np.real(np.vdot(e, dz)) / np.real(np.vdot(e, e)))
            if c > 0:
                out.append((c, float(np.sum(np.abs(dz - c * e) ** 2)), tau))
        out.sort(key=lambda x: x[1])
        zref = float(np.median(np.abs(ctx.Z[m])))
        cands = [(c, c / tau) for c, _, tau in out[:3]] or [(0.1 * zref / w[-1], 0.1 * zref)]
        return [{"L_lr2": _clip(pL, L), "R_lr2": _clip(pR, R)} for L, R in cands]


@dataclass(frozen=True)
class LeadImpedance(Term):
    """``Z ← Z + Rl + s Ll``: cables and fixture in series."""

    id = "lead_impedance"
    augmentation = True
    physics = "lead_impedance"
    description = "cables and fixture in series with the transducer"
    signature = "a series resistance (indistinguishable from R0) and a small inductance at the top"
    identifiability = "Rl is not identifiable against R0: the data determine only R0 + Rl"

    @classmethod
    def default_params(cls):
        return specs("Rl", "Ll")

    def evaluate(self, s, v, other):
        return col(v, 0) + col(v, 1) * s

    def jw_rational(self, v):
        return np.stack([v[:, 0], v[:, 1]], axis=-1), np.ones((v.shape[0], 1))

    def foster(self, v, sections):
        return FosterPart(R=float(v[0]), G=float(v[1]))

    def start(self, ctx):
        pR, pL = self.params["Rl"].prior, self.params["Ll"].prior
        top = _top(ctx)
        ll = float(np.median((ctx.Z - ctx.Z_base).imag[top] / ctx.omega[top]))
        Rl = 0.01 * ctx.base["R0"]
        return [{"Rl": _clip(pR, Rl), "Ll": _clip(pL, L)} for L in ([ll] if ll > 0 else []) + [1e-7, 1e-5]]


@dataclass(frozen=True)
class MeasurementArtifact(Term):
    """Above ``ωs`` the measured ``Y`` is multiplied by ``(1 + δ) e^{jψ}``: an instrument range switch
    or calibration boundary (not device physics)."""

    id = "measurement_artifact"
    stage = "measurement"
    augmentation = True
    device = False
    physics = "measurement_artifact"
    description = "the instrument, not the device: a range switch or calibration boundary"
    signature = "a step in magnitude and phase at one frequency"

    @classmethod
    def default_params(cls):
        return specs("omegas", "delta_s", "psi_s")

    def evaluate(self, s, v, other):
        step = np.abs(s) > col(v, 0)
        return np.where(step, (1.0 + col(v, 1)) * np.exp(1j * col(v, 2)), 1.0 + 0j)

    def start(self, ctx):
        pw, pd, pp = (self.params[n].prior for n in ("omegas", "delta_s", "psi_s"))
        m = np.flatnonzero(ctx.in_band())
        lr = np.log(ctx.Y / ctx.Y_base)[m]
        # a step between points k-1 and k: the median after minus the median before, over windows of
        # a few percent of the band (a smooth misfit of the base fit hardly moves in that span)
        h = max(3, lr.size // 40)
        steps = []
        for k in range(h, lr.size - h + 1):
            jump = (np.median(lr[k : k + h].real) - np.median(lr[k - h : k].real)
                    + 1j * (np.median(lr[k : k + h].imag) - np.median(lr[k - h : k].imag)))
            steps.append((abs(jump), k, jump))
        steps.sort(key=lambda c: -c[0])
        cands = []
        for st in steps:  # distinct places only
            if all(abs(st[1] - c[1]) > h for c in cands):
                cands.append(st)
            if len(cands) == 3:
                break
        out = []
        for _, k, jump in cands:
            i = m[k]
            ws = float(np.sqrt(ctx.omega[i - 1] * ctx.omega[i]))
            out.append({"omegas": _clip(pw, ws), "delta_s": _clip(pd, float(np.exp(jump.real) - 1.0)),
                        "psi_s": _clip(pp, float(jump.imag))})
        return out
