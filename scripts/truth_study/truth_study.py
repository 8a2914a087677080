"""Truth study (issue 23): does the diagnosed model predict a driver's *measured* blocked coil impedance
better than the baseline, band by band?

One command (data placed as ``scripts/truth_study/SOURCES.md`` says, never inside the repository)::

    OMP_NUM_THREADS=1 PYTHONPATH=$PWD .venv/bin/python scripts/truth_study/truth_study.py \
        /work/notes/truth_data [--time-budget 300] [--seed 0] [--json out.json]

or with ``BAYES_EMT_TRUTH_DIR`` set instead of the positional argument.

For each recording of :data:`RECORDINGS` found under the data directory (its SHA-256 checked):

1. the terminal impedance ``Z = U/I`` and the velocity per current ``H = V/I`` on the recording's own
   FFT grid (``V = jω X`` when a displacement ``X`` is given);
2. the force factor Bl *without a mechanical model*: real least squares of
   ``Z = Σ_k c_k (jω/ω_ref)^k + Bl·H`` (``c_k`` complex, a smooth polynomial standing in for the
   blocked impedance) over ``[fs/3, 3 fs]``; the spread over polynomial degrees 1-3 is reported;
3. the measured blocked impedance ``Ze = Z − Bl·H`` up to the recording's pistonic limit
   ``v_max_hz`` (above it the laser spot no longer moves with the coil: cone modes). Above that limit
   the motional part is extrapolated from the *velocity* data, not from ``Z``: ``Ze = Z − Bl²/Zm``
   with ``Zm = jωMms + Rms + Kms/(jω)`` fitted to the measured ``Bl·I/V`` over ``[2 fs, v_max_hz]``.
   Bands above ``v_max_hz`` are marked ``extrapolated`` in the table; the size of that correction
   (rms ``|Bl²/Zm| / |Ze|`` per band) is printed beside them as the truth's own uncertainty scale;
4. the truth's R0 (the median of ``Re Ze`` over ``[f_lo, 3 f_lo]``, where eddy currents add nothing
   measurable) and fs (where ``Im(I/V)`` changes sign: the mechanical resonance, model-free);
5. the baseline fit (``bayes_emt.fit(meas, START)``, START = UD by default) and the diagnosis
   (``bayes_emt.discovery.diagnose(meas, START, seed=, time_budget=)``) of the terminal impedance
   alone on a log-spaced subset of the FFT bins;
6. per band the rms relative error ``sqrt(mean |Zb − Ze|² / |Ze|²)`` of each model's blocked
   impedance ``Zb`` (:func:`blocked_impedance`) against ``Ze``, and R0, fs against the truth.

The markdown table goes to stdout; ``--json`` writes the same numbers (strict JSON) atomically.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_emt import fit as fit_model
from bayes_emt._atomic import atomic_write_text
from bayes_emt.discovery import diagnose
from bayes_emt.measurement import Measurement
from bayes_emt.models import Model, parse_model_spec

#: the analysis bands [Hz] of issue 23
BANDS_HZ: tuple[tuple[float, float], ...] = (
    (10.0, 100.0), (100.0, 1000.0), (1000.0, 2500.0), (2500.0, 7000.0), (7000.0, 20000.0))

#: catalogue terms in the series stage that are motional (a mechanical mode), not the blocked coil
MOTIONAL_SERIES_TERMS = frozenset({"second_resonance"})


@dataclass(frozen=True)
class Recording:
    """Where a public U/I/velocity recording lies under the data directory and how to read it.

    ``path`` relative to the data directory; ``sha256`` of the file as published; ``f_lo``/``f_hi``
    [Hz] the band analysed (inside the excitation); ``v_max_hz`` [Hz] the upper end of the pistonic
    velocity (see SOURCES.md for how it was chosen); ``device`` in words.
    """

    name: str
    path: str
    sha256: str
    f_lo: float
    f_hi: float
    v_max_hz: float
    device: str


RECORDINGS: tuple[Recording, ...] = (
    Recording(
        name="novak_imdea_lecture",
        path="antonin-novak+IMDEA/Transducers Measurements/Lectures/meas_data.npz",
        sha256="b8f365def5ce1949d9e4cc7d17b6e3c594ca53263c11d259e44d57fc20a538f6",
        f_lo=10.0,
        f_hi=19500.0,
        v_max_hz=1000.0,
        device="woofer (Le Mans Univ. lecture rig), free air; laser Doppler velocity at the cone",
    ),
)


# ---- reading -------------------------------------------------------------------------------------
def read_uiv(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(f [Hz], U [V], I [A], V [m/s])`` spectra from an ``.npz`` with ``f_axis, U, I`` and ``V``
    (velocity) or ``X`` (displacement [m], turned into ``V = jω X``)."""
    with np.load(path, allow_pickle=False) as d:
        keys = set(d.files)
        missing = {"f_axis", "U", "I"} - keys
        if missing or not keys & {"V", "X"}:
            raise SystemExit(f"{path}: needs arrays f_axis, U, I and V or X; has {sorted(keys)}")
        f = np.asarray(d["f_axis"], float)
        U, I = np.asarray(d["U"], complex), np.asarray(d["I"], complex)
        V = (np.asarray(d["V"], complex) if "V" in keys
             else 2j * np.pi * f * np.asarray(d["X"], complex))
    if not (f.shape == U.shape == I.shape == V.shape) or f.ndim != 1:
        raise SystemExit(f"{path}: f_axis, U, I, V must be 1-D arrays of one length")
    return f, U, I, V


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ---- the measured truth --------------------------------------------------------------------------
def _zero_crossing(f, y, near):
    """The frequency [Hz] nearest ``near`` where ``y`` changes sign (linear interpolation)."""
    idx = np.flatnonzero(np.sign(y[:-1]) != np.sign(y[1:]))
    if idx.size == 0:
        raise SystemExit("no sign change of Im(I/V): the velocity has no resonance in the band")
    i = idx[np.argmin(np.abs(f[idx] - near))]
    return float(f[i] - y[i] * (f[i + 1] - f[i]) / (y[i + 1] - y[i]))


