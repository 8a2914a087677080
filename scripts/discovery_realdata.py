"""Discrepancy discovery on every real recording in ../shared/realdata (issue 13, acceptance 4).

One command::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_realdata.py \
        [--out scripts/results/discovery_realdata]

Each recording (read and band-limited as :data:`bayes_emt.io.datasets.REALDATA_FILES` says) is
diagnosed from the base model the evidence prefers; the findings, what stays unexplained, the rms
relative residual before and after and how R0, Qms, fs (the Thiele-Small convention of
:func:`bayes_emt.discovery.diagnose.moved_parameters`) and φ̄ moved are written per
recording (``NAME.json``, reused on a re-run: resume) and in ``table.md``. For the LS10-44
added-mass pair (0.100 kg added) the joint added-mass fit is run with the starting and the final
model of the free-air run, giving how the physical mass m [kg] and force factor Bl [N/A] moved.
The table gives the wall time of the diagnosis and its ratio to one UD fit of the same file timed
just before it in the same process, and whether the time budget (``--time-budget`` CPU s of the
process and its workers) was hit.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

from bayes_emt._atomic import atomic_write_text
from bayes_emt.added_mass.fit import fit_added_mass
from bayes_emt.discovery import diagnose
from bayes_emt.discovery.diagnose import moved_parameters
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io.datasets import REALDATA_FILES, load_realdata
from bayes_emt.models import parse_model_spec

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
PAIR = ("dayton_LS10-44_freeair_run2.txt", "dayton_LS10-44_added100g_run2.txt", 0.100)
#: how each recording was mounted (../shared/realdata/README.md), for ``--setup known``
SETUP = {
    "dayton_LS10-44.zma": "free-air",
    "dayton_LS10-44_freeair_run2.txt": "free-air",
    "dayton_LS10-44_added100g_run2.txt": "free-air",
    "seas_E0018_freeair.zma": "free-air",
    "koan_mid_sealed.zma": "sealed",
    "koan_tweeter.zma": "sealed",  # a tweeter's closed back: no port
}


def run_one(name: str, out: Path, setup: str = "unknown", time_budget: float | None = 240.0,
            workers: int | None = None) -> dict:
    path = out / f"{name}.json"
    if path.exists():
        return json.loads(path.read_text())
    meas = load_realdata(REAL, name)
    setup = SETUP.get(name, "unknown") if setup == "known" else setup
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        fit_admittance(meas, parse_model_spec("UD"))
        t_ud = time.perf_counter() - t
        t = time.perf_counter()
        d = diagnose(meas, None, setup=setup, time_budget=time_budget, workers=workers,
                     progress=lambda m: print("   ", m, flush=True))
    rec = {"file": name, "n_points": meas.n_points, "seconds": time.perf_counter() - t, "setup": setup,
           "seconds_one_ud_fit": t_ud, "time_budget_cpu_s": time_budget, "workers": workers,
           "budget_hit": d.budget_hit,
           "load_average_1min": os.getloadavg()[0], **d.details()}
    # fs and Qms by the Thiele-Small convention (under creep: the mechanical impedance's resonance and
    # all its loss there), as the diagnosis reports them
    mv = moved_parameters(d.baseline_fit, d.final_fit)
    rec["moved"] = {k: {x: mv[k][x] for x in ("before", "after", "relative_change")}
                    for k in ("R0", "Qms", "fs_hz", "phi") if k in mv}
    atomic_write_text(path, json.dumps(rec, indent=1, default=float))
    return rec


def added_mass(recs: dict, out: Path) -> dict | None:
    path = out / "added_mass_pair.json"
    if path.exists():
        return json.loads(path.read_text())
    a, b, dm = PAIR
    if a not in recs:
        return None
    base, loaded = load_realdata(REAL, a), load_realdata(REAL, b)
    res = {}
    for which in ("baseline_model", "final_model"):
        spec = recs[a][which]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = fit_added_mass(base, loaded, dm, parse_model_spec(spec))
        res[which] = {
            "model": spec,
            "m_kg": r.values["m"],
            "Bl_N_per_A": r.values["phi_raw"],
            "k_N_per_m": r.values["k"],
            "R0_ohm": r.values["R0"],
            "rms_rel_residual": list(r.rms_rel_residual),
        }
    for q in ("m_kg", "Bl_N_per_A", "k_N_per_m", "R0_ohm"):
        x0, x1 = res["baseline_model"][q], res["final_model"][q]
        res.setdefault("relative_change", {})[q] = (x1 - x0) / x0
    atomic_write_text(path, json.dumps(res, indent=1))
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="scripts/results/discovery_realdata")
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--setup", default="unknown", choices=["unknown", "known"],
                    help="unknown (default): every recording diagnosed with setup unknown; known: with "
                         "its mounting from ../shared/realdata/README.md (free air, sealed)")
    ap.add_argument("--time-budget", type=float, default=240.0, help="CPU s per diagnosis (0: none)")
    ap.add_argument("--workers", type=int, default=None,
                    help="diagnose's worker processes (default: the library's, 2 on a 2-core machine)")
    ap.add_argument("--report-only", action="store_true",
                    help="tabulate the recordings already diagnosed in --out (and the added-mass pair)")
    a = ap.parse_args(argv)
    if not REAL.exists():
        print(f"no real recordings at {REAL}")
        return 2
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    recs = {}
    for name in sorted(REALDATA_FILES):
        if (a.only and name not in a.only) or (a.report_only and not (out / f"{name}.json").exists()):
            continue
        print(name, flush=True)
        recs[name] = run_one(name, out, a.setup, a.time_budget or None, a.workers)
    pair = added_mass(recs, out) if not a.only else None
    lines = [
        "| recording | start | final | findings | unexplained bands (Hz) | rms before | rms after | "
        "R0 | Qms | fs | seconds | x one UD fit | budget hit |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in recs.items():
        fnd = (
            "; ".join(
                f"{f['physics']} ({f['band_hz'][0]:.3g}-{f['band_hz'][1]:.3g} Hz"
                + (", broadband" if f.get("broadband") else "")
                + f", dlogZ {f['delta_log_evidence']:.0f})"
                for f in r["findings"]
            )
            or "none"
        )
        une = (
            "; ".join(f"{u['band_hz'][0]:.3g}-{u['band_hz'][1]:.3g}" for u in r["unexplained_detail"])
            or "none"
        )
        mv = r["moved"]
        lines.append(
            f"| {name} | {r['baseline_model']} | {r['final_model']} | {fnd} | {une} | "
            f"{100 * r['rms_rel_residual']['baseline']:.2f} % | "
            f"{100 * r['rms_rel_residual']['final']:.2f} % | "
            + " | ".join(
                f"{mv[k]['before']:.4g} -> {mv[k]['after']:.4g} ({100 * mv[k]['relative_change']:+.1f} %)"
                for k in ("R0", "Qms", "fs_hz")
            )
            + f" | {r['seconds']:.0f} | "
            + (f"{r['seconds'] / r['seconds_one_ud_fit']:.0f}" if r.get("seconds_one_ud_fit") else "-")
            + " | " + {True: "yes", False: "no"}.get(r.get("budget_hit"), "-") + " |"
        )
    if pair:
        lines += [
            "",
            "LS10-44 added-mass pair (0.100 kg), joint fit with the starting and the final model:",
            "",
            "| model | m [kg] | Bl [N/A] | k [N/m] | R0 [ohm] |",
            "|---|---|---|---|---|",
        ]
        for which in ("baseline_model", "final_model"):
            p = pair[which]
            lines.append(
                f"| {p['model']} | {p['m_kg']:.4g} | {p['Bl_N_per_A']:.4g} | {p['k_N_per_m']:.4g} | "
                f"{p['R0_ohm']:.4g} |"
            )
        rc = pair["relative_change"]
        lines.append(
            f"| change | {100 * rc['m_kg']:+.1f} % | {100 * rc['Bl_N_per_A']:+.1f} % | "
            f"{100 * rc['k_N_per_m']:+.1f} % | {100 * rc['R0_ohm']:+.1f} % |"
        )
    if not a.only:
        atomic_write_text(out / "table.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
