"""Reproduce the paper's numbers (SPEC.md §5) and print them beside the printed values.

    .venv/bin/python scripts/reproduce_paper.py [--seeds 20] [--out scripts/results/paper_reproduction.txt]

What it does, each against the value SPEC.md §5 prints:

1. Tables 1-5 (and UL from Table 4's UD values): noise-free data simulated on the paper's grid
   (2000 log-spaced points, 1e1..1e5 rad/s) are written to a file and fitted by the command line,
   ``bayes-emt fit FILE --model M --json OUT``, from the data alone; the worst relative parameter
   error per model (NL also the worst relative impedance error).
2. Standard errors: ``--seeds`` datasets per model with 0.2 % relative complex noise; the fraction of
   fitted parameters within 1, 2 and 4 standard errors of the truth.
3. The NL ring count: a 7-ring fit of Table 5 data (0.2 % noise), Hankel singular values, chosen n.
4. Table B.9 from Tables 5 and B.8 (two-fit formulas of SPEC §3.4).
5. Table 6: the H∞-optimal RC shunt per model, the NL design's attenuation, Table 6's designs
   evaluated on the NL model, the Rs at which each design's loop goes unstable, and the time per design.

Everything is seeded; the same command prints the same numbers (times aside).
"""

from __future__ import annotations

import argparse
import io
import json
import sys
import tempfile
import time
import warnings
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np

from bayes_emt import build_model, simulate
from bayes_emt.added_mass.fit import physical_from_two_fits
from bayes_emt.cli import main as cli
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.estimation.hankel import select_rings
from bayes_emt.io import write_measurement
from bayes_emt.reference import (
    PAPER_ADDED_MASS,
    PAPER_OMEGA_RANGE,
    PAPER_PHYSICAL,
    PAPER_POINTS,
    PAPER_SHUNTS,
    PAPER_TABLES,
)
from bayes_emt.shunt import design_rc_shunt, evaluate_rc_shunt

CASES = [("I", "I"), ("II", "II"), ("III", "III"), ("UD", "UD"), ("NL", "NL"), ("UL", "UD")]
OMEGA = np.geomspace(*PAPER_OMEGA_RANGE, PAPER_POINTS)  # rad/s
NL_PREDICTED = {"I": -13.9, "II": -15.1, "III": -16.2, "UD": -20.4, "NL": -24.7}  # SPEC §5 [dB]


def tables_by_cli(say, tmp: Path) -> None:
    say("1. Tables 1-5 from noise-free data, fitted by `bayes-emt fit` (no user guess)")
    say(f"   {'model':<6}{'worst |rel. error|':>20}  {'parameter':<10}{'impedance':>12}{'seconds':>9}")
    for name, table in CASES:
        model = build_model(name, rings=5 if name in ("NL", "UL") else None)
        truth = model.vector(PAPER_TABLES[table])
        data, out = tmp / f"{name}.csv", tmp / f"{name}.json"
        write_measurement(simulate(model, truth, OMEGA), data)
        t0 = time.perf_counter()
        with redirect_stdout(io.StringIO()), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc = cli(["fit", str(data), "--model", name, "--json", str(out)])
        sec = time.perf_counter() - t0
        if rc != 0:
            say(f"   {name:<6}  FAILED (exit {rc})")
            continue
        got = model.vector(json.loads(out.read_text())["parameters"])
        rel = np.abs(got / truth - 1)
        zrel = np.max(np.abs(model.impedance(OMEGA, got) / model.impedance(OMEGA, truth) - 1))
        i = int(np.argmax(rel))
        say(f"   {name:<6}{rel[i]:>20.2e}  {model.names[i]:<10}{zrel:>12.2e}{sec:>9.1f}")