def force_factor(f, Z, H, fs, deg: int) -> float:
    """Bl [N/A] by real least squares of ``Z = Σ_{k≤deg} c_k (jω/ω_ref)^k + Bl·H`` over
    [fs/3, 3 fs]: no mechanical model, only a smooth blocked impedance."""
    m = (f >= fs / 3) & (f <= 3 * fs)
    x = 1j * f[m] / fs
    cols = []
    for k in range(deg + 1):
        b = x**k
        cols += [np.r_[b.real, b.imag], np.r_[-b.imag, b.real]]
    cols.append(np.r_[H[m].real, H[m].imag])
    sol = np.linalg.lstsq(np.column_stack(cols), np.r_[Z[m].real, Z[m].imag], rcond=None)[0]
    return float(sol[-1])


@dataclass(frozen=True)
class Truth:
    """The blocked impedance ``Ze`` [Ω] on the FFT grid ``f`` [Hz] and what it was built from."""

    f: np.ndarray
    Z: np.ndarray
    Ze: np.ndarray
    z_extrapolated: np.ndarray  # |Bl²/Zm| where the motional part was extrapolated, else 0
    Bl: float
    Bl_spread: tuple[float, float]
    R0: float
    fs: float
    Mms: float
    Rms: float
    Kms: float
    v_max_hz: float


def measured_truth(f, U, I, V, rec: Recording) -> Truth:
    ok = f > 0
    f, U, I, V = f[ok], U[ok], I[ok], V[ok]
    Z, H = U / I, V / I
    w = 2 * np.pi * f
    band = (f >= rec.f_lo) & (f <= rec.v_max_hz)
    guess = f[band][np.argmax(np.abs(H[band]))]
    fs = _zero_crossing(f[band], (I / V)[band].imag, guess)
    bls = [force_factor(f, Z, H, fs, d) for d in (1, 2, 3)]
    Bl = bls[1]
    # mechanical impedance from the velocity data, for the extrapolation above v_max_hz only
    m = (f >= 2 * fs) & (f <= rec.v_max_hz)
    Zm = Bl * I[m] / V[m]
    Rms = float(np.mean(Zm.real))
    Mms, Kms = np.linalg.lstsq(np.column_stack([w[m], -1 / w[m]]), Zm.imag, rcond=None)[0]
    zmot_fit = Bl**2 / (1j * w * Mms + Rms + Kms / (1j * w))
    above = f > rec.v_max_hz
    Ze = np.where(above, Z - zmot_fit, Z - Bl * H)
    low = (f >= rec.f_lo) & (f <= 3 * rec.f_lo)
    R0 = float(np.median(Ze[low].real))
    return Truth(f=f, Z=Z, Ze=Ze, z_extrapolated=np.where(above, np.abs(zmot_fit), 0.0), Bl=Bl,
                 Bl_spread=(min(bls), max(bls)), R0=R0, fs=fs, Mms=float(Mms), Rms=Rms, Kms=float(Kms),
                 v_max_hz=rec.v_max_hz)


