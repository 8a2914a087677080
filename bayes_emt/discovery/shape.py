"""The shape of a mismatch nothing in the catalogue explains: a low-order rational fit of the residual.

Over the band, the complex relative residual ``e(ω) = (Y_meas − Y_model)/Y_model`` is fitted by
``e(s) ≈ (a0 + a1 x + a2 x²)/(1 + b1 x + b2 x²)`` with ``x = s/ω_c`` (``ω_c`` the band's geometric
centre), by Levy's linearisation (one real linear least-squares problem,
``min Σ |num(x_k) − den(x_k) e_k|²``; Levy 1959). Its poles and zeros [rad/s] say what kind of
feature the residual is (a complex pole pair: a resonance; real poles: a relaxation; a step: a pole
and zero close together), in words a user can act on.
"""

from __future__ import annotations

import numpy as np

from ..measurement import Measurement
from ..models import Model
from .locate import Band

__all__ = ["residual_shape", "describe_shape", "narrow_resonance", "NARROW_RATIO"]


def residual_shape(meas: Measurement, model: Model, theta, band: Band, order: int = 2) -> dict:
    """Rational fit of the band's relative residual (module docstring): ``{"poles_rad_s",
    "zeros_rad_s"}`` (complex numbers as ``[re, im]`` pairs), ``rms_residual_rel`` (the
    residual's rms), ``rms_unexplained_rel`` (after the rational fit), ``mean_real``/``mean_imag``."""
    sl = slice(band.i_lo, band.i_hi + 1)
    w = meas.omega[sl]
    with np.errstate(all="ignore"):
        Ym = model.bind(meas.omega).admittance(meas.omega, theta)[sl]
    e = (meas.Y[sl] - Ym) / Ym
    wc = float(np.sqrt(w[0] * w[-1]))
    x = 1j * w / wc
    cols = [x**i for i in range(order + 1)] + [-e * x**i for i in range(1, order + 1)]
    A = np.stack(cols, axis=1)
    Ar = np.concatenate([A.real, A.imag])
    br = np.concatenate([e.real, e.imag])
    c, *_ = np.linalg.lstsq(Ar, br, rcond=None)
    a, b = c[: order + 1], np.r_[1.0, c[order + 1 :]]
    fit = np.polyval(a[::-1], x) / np.polyval(b[::-1], x)
    zeros = np.roots(a[::-1]) * wc if np.any(a[1:] != 0) else np.array([])
    poles = np.roots(b[::-1]) * wc

    def pairs(r):  # roots in the s-plane as [Re, Im] [rad/s]
        return [[float(z.real), float(z.imag)] for z in np.asarray(r, complex)]

    return {
        "poles_rad_s": pairs(poles),
        "zeros_rad_s": pairs(zeros),
        "rms_residual_rel": float(np.sqrt(np.mean(np.abs(e) ** 2))),
        "rms_unexplained_rel": float(np.sqrt(np.mean(np.abs(e - fit) ** 2))),
        "mean_real": float(np.mean(e.real)),
        "mean_imag": float(np.mean(e.imag)),
    }


#: a band no wider than this ratio hi/lo (about a third of an octave) holding a resonance-like pole
#: pair is a narrow feature no lumped model explains (cone break-up, a surround dip)
NARROW_RATIO = 1.26


def narrow_resonance(band: Band, shape: dict) -> dict | None:
    """``{"f_hz", "q", "band_hz"}`` when ``band`` is a narrow feature, at most :data:`NARROW_RATIO`
    wide (hi/lo), at its rational fit's sharpest pole pair inside it. Q is the pole's
    ``|p|/(2 |Re p|)``: a pole in the right half-plane (Levy's linearisation does not enforce
    stability) is read by its mirror image, which has the same magnitude response; without a pole
    pair inside the band Q is the band's ``f_centre/(f_hi − f_lo)``."""
    lo, hi = band.lo / (2 * np.pi), band.hi / (2 * np.pi)
    best = None
    for re, im in shape["poles_rad_s"]:
        mod = float(np.hypot(re, im))
        if im > 1e-6 * mod and band.lo <= mod <= band.hi:
            q = mod / (2 * abs(re)) if re != 0 else float("inf")
            if best is None or q > best[1]:
                best = (mod / (2 * np.pi), q)
    if hi / lo > NARROW_RATIO:
        return None
    if best is None:
        fc = float(np.sqrt(lo * hi))
        best = (fc, fc / (hi - lo) if hi > lo else float("inf"))
    return {"f_hz": float(best[0]), "q": float(min(best[1], 1e6)), "band_hz": [lo, hi]}


def describe_shape(band: Band, shape: dict) -> str:
    """Plain words for an unexplained band: where, how large, which parts, and the rational
    fit's poles (a complex pair reads as a resonance at its modulus with its damping ratio
    ``|Re p|/|p|``, never negative: see :func:`narrow_resonance`); a narrow feature is named as an
    unmodelled narrow resonance with the band to exclude."""
    lo, hi = band.lo / (2 * np.pi), band.hi / (2 * np.pi)
    nr = narrow_resonance(band, shape)
    if nr is not None:
        q, rms = nr["q"], 100 * shape["rms_residual_rel"]
        return (
            f"unmodelled narrow resonance at {nr['f_hz']:.4g} Hz, Q ≈ {q:.3g} (rms {rms:.2g} % "
            f"in {'/'.join(band.parts)} part(s), {lo:.4g}-{hi:.4g} Hz): no lumped term explains it (cone "
            f"break-up, a surround dip); exclude the band (--exclude-band {lo:.4g}:{hi:.4g}, "
            f"exclude_band=[({lo:.4g}, {hi:.4g})]) to keep it out of the fit"
        )
    words = []
    for re, im in shape["poles_rad_s"]:
        mod = float(np.hypot(re, im))
        if abs(im) > 1e-6 * mod and im > 0:
            zeta = abs(re) / mod if mod > 0 else float("nan")
            words.append(
                f"a resonance-like pole pair at {mod / (2 * np.pi):.4g} Hz (damping ratio {zeta:.2g})"
            )
        elif abs(im) <= 1e-6 * mod:
            words.append(f"a real pole at {abs(re) / (2 * np.pi):.4g} Hz")
    form = "; ".join(words) if words else "no pole in the rational fit"
    sharp = [(float(np.hypot(re, im)), float(np.hypot(re, im)) / (2 * abs(re)) if re else float("inf"))
             for re, im in shape["poles_rad_s"] if im > 0 and band.lo <= np.hypot(re, im) <= band.hi]
    sharp = [(w, q) for w, q in sharp if q >= 5.0]
    if sharp:
        w, q = max(sharp, key=lambda p: p[1])
        f, q = w / (2 * np.pi), min(q, 1e6)
        half = max(1.5 / q, 0.01)  # at least ±1 %: a pole sharper than the grid is not resolved
        f1, f2 = f * (1 - half), f * (1 + half)
        form += (f"; the pole pair at {f:.4g} Hz is sharp (Q ≈ {q:.3g}): if it is a cone or surround "
                 f"mode no lumped term models, exclude about --exclude-band {f1:.4g}:{f2:.4g}")
    broad = np.log10(hi / lo) > 2.0 if lo > 0 else False
    return (
        f"unexplained {'broadband ' if broad else ''}mismatch of rms {100 * shape['rms_residual_rel']:.2g} % "
        f"in {'/'.join(band.parts)} "
        f"part(s) between {lo:.4g} and {hi:.4g} Hz ({band.lo:.4g}-{band.hi:.4g} rad/s); residual shape: "
        f"{form}; no catalogue term explains it significantly"
    )
