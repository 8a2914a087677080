"""T/S parameters of the real Dayton Audio LS10-44 added-mass pair, and what an ohmmeter reading
does to R0 (issue 22, acceptance 2 and 4).

Data: ``../shared/realdata/dayton_LS10-44_freeair_run2.txt`` and ``..._added100g_run2.txt``
(Δm = 0.100 kg, phase in radians), 10 Hz–1 kHz; Sd = 0.0363 m² (the value the data's source
repository, yankz12/audiolib-elac ``test/test_z.py``, uses). The "meter" reading is the file's
own lowest point, Re Z(1 Hz) = 7.40 Ω (outside the fitted band; the motional part there is
below 0.01 Ω).

    .venv/bin/python scripts/ts_realdata.py          # about 7 minutes; writes scripts/results/ts_ls10_44.txt

The reading counts as a cut (the default: R0 from the reading alone, the rest fitted at it) or as a
prior (Bayes' rule with the data); both are shown.

Comparison with the manufacturer's published values (issue 22, acceptance 2):
:data:`bayes_emt.thiele_small.published.LS10_44` (Dayton Audio's product page and spec sheet,
source cited there; coils in series, as in these recordings: Re Z(1 Hz) = 7.40 Ω = the published
Re). Compared: the pair's UD posterior (no reading) and a free-air UD posterior of the other
LS10-44 sample, ``dayton_LS10-44.zma`` (10 Hz-20 kHz), without and with the published Re as a
0.25 % ohmmeter reading (a cut, the default).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from bayes_emt.io import read_measurement
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.published import LS10_44, LS10_44_SOURCE
from bayes_emt.thiele_small.relations import DISPLAY

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
    results = {}
    for fast in (True, False):
        for re in (None, (meter, 0.01 * meter, "cut"), (meter, 0.01 * meter, "prior")):
            r = thiele_small(free_path, "UD", loaded=loaded, sd=SD, re=re, fast=fast, seed=0,
                             f_range_hz=BAND, read_options=OPTS)
            results[fast, None if re is None else re[2]] = r
            lines.append(f"\n--- ts UD, {'fast' if fast else 'posterior'}, re={re}")
            lines += r.summary().splitlines()
            sp = r.inputs["model_spread"]
            probs = ", ".join(f"{m['model']} rms {100 * m['rms_rel_residual']:.2f} % "
                              f"P {'-' if m['probability'] is None else format(m['probability'], '.3g')}"
                              f"{' undetermined ' + ','.join(m['undetermined']) if m['undetermined'] else ''}"
                              for m in sp["models"])
            lines.append(f"model spread over {sp['included']} ({probs})")
            lines += [f"warning [{w['code']}]: {w['message']}" for w in r.warnings
                      if w["code"] == "re_conflict"]
    lines.append("\n--- R0 across coil models (least squares, free-air recording), with and without the "
                 "reading: every candidate, then the model spread's rule (adequate, determined, probable)")
    for re in (None, (meter, 0.01 * meter, "cut"), (meter, 0.01 * meter, "prior"),
               (meter, 0.0025 * meter, "prior")):
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
    lines += _published_comparison(results[False, None])
    text = "\n".join(lines) + "\n"
    print(text)
    OUT.write_text("scripts/ts_realdata.py\n" + text, encoding="utf-8")
    return 0


def _published_comparison(pair) -> list[str]:
    """The published set beside the pair's posterior, the other sample's free-air posterior, and
    that one again with the published Re as a tight ohmmeter reading (7.4 ohm, sd 0.25 %);
    relative differences in %."""
    zma = REAL / "dayton_LS10-44.zma"
    other = thiele_small(zma, "UD", seed=0, f_range_hz=(10.0, 20000.0))
    metered = thiele_small(zma, "UD", seed=0, f_range_hz=(10.0, 20000.0), models_for_spread=[],
                           re=(LS10_44["Re"], 0.0025 * LS10_44["Re"]))
    cols = [("run2 pair, UD posterior", pair), (".zma free air, UD posterior", other),
            (".zma, --re 7.4:0.0185", metered)]
    lines = [f"\n--- published values ({LS10_44_SOURCE})",
             f"{'parameter':<10} {'published':<10} " + " ".join(f"{h:<36} {'diff':<8}" for h, _ in cols)
             + " unit"]
    for name in ("fs", "Re", "Le", "Qms", "Qes", "Qts", "Bl", "Mms", "Cms", "Vas"):
        unit, f = DISPLAY[name]
        cells = [f"{name:<10} {LS10_44[name] * f:<10.4g}"]
        for _, r in cols:
            q = r.parameters.get(name)
            if q is None:
                cells.append(f"{'-':<36} {'':<8}")
                continue
            lo, hi = q["ci90"]
            txt = f"{q['value'] * f:.4g} ({lo * f:.4g}..{hi * f:.4g})"
            cells.append(f"{txt:<36} {100 * (q['value'] / LS10_44[name] - 1):<+7.1f}%")
        lines.append(" ".join(cells) + f" {unit}")
    lines.append(f"(.zma free air: model spread over {other.inputs['model_spread']['included']}; "
                 f"Sd here {SD} m^2, published {LS10_44['Sd']} m^2)")
    return lines


if __name__ == "__main__":
    raise SystemExit(main())
