"""Why Qes from |Z| alone differs from Qes with the phase on the three DATS recordings: the numbers.

Per file, for one model (default UD), least-squares fits of the same model (seed-free):

* ``phase``: the recording as written (complex relative residual);
* ``|Z|``: the phase dropped (log-magnitude residual);
* ``min-phase``: the complex fit with the recorded phase replaced by the minimum-phase partner of the
  recorded |Z| (``bayes_emt.thiele_small.bode.minimum_phase_partner`` about the |Z|-only fit);
* ``same weights``: both fits again with every point weighted by the with-phase posterior's noise
  model, ``s_k = sqrt(sigma_rel^2 + (sigma_abs/|Y_k|)^2)`` (posterior medians, seed 1), so that the
  two differ only in whether the phase enters;

then Small's model-free Qes with the plateau Re (with and without the phase), DATS's own Qes, and
the departure of the recorded phase from the minimum-phase partner of |Z| near resonance.

    OMP_NUM_THREADS=1 .venv/bin/python scripts/magnitude_only_cause.py [--model UD]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
from scipy import optimize

from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.estimation.plateau import plateau_reading
from bayes_emt.inference.sampling import sample_posterior
from bayes_emt.io import read_measurement
from bayes_emt.io.phase import drop_phase
from bayes_emt.measurement import Measurement
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small.bode import minimum_phase_partner, phase_departure
from bayes_emt.thiele_small.compute import TS_SAMPLER, _ts_sampler
from bayes_emt.thiele_small.curve import fit_curve
from bayes_emt.thiele_small.model_free import model_free_ts
from bayes_emt.thiele_small.relations import free_air

REAL = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"
FILES = ["grs_12SW-4HE_dats_0h.txt", "scanspeak_18W-4424G00_dats_0h.txt",
         "sb_SB26STAC-C000-4_dats_freeair.txt"]


def _qes(model, theta) -> float:
    return float(free_air(model, np.asarray(theta, float)[None, :])["Qes"][0])


def _weighted(meas, fit, s, magnitude: bool) -> float:
    """Qes of ``fit.model`` refitted with per-point relative standard deviations ``s``."""
    params, absy = fit.model.params, np.abs(meas.Y)

    def res(z):
        y = fit.model.admittance(meas.omega, params.from_z(z)[None, :])[0]
        if magnitude:
            return np.log(np.abs(y) / absy) / s
        d = (y - meas.Y) / absy / s
        return np.concatenate([d.real, d.imag])

    sol = optimize.least_squares(res, params.to_z(fit.theta), method="lm", x_scale="jac", max_nfev=5000)
    return _qes(fit.model, params.from_z(sol.x))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default="UD")
    args = ap.parse_args()
    model = parse_model_spec(args.model)
    rows = []
    for name in FILES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            meas = read_measurement(REAL / name)
            mag = drop_phase(meas)
            fp, fm = fit_admittance(meas, model), fit_admittance(mag, model)
            zm = 1.0 / fm.model.admittance(meas.omega, fm.theta[None, :])[0]
            ph = minimum_phase_partner(meas.f_hz, np.abs(meas.Z), np.abs(zm), np.angle(zm, deg=True))
            mp = Measurement(meas.omega, 1.0 / (np.abs(meas.Z) * np.exp(1j * np.deg2rad(ph))),
                             weights=meas.weights, meta=dict(meas.meta))
            fh = fit_admittance(mp, model)
            post = sample_posterior(meas, model, fit=fp, seed=1, settings=TS_SAMPLER or _ts_sampler(),
                                    progress=False)
            med = np.median(post.flat(), axis=0)
            srel, sabs = med[post.names.index("sigma_rel")], med[post.names.index("sigma_abs")]
            s = np.sqrt(srel**2 + (sabs / np.abs(meas.Y)) ** 2)
            qw_p, qw_m = _weighted(meas, fp, s, False), _weighted(meas, fp, s, True)
            fs = float(free_air(fp.model, fp.theta[None, :])["fs"][0])
            plat = plateau_reading(meas, fp.model, fp.theta, fs)
            small = [model_free_ts(meas, (plat.meter.value, plat.meter.sd), use_phase=u, n_draws=50,
                                   seed=1)["Qes"] for u in (True, False)]
            dep = phase_departure(fit_curve(fp.model, fp.theta[None, :], meas, fp.rms_rel_residual, 1), fs)
        qp, qm, qh = _qes(fp.model, fp.theta), _qes(fm.model, fm.theta), _qes(fh.model, fh.theta)
        bench = meas.meta["bench_fit"]["values"]["Qes"]
        rows.append(f"| {name} | {qp:.4g} | {qm:.4g} ({100 * (qm / qp - 1):+.2f} %) | {qh:.4g} "
                    f"({100 * (qm / qh - 1):+.2f} %) | {qw_p:.4g} / {qw_m:.4g} "
                    f"({100 * (qw_m / qw_p - 1):+.2f} %) | "
                    f"{small[0]:.4g} / {small[1]:.4g} | {bench:.4g} | {dep['max_deg']:.2f} "
                    f"({dep['noise_deg']:.3f}) |")
        print(rows[-1], flush=True)
    print(f"\nmodel {model.label}: Qes by least squares")
    print("| file | with phase | |Z| only (vs with phase) "
          "| complex fit to the min-phase partner (|Z| only vs it) "
          "| same weights: with phase / |Z| only | Small with plateau Re: phase / |Z| | DATS | "
          "phase departure deg (noise) |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