def standard_errors(say, seeds: int) -> None:
    say(f"\n2. Standard errors: {seeds} seeds per model, 0.2 % noise; fraction of parameters within k SE")
    say(f"   {'model':<6}{'k=1':>8}{'k=2':>8}{'k=4':>8}   (Gaussian: 0.68, 0.95, 0.9999)")
    for name, table in CASES:
        model = build_model(name, rings=5 if name in ("NL", "UL") else None)
        truth = model.vector(PAPER_TABLES[table])
        t = []
        for seed in range(seeds):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_admittance(simulate(model, truth, OMEGA, noise=0.002, seed=seed), model)
            t.extend(np.abs(fit.theta - truth) / np.array([fit.stderr[n] for n in model.names]))
        t = np.asarray(t)
        say(f"   {name:<6}" + "".join(f"{np.mean(t <= k):>8.3f}" for k in (1, 2, 4)))


def ring_count(say) -> None:
    nl = build_model("NL", rings=5)
    meas = simulate(nl, nl.vector(PAPER_TABLES["NL"]), OMEGA, noise=0.002, seed=11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rc = select_rings(meas, 7)
    say("\n3. NL ring count (SPEC §3.3): 7-ring fit of Table 5 data (0.2 % noise, seed 11)")
    say("   Hankel singular values [S]: " + ", ".join(f"{h:.3g}" for h in rc.hsv))
    say(f"   noise floor {rc.noise_floor:.3g} S; chosen n = {rc.rings} (paper: 5)")


def table_b9(say) -> None:
    got = physical_from_two_fits(PAPER_TABLES["NL"], PAPER_ADDED_MASS["parameters"],
                                 PAPER_ADDED_MASS["delta_m"])
    units = {"m": "kg", "c": "N s/m", "k": "N/m", "phi_raw": "N/A"}
    say("\n4. Table B.9 from Tables 5 + B.8 (Δm = −0.645 kg)")
    for k, u in units.items():
        say(f"   {k:<8}{got[k]:>10.4g} {u:<6} (Table B.9: {PAPER_PHYSICAL[k]:.4g})")


def table6(say) -> None:
    say("\n5. Table 6: H∞-optimal RC shunt per model (from Tables 1-5)")
    say(f"   {'model':<6}{'Rs [Ω]':>9}{'paper':>8}{'Cs [F]':>10}{'paper':>8}{'att. [dB]':>11}"
        f"{'Rs_instab. [Ω]':>16}{'on NL [dB]':>12}{'SPEC':>7}{'design [s]':>12}")
    nl = build_model("NL")
    th_nl = nl.vector(PAPER_TABLES["NL"])
    for name in ("I", "II", "III", "UD", "NL"):
        model = build_model(name)
        t0 = time.perf_counter()
        d = design_rc_shunt(model, model.vector(PAPER_TABLES[name]))
        sec = time.perf_counter() - t0
        ref = PAPER_SHUNTS[name]
        on_nl = evaluate_rc_shunt(nl, th_nl, ref["Rs"], ref["Cs"]).attenuation_db
        say(f"   {name:<6}{d.Rs:>9.3f}{ref['Rs']:>8.2f}{d.Cs:>10.4f}{ref['Cs']:>8.3g}"
            f"{d.attenuation_db:>11.2f}"
            f"{d.Rs_instability:>16.4f}{on_nl:>12.2f}{NL_PREDICTED[name]:>7.1f}{sec:>12.2f}")
        if name == "I":
            cf = d.closed_form
            say(f"   {'':<6}closed form (Den Hartog, ζ = 0): Rs {cf['Rs']:.3f} Ω, Cs {cf['Cs']:.4f} F "
                "(Table 6 prints this one); exact optimum above")
    say("   'on NL' evaluates Table 6's printed (Rs, Cs) on the Table 5 NL model; SPEC §5 predicts 'SPEC'.")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=20, help="noisy datasets per model for part 2 (0 skips it)")
    ap.add_argument("--out", type=Path, help="also write the report to this file")
    args = ap.parse_args(argv)
    lines: list[str] = []

    def say(s: str) -> None:
        print(s, flush=True)
        lines.append(s)

    with tempfile.TemporaryDirectory() as tmp:
        tables_by_cli(say, Path(tmp))
    if args.seeds > 0:
        standard_errors(say, args.seeds)
    ring_count(say)
    table_b9(say)
    table6(say)
    if args.out:
        args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