def log_subset(f, lo, hi, n: int) -> np.ndarray:
    """Indices of the FFT bins nearest ``n`` log-spaced frequencies in [lo, hi] (duplicates dropped)."""
    want = np.geomspace(lo, hi, n)
    return np.unique(np.clip(np.searchsorted(f, want), 0, f.size - 1))


# ---- the models' blocked impedance ---------------------------------------------------------------
def blocked_impedance(model: Model, theta, omega) -> np.ndarray:
    """The model's terminal impedance with the coil blocked [Ω] at ``omega`` [rad/s]:
    ``1 / (1/Zs + Yp)`` with ``Zs`` the device's series impedance (R0 + coil + other series terms
    except the motional ones of :data:`MOTIONAL_SERIES_TERMS`) and ``Yp`` what sits across the
    terminals (winding capacitance); instrument terms (``device = False``) left out."""
    s = 1j * np.asarray(omega, float)
    theta = np.asarray(theta, float)
    loop = model.loop(s, theta)
    zs = np.array(loop.z_series, complex)
    for t in model.terms:
        if t.id in MOTIONAL_SERIES_TERMS and t.device:
            zs = zs - t.evaluate(s, theta[model.term_slice(t)][None, :], {}).reshape(zs.shape)
    return 1.0 / (1.0 / zs + loop.y_parallel)


def instrument_factor(model: Model, theta, omega) -> np.ndarray:
    """What the instrument terms (``device = False``: a measurement artifact's gain step) multiply
    the device's admittance by at ``omega`` [rad/s]; 1 for a model without them. The blocked
    impedance *as that instrument would measure it* is ``blocked_impedance / factor``: the fair
    comparison if the artifact were real, since ``Ze = U/I − Bl V/I`` then carries it in ``U/I``."""
    theta = np.asarray(theta, float)
    return model.admittance(omega, theta) * model.impedance_s(1j * np.asarray(omega, float), theta)


def rms_rel(a, b) -> float:
    return float(np.sqrt(np.mean(np.abs(a - b) ** 2 / np.abs(b) ** 2)))


def band_errors(f, Ze, zb, z_extra, v_max_hz) -> list[dict]:
    out = []
    for lo, hi in BANDS_HZ:
        m = (f >= lo) & (f < hi)
        if not m.any():
            out.append({"band_hz": [lo, hi], "n": 0})
            continue
        rec = {"band_hz": [lo, hi], "n": int(m.sum()),
               "f_range_hz": [float(f[m][0]), float(f[m][-1])],
               "extrapolated": bool(hi > v_max_hz),
               "truth_extrapolation_rms_rel": float(np.sqrt(np.mean((z_extra[m] / np.abs(Ze[m])) ** 2)))}
        for k, z in zb.items():
            rec[k] = rms_rel(z[m], Ze[m])
        out.append(rec)
    return out


