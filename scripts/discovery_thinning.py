"""The diagnosis of the dense LS10-44 run2 recordings with every point and thinned to the search's
default density (issue 23, speed): wall and CPU seconds (this process and its worker processes),
the ratio to one UD fit of the same file (the best of three, same run), the final model, the
findings and R0, for ``diagnose(per_decade=None)`` and ``diagnose()`` (at most
:data:`bayes_emt.discovery.diagnose.SEARCH_PER_DECADE` points per decade) one after the other::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/discovery_thinning.py \\
        scripts/results/discovery_realdata/thinning.json

Skipped (exit 0, a message) when ../shared/realdata is absent. Minutes: the unthinned free-air
diagnosis alone takes about 2 min on a quiet 2-core machine.
"""

from __future__ import annotations

import json
import resource
import sys
import time
import warnings
from pathlib import Path

from bayes_emt._atomic import atomic_write_text
from bayes_emt.discovery import diagnose
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io.datasets import load_realdata
from bayes_emt.models import parse_model_spec

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
FILES = ("dayton_LS10-44_added100g_run2.txt", "dayton_LS10-44_freeair_run2.txt")


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main(out: Path) -> int:
    if not REAL.is_dir():
        print(f"{REAL} is absent: nothing to do")
        return 0
    rows = {}
    warnings.simplefilter("ignore")
    for name in FILES:
        meas = load_realdata(REAL, name)
        ud = []
        for _ in range(3):
            t = time.perf_counter()
            fit_admittance(meas, parse_model_spec("UD"))
            ud.append(time.perf_counter() - t)
        for per_decade in (None, "default"):
            kw = {} if per_decade == "default" else {"per_decade": None}
            t, c, c0 = time.perf_counter(), time.process_time(), _children_cpu()
            d = diagnose(meas, None, seed=0, **kw)
            wall, cpu = time.perf_counter() - t, time.process_time() - c + _children_cpu() - c0
            row = {"wall_s": wall, "cpu_s": cpu, "ud_fit_s": min(ud), "ratio": wall / min(ud),
                   "search_points": d.search_points, "final_model": d.final_model,
                   "findings": [f.physics for f in d.findings], "R0_ohm": d.final_fit.parameters["R0"],
                   "budget_hit": d.budget_hit}
            rows[f"{name}, per_decade={d.search_points['per_decade']}"] = row
            print(name, json.dumps(row), flush=True)
    atomic_write_text(out, json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("thinning.json")))
