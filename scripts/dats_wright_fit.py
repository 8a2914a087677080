"""Fit DATS's own kind of model to the curve a DATS export holds, and print it beside DATS's header.

The Dayton Audio Test System writes its T/S fit in the export's header, with the coefficients of a
Wright-type lossy coil (``K(r)``, ``X(r)``, ``K(i)``, ``X(i)``; J. R. Wright, "An empirical model for
loudspeaker motor impedance", J. Audio Eng. Soc. 38(10), 1990). This script fits that kind of model to the
exported curve itself:

    Z(ω) = Re + Kr ω^Xr + j Ki ω^Xi + Res / (1 + j Qms (f/fs − fs/f)),   ω in rad/s,

with Re held at DATS's ``R(e)`` (DATS reads it before the fit), by least squares on the relative
complex residual over the fitted rows (those the package's reader keeps: above the analyser's
resolution), from two starts (DATS's own coil coefficients and fs, and a neutral lossy coil), the
better fit kept. Qes = Qms Re / Res, Qts = Qms Qes /
(Qms + Qes). It answers one question: are DATS's fs and Q values those of its own model on the curve
it exported? (On the SB26 tweeter they are not: the fit gives fs 670 Hz against DATS's 658.1 Hz.)

    .venv/bin/python scripts/dats_wright_fit.py ../shared/realdata/*dats*.txt
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from scipy.optimize import least_squares

from bayes_emt.io import read_measurement


def wright_fit(path: str) -> dict:
    """DATS's header values and the Wright-coil fit of the exported curve (module docstring)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meas = read_measurement(path)
    bench = meas.meta.get("bench_fit", {}).get("values", {})
    if not {"fs", "Re"} <= set(bench):
        raise SystemExit(f"{path}: no DATS fit (fs, R(e)) in the header")
    f = meas.f_hz
    w = 2 * np.pi * f
    z = 1.0 / meas.Y
    re = float(bench["Re"])
    fs0 = float(bench["fs"])
    near = (f > fs0 / 3) & (f < fs0 * 3)
    peak = float(np.max(np.abs(z[near])))

    def model(p):
        kr, xr, lki, xi, lres, lfs, lq = p
        fs = np.exp(lfs)
        zm = np.exp(lres) / (1 + 1j * np.exp(lq) * (f / fs - fs / f))
        return re + kr * w**xr + 1j * np.exp(lki) * w**xi + zm

    def resid(p):
        r = (model(p) - z) / np.abs(z)
        return np.r_[r.real, r.imag]

    extra = meas.meta.get("bench_fit", {}).get("extra", {})

    def coef(key, default):
        v = extra.get(key, {}).get("value")
        return float(v) if v else default

    lo = np.array([-10, 0, -30, 0, -5, np.log(fs0 / 2), np.log(0.1)])
    hi = np.array([10, 1.5, 5, 1, 6, np.log(fs0 * 2), np.log(50)])
    mech = [np.log(max(peak - re, 1e-3)), np.log(fs0), np.log(float(bench.get("Qms", 3.0)))]
    # two starts, the better fit kept: DATS's own coil coefficients, and a neutral lossy coil
    starts = [[coef("K(r)", 0.01), coef("X(r)", 0.5), np.log(coef("K(i)", 1e-3)), coef("X(i)", 0.7)],
              [0.01, 0.5, np.log(1e-3), 0.7]]
    fits = [least_squares(resid, np.clip(c + mech, lo + 1e-9, hi - 1e-9), bounds=(lo, hi)) for c in starts]
    sol = min(fits, key=lambda r: r.cost)
    kr, xr, lki, xi, lres, lfs, lq = sol.x
    fs, qms, res = np.exp(lfs), np.exp(lq), np.exp(lres)
    qes = qms * re / res
    dats = {k: bench.get(k) for k in ("fs", "Qms", "Qes", "Qts")}
    return {"file": path, "points": int(f.size), "dats": dats,
            "fit": {"fs": fs, "Qms": qms, "Qes": qes, "Qts": qms * qes / (qms + qes),
                    "Kr": kr, "Xr": xr, "Ki": float(np.exp(lki)), "Xi": xi},
            "rms_relative": float(np.sqrt(np.mean(sol.fun**2)))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", help="DATS impedance exports")
    a = ap.parse_args(argv)
    for path in a.files:
        r = wright_fit(path)
        d, g = r["dats"], r["fit"]
        print(f"{path} ({r['points']} points fitted; rms relative residual {100 * r['rms_relative']:.2f} %)")
        print(f"  DATS header:           fs {d['fs']} Hz, Qms {d['Qms']}, Qes {d['Qes']}, Qts {d['Qts']}")
        print(f"  Wright coil fit, curve: fs {g['fs']:.2f} Hz, Qms {g['Qms']:.3f}, Qes {g['Qes']:.3f}, "
              f"Qts {g['Qts']:.3f} (Kr {g['Kr']:.4g}, Xr {g['Xr']:.3f}, Ki {g['Ki']:.4g}, Xi {g['Xi']:.3f}; "
              f"fs {100 * (g['fs'] / d['fs'] - 1):+.1f} % from DATS's)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