# ---- one recording -------------------------------------------------------------------------------
def study(rec: Recording, path: Path, *, start: str, n_points: int, seed: int, time_budget: float | None,
          extra: tuple[str, ...] = (), say=print) -> dict:
    f, U, I, V = read_uiv(path)
    tr = measured_truth(f, U, I, V, rec)
    idx = log_subset(tr.f, rec.f_lo, rec.f_hi, n_points)
    fsel = tr.f[idx]
    meas = Measurement.from_hz(fsel, 1.0 / tr.Z[idx], meta={"source": f"{rec.name} ({path.name})"})
    omega = 2 * np.pi * fsel
    say(f"{rec.name}: {meas.n_points} points {fsel[0]:.4g}-{fsel[-1]:.5g} Hz; truth Bl = {tr.Bl:.4g} N/A "
        f"(degrees 1-3: {tr.Bl_spread[0]:.4g}-{tr.Bl_spread[1]:.4g}), R0 = {tr.R0:.4g} ohm, "
        f"fs = {tr.fs:.4g} Hz, Mms = {1e3 * tr.Mms:.3g} g")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        base = fit_model(meas, start)
        t_fit = time.perf_counter() - t0
        say(f"  baseline {base.model.label}: rms rel residual {100 * base.rms_rel_residual:.2f} % "
            f"({t_fit:.1f} s)")
        t0 = time.perf_counter()
        d = diagnose(meas, parse_model_spec(start), seed=seed, time_budget=time_budget,
                     progress=lambda m: say("   ", m))
        t_diag = time.perf_counter() - t0
    fits = {"baseline": base, "diagnosed": d.final_fit}
    for spec in extra:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fits[spec] = fit_model(meas, spec)
        say(f"  fixed model {fits[spec].model.label}: rms rel residual "
            f"{100 * fits[spec].rms_rel_residual:.2f} %")
    zb, columns = {}, []
    for k, v in fits.items():
        zb[k] = blocked_impedance(v.model, v.theta, omega)
        columns.append([k, f"{k} {v.model.label}" if k in ("baseline", "diagnosed") else k])
        gain = instrument_factor(v.model, v.theta, omega)
        if np.max(np.abs(gain - 1.0)) > 1e-9:
            zb[k + "+instrument"] = zb[k] / gain
            columns.append([k + "+instrument", columns[-1][1] + ", instrument terms applied"])
    params = {}
    for k, v in fits.items():
        p = v.parameters
        fs = p["omega0"] / (2 * math.pi)
        params[k] = {"model": v.model.label, "rms_rel_residual_terminal": v.rms_rel_residual,
                     "R0": p["R0"], "R0_rel_err": (p["R0"] - tr.R0) / tr.R0,
                     "fs_hz": fs, "fs_rel_err": (fs - tr.fs) / tr.fs}
    return {
        "recording": rec.name, "device": rec.device, "file": rec.path, "n_points": meas.n_points,
        "truth": {"Bl_N_per_A": tr.Bl, "Bl_spread_N_per_A": list(tr.Bl_spread), "R0_ohm": tr.R0,
                  "fs_hz": tr.fs, "Mms_kg": tr.Mms, "Rms_N_s_per_m": tr.Rms, "Kms_N_per_m": tr.Kms,
                  "v_max_hz": tr.v_max_hz},
        "models": params,
        "findings": [x.physics for x in d.findings],
        "extra_models": list(extra),
        "columns": columns,
        "diagnosis_warnings": list(d.warnings),
        "seconds": {"baseline_fit": t_fit, "diagnose": t_diag},
        "bands": band_errors(fsel, tr.Ze[idx], zb, tr.z_extrapolated[idx], tr.v_max_hz),
    }


def _verdict(err: float, ref: float) -> str:
    """Against the baseline: ``better``/``worse`` beyond 1 % of the baseline's error, else ``same``."""
    return "better" if err < 0.99 * ref else "worse" if err > 1.01 * ref else "same"


