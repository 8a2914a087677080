"""Recovery table of the physics catalogue (SPEC §7): for every term, data simulated from base + term
(0.2 % noise, 2000 log-spaced points over 1e1..1e5 rad/s, seed 1) are fitted with ``BASE+term`` from
the data alone; the table gives each term parameter's truth, estimate, standard error and relative
error, the rms relative residual against the noise floor, and the seconds per fit.

    .venv/bin/python scripts/catalogue_recovery.py [--out scripts/results/catalogue_recovery.txt]

The truths are those of ``tests/test_catalogue.py`` (realistic sizes for the paper's shaker, each
effect well above the noise); ``lead_impedance``'s Rl is not identifiable against R0 (SPEC §7).
"""

from __future__ import annotations

import argparse
import io
import sys
import time
import warnings
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_catalogue import CASES  # noqa: E402

from bayes_emt import build_model, simulate  # noqa: E402
from bayes_emt.estimation.fitting import fit_admittance  # noqa: E402
from bayes_emt.reference import PAPER_TABLES  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None, help="also write the table here")
    args = ap.parse_args(argv)
    buf = io.StringIO()
    with redirect_stdout(buf):
        print(f"{'term':22s} {'parameter':13s} {'truth':>11s} {'estimate':>11s} {'std err':>10s} "
              f"{'rel. err':>9s} {'rms/floor':>9s} {'seconds':>7s}")
        for term, (base, extra) in sorted(CASES.items()):
            model = build_model(f"{base}+{term}")
            truth = {**PAPER_TABLES[base], **extra}
            meas = simulate(model, truth, noise=0.002, seed=1)
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_admittance(meas, model)
            dt = time.perf_counter() - t0
            p, se = fit.parameters, fit.stderr
            floor = 0.002 * np.sqrt(2)
            for i, (name, value) in enumerate(extra.items()):
                first = i == 0
                ratio = fit.rms_rel_residual / floor if first else float("nan")
                print(f"{term if first else '':22s} {name:13s} {value:11.4g} {p[name]:11.4g} "
                      f"{se[name]:10.3g} "
                      f"{p[name] / value - 1:+9.4f} {ratio:9.3f} {dt if first else float('nan'):7.1f}")
    text = buf.getvalue().replace(" nan", "    ")
    print(text, end="")
    if args.out:
        Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
