"""T/S parameters of the real Dayton Audio LS10-44 added-mass pair, and what an ohmmeter reading
does to R0 (issue 22, acceptance 2 and 4).

Data: ``../shared/realdata/dayton_LS10-44_freeair_run2.txt`` and ``..._added100g_run2.txt``
(Δm = 0.100 kg, phase in radians), 10 Hz–1 kHz; Sd = 0.0363 m² (the value the data's source
repository, yankz12/audiolib-elac ``test/test_z.py``, uses). The "meter" reading is the file's
own lowest point, Re Z(1 Hz) = 7.40 Ω (outside the fitted band; the motional part there is
below 0.01 Ω).

    .venv/bin/python scripts/ts_realdata.py          # about 3 minutes; writes scripts/results/ts_ls10_44.txt

No comparison with the manufacturer's published values (issue 22, acceptance 2): they were not
found in the searchable sources. The audioXpress review "Test Bench: Dayton Audio LS10-44 and
LS12-44 Shallow-Mount Subwoofers" (April 2016, audioxpress.com) exists, but only its first part,
without the parameter table, is stored; no Dayton/Parts Express data sheet, WinISD ``.wdr`` or
driver database with the LS10-44's values was found in code or pages. The LS10-44 has two 4-ohm
coils; Re Z(1 Hz) = 7.40 ohm here says the recording is of the two in series, so a published
per-coil Re would be compared with half of it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from bayes_emt.io import read_measurement
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
        for re in (None, (meter, 0.01 * meter)):
            r = thiele_small(free_path, "UD", loaded=loaded, sd=SD, re=re, fast=fast, seed=0,
                             f_range_hz=BAND, read_options=OPTS)
            lines.append(f"\n--- ts UD, {'fast' if fast else 'posterior'}, re={re}")
            lines += r.summary().splitlines()
            sp = r.inputs["model_spread"]
            probs = ", ".join(f"{m['model']} rms {100 * m['rms_rel_residual']:.2f} % "
                              f"P {'-' if m['probability'] is None else format(m['probability'], '.3g')}"
                              f"{' undetermined ' + ','.join(m['undetermined']) if m['undetermined'] else ''}"
                              for m in sp["models"])
            lines.append(f"model spread over {sp['included']} ({probs})")
    lines.append("\n--- R0 across coil models (least squares, free-air recording), with and without the "
                 "reading: every candidate, then the model spread's rule (adequate, determined, probable)")
    for re in (None, (meter, 0.01 * meter), (meter, 0.0025 * meter)):
        r = thiele_small(free_path, "UD", models_for_spread=["II", "III", "UD+suspension_creep"], re=re,
                         fast=True, seed=0, f_range_hz=BAND, read_options=OPTS)
        models = r.inputs["model_spread"]["models"]
        r0 = [m["values"]["Re"] for m in models]
        lines.append(f"re={re}:")
        for m in models:
            lz = "-" if m["log_evidence"] is None else f"{m['log_evidence']:.1f}"
            p = "-" if m["probability"] is None else f"{m['probability']:.3g}"
            rms = 100 * m["rms_rel_residual"]
            lines.append(f"  {m['model']:<20} R0 {m['values']['Re']:.3f} ohm  rms {rms:.2f} %  "
                         f"undetermined {m['undetermined'] or '-'}  log Z {lz}  P {p}  "
                         f"{'included' if m['included'] else 'excluded'}")
        sp = r.parameters["Re"]["model_spread"]
        lines.append(f"  every candidate: {min(r0):.3f}..{max(r0):.3f} = {max(r0) - min(r0):.3f} ohm; "
                     "model_spread: " + ("none (one model left)" if sp is None else
                                         f"{sp[0]:.3f}..{sp[1]:.3f} = {sp[1] - sp[0]:.3f} ohm"))
    text = "\n".join(lines) + "\n"
    print(text)
    OUT.write_text("scripts/ts_realdata.py\n" + text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