def markdown(results: list[dict]) -> str:
    lines = []
    for r in results:
        t, models = r["truth"], r["models"]
        keys = [c[0] for c in r["columns"]]
        b, dg = models["baseline"], models["diagnosed"]
        lines += [
            f"### {r['recording']}: {r['device']}",
            "",
            f"Truth: Bl = {t['Bl_N_per_A']:.4g} N/A, R0 = {t['R0_ohm']:.4g} ohm, fs = {t['fs_hz']:.4g} Hz; "
            f"velocity used up to {t['v_max_hz']:.4g} Hz; {r['n_points']} points fitted. "
            f"Baseline {b['model']}, "
            f"diagnosed {dg['model']} (findings: {', '.join(r['findings']) or 'none'}; diagnose "
            f"{r['seconds']['diagnose']:.0f} s wall, one baseline fit {r['seconds']['baseline_fit']:.1f} s).",
            "",
            "rms relative error of each model's blocked impedance against the measured Ze [%] "
            "(verdict against the baseline, ±1 % of its error = same; where the truth is "
            "piston-extrapolated, a difference smaller than the extrapolated correction is marked "
            "'within the extrapolation'):",
            "",
            "| band [Hz] | points | " + " | ".join(c[1] for c in r["columns"]) + " | truth |",
            "|---|---|" + "---|" * len(keys) + "---|",
        ]
        for x in r["bands"]:
            lo, hi = x["band_hz"]
            if not x["n"]:
                lines.append(f"| {lo:g}-{hi:g} | 0 |" + " - |" * len(keys) + " - |")
                continue
            cells = [f"{100 * x['baseline']:.2f}"]
            # where the truth is extrapolated, a difference smaller than the extrapolated correction
            # is not a verdict: it says so
            unsure = x["extrapolated"] and x["truth_extrapolation_rms_rel"]
            for k in keys[1:]:
                inside = unsure and abs(x[k] - x["baseline"]) < unsure
                cells.append(f"{100 * x[k]:.2f} ({_verdict(x[k], x['baseline'])}"
                             + ("; within the extrapolation)" if inside else ")"))
            truth = (f"piston-extrapolated above {t['v_max_hz']:.4g} Hz (correction "
                     f"{100 * x['truth_extrapolation_rms_rel']:.1f} % of Ze)" if x["extrapolated"]
                     else "measured velocity")
            lines.append(f"| {lo:g}-{hi:g} | {x['n']} | " + " | ".join(cells) + f" | {truth} |")
        lines += ["", "| model | terminal rms [%] | R0 [ohm] | fs [Hz] |", "|---|---|---|---|",
                  f"| truth | - | {t['R0_ohm']:.4g} | {t['fs_hz']:.4g} |"]
        for k in models:
            m = models[k]
            name = f"{k}: {m['model']}" if k in ("baseline", "diagnosed") else k
            lines.append(f"| {name} | {100 * m['rms_rel_residual_terminal']:.2f} | "
                         f"{m['R0']:.4g} ({100 * m['R0_rel_err']:+.1f} %) | "
                         f"{m['fs_hz']:.4g} ({100 * m['fs_rel_err']:+.1f} %) |")
        for w in r["diagnosis_warnings"]:
            lines.append(f"- diagnosis warning: {w}")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("data_dir", nargs="?", default=os.environ.get("BAYES_EMT_TRUTH_DIR"),
                    help="where SOURCES.md's files are placed (default: $BAYES_EMT_TRUTH_DIR)")
    ap.add_argument("--start", default="UD", help="baseline and starting model (default UD)")
    ap.add_argument("--points", type=int, default=500, help="log-spaced FFT bins fitted (default 500)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--time-budget", type=float, default=300.0,
                    help="diagnose's CPU-second budget (default 300; 0 = none)")
    ap.add_argument("--model", action="append", default=[], metavar="SPEC",
                    help="also fit this model spec to the terminal impedance and score its blocked "
                         "impedance (repeatable), e.g. the diagnosis another run reported")
    ap.add_argument("--json", type=Path, help="also write the results here (strict JSON)")
    a = ap.parse_args(argv)
    if not a.data_dir:
        ap.error("give the data directory or set BAYES_EMT_TRUTH_DIR (see scripts/truth_study/SOURCES.md)")
    root = Path(a.data_dir)
    if not root.is_dir():
        ap.error(f"data directory {root} does not exist")
    results = []
    for rec in RECORDINGS:
        path = root / rec.path
        if not path.is_file():
            print(f"{rec.name}: {path} absent, skipped (SOURCES.md says how to place it)", file=sys.stderr)
            continue
        if sha256(path) != rec.sha256:
            print(f"{rec.name}: {path} is not the published file (SHA-256 differs), skipped", file=sys.stderr)
            continue
        results.append(study(rec, path, start=a.start, n_points=a.points, seed=a.seed,
                             time_budget=a.time_budget or None, extra=tuple(a.model),
                             say=lambda *m: print(*m, file=sys.stderr, flush=True)))
    if not results:
        print("no recording found: nothing to report", file=sys.stderr)
        return 1
    print(markdown(results))
    if a.json:
        if a.json.exists() and a.json.resolve() in {(root / r.path).resolve() for r in RECORDINGS}:
            ap.error(f"--json {a.json} is an input file")
        atomic_write_text(a.json, json.dumps(results, indent=1, allow_nan=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
