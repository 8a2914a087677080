"""T/S parameters of the real Dayton Audio LS10-44 added-mass pair, and what an ohmmeter reading
does to R0 (issue 22, acceptance 2 and 4).

Data: ``../shared/realdata/dayton_LS10-44_freeair_run2.txt`` and ``..._added100g_run2.txt``
(Δm = 0.100 kg, phase in radians), 10 Hz–1 kHz; Sd = 0.0363 m² (the value the data's source
repository, yankz12/audiolib-elac ``test/test_z.py``, uses). The "meter" reading is the file's
own lowest point, Re Z(1 Hz) = 7.40 Ω (outside the fitted band; the motional part there is
below 0.01 Ω).

    .venv/bin/python scripts/ts_realdata.py          # about 5 minutes; writes scripts/results/ts_ls10_44.txt

The reading counts as a cut (the default: R0 from the reading alone, the rest fitted at it) or as a
prior (Bayes' rule with the data); both are shown.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io import read_measurement
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small import thiele_small

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT / ".." / "shared" / "realdata"
OUT = ROOT / "scripts" / "results" / "ts_ls10_44.txt"
OPTS = {"freq_unit": "hz", "phase_unit": "rad"}
BAND = (10.0, 1000.0)
SD = 0.0363


def main() -> int:
    free_path = REAL / "dayton_LS10-44_freeair_run2.txt"
    if not free_path.exists():
        print(f"{free_path}: absent", file=sys.stderr)
        return 1
    loaded = [(REAL / "dayton_LS10-44_added100g_run2.txt", 0.100)]
    full = read_measurement(free_path, **OPTS)
    z1 = full.Z[np.argmin(np.abs(full.f_hz - 1.0))]
    meter = round(float(z1.real), 2)
    lines = [f"Dayton LS10-44 pair, {BAND[0]:g}-{BAND[1]:g} Hz, Sd {SD} m^2; "
             f"Re Z(1 Hz) = {z1.real:.3f} ohm"]
    for fast in (True, False):
        for re in (None, (meter, 0.01 * meter, "cut"), (meter, 0.01 * meter, "prior")):
            r = thiele_small(free_path, "UD", loaded=loaded, sd=SD, re=re, fast=fast, seed=0,
                             f_range_hz=BAND, read_options=OPTS)
            lines.append(f"\n--- ts UD, {'fast' if fast else 'posterior'}, re={re}")
            lines += r.summary().splitlines()
            lines.append(f"model spread: {r.inputs['model_spread']}")
            lines += [f"warning [{w['code']}]: {w['message']}" for w in r.warnings
                      if w["code"] == "re_conflict"]
    meas = full.select(2 * math.pi * BAND[0], 2 * math.pi * BAND[1])
    lines.append("\n--- R0 across coil models (least squares, free-air recording), with and without "
                 "the reading")
    for re in (None, (meter, 0.01 * meter, "cut"), (meter, 0.01 * meter, "prior"),
               (meter, 0.0025 * meter, "prior")):
        r0 = {}
        for spec in ("II", "III", "UD", "UD+suspension_creep"):
            f = fit_admittance(meas, parse_model_spec(spec), re=re)
            r0[spec] = (f.parameters["R0"], f.stderr["R0"], f.rms_rel_residual)
        vals = [v[0] for v in r0.values()]
        lines.append(f"re={re}: " + "; ".join(f"{s} {v:.3f}+/-{e:.3f} ohm (rms {100 * q:.2f} %)"
                                               for s, (v, e, q) in r0.items())
                     + f" | spread {min(vals):.3f}..{max(vals):.3f} = {max(vals) - min(vals):.3f} ohm")
    text = "\n".join(lines) + "\n"
    print(text)
    OUT.write_text("scripts/ts_realdata.py\n" + text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
