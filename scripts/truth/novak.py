"""Model-free reference T/S values of the woofer in Antonin Novak's public lecture recording
(voltage U, current I and laser-Doppler cone velocity V of the same sweep; see corpus.toml):

* fs: where ``Im(I/V)`` changes sign (the mechanical resonance, no model), linear interpolation;
* Bl: real least squares of ``Z = Σ_{k≤2} c_k (jω/ωs)^k + Bl·V/I`` over [fs/3, 3 fs] (a smooth
  polynomial stands in for the blocked impedance; no mechanical model);
* Re: the median of ``Re(Z − Bl·V/I)`` over 10-30 Hz (the blocked impedance where eddy currents add
  nothing measurable);
* the mechanical impedance ``Zm = Bl·I/V`` near fs: ``Im Zm = ω Mms − Kms/ω`` by least squares and
  ``Rms = mean Re Zm`` over [0.8 fs, 1.25 fs] (the T/S values *at* fs, as the impedance peak sees
  them, creep included); ``Qms = ωs Mms / Rms``, ``Qes = ωs Mms Re / Bl²``, ``Qts``.

The spread of Qms and Qes over the windows [0.5, 2], [0.7, 1.4] and [0.8, 1.25] fs (about 1 % and
2 %) is the reference's own uncertainty; run.py prints it beside the reference. The functions
``force_factor`` and the zero crossing are those of ``scripts/truth_study/truth_study.py``."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "truth_study"))
from truth_study import _zero_crossing, force_factor, read_uiv  # noqa: E402

WINDOWS = ((0.8, 1.25), (0.7, 1.4), (0.5, 2.0))


def reference(path: Path) -> tuple[dict, dict]:
    """``(values, spread)``: the SI reference values (fs, Re, Qms, Qes, Qts, Bl, Mms) and, per
    value, the ``[min, max]`` over the mechanical fit windows (fs, Re, Bl: their own value)."""
    f, U, I, V = read_uiv(path)
    ok = f > 0
    f, U, I, V = f[ok], U[ok], I[ok], V[ok]
    Z, H = U / I, V / I
    w = 2 * np.pi * f
    band = (f >= 10.0) & (f <= 1000.0)
    fs = _zero_crossing(f[band], (I / V)[band].imag, f[band][np.argmax(np.abs(H[band]))])
    bl = force_factor(f, Z, H, fs, 2)
    low = (f >= 10.0) & (f <= 30.0)
    re = float(np.median((Z - bl * H)[low].real))
    ws = 2 * math.pi * fs
    zm = bl * I / V
    per = []
    for lo, hi in WINDOWS:
        m = (f >= lo * fs) & (f <= hi * fs)
        mms, _ = np.linalg.lstsq(np.column_stack([w[m], -1 / w[m]]), zm[m].imag, rcond=None)[0]
        rms = float(np.mean(zm[m].real))
        qms, qes = ws * mms / rms, ws * mms * re / bl**2
        per.append({"Qms": qms, "Qes": qes, "Qts": qms * qes / (qms + qes), "Mms": float(mms)})
    values = {"fs": fs, "Re": re, "Bl": bl, **per[0]}
    spread = {k: [min(p[k] for p in per), max(p[k] for p in per)] for k in per[0]}
    spread.update({k: [values[k], values[k]] for k in ("fs", "Re", "Bl")})
    return values, spread


def measurement(path: Path, n_points: int = 400, f_lo: float = 10.0, f_hi: float = 19500.0):
    """The terminal impedance ``Z = U/I`` on the FFT bins nearest ``n_points`` log-spaced
    frequencies in [f_lo, f_hi] Hz (duplicates dropped), as a Measurement."""
    from bayes_emt.measurement import Measurement

    f, U, I, _ = read_uiv(path)
    idx = np.unique(np.clip(np.searchsorted(f, np.geomspace(f_lo, f_hi, n_points)), 0, f.size - 1))
    return Measurement.from_impedance(2 * math.pi * f[idx], (U / I)[idx],
                                      meta={"source": f"{path.name} (Z = U/I, {idx.size} FFT bins)"})


if __name__ == "__main__":
    v, s = reference(Path(sys.argv[1]))
    for k in v:
        print(f"{k} = {v[k]:.6g}   # windows {s[k][0]:.4g}..{s[k][1]:.4g}")
