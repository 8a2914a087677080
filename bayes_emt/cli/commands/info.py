"""``bayes-emt info DATA``: what a measurement file holds.

Reads the file as every other command does (so it is also the quickest check that a file reads,
and under which units), then prints the point count, the frequency range in Hz and rad/s, the
|Z| range in ohm and the mechanical resonance (:func:`bayes_emt.estimation.checks.locate_resonance`).
"""

from __future__ import annotations

import math

from ._common import add_data_args, add_output_args, add_parser, detail, note

EXAMPLES = """\
bayes-emt info speaker.zma
bayes-emt info lcr_export.csv --freq-unit hz --phase-unit rad
bayes-emt info analyser.s1p --verbose
"""


def register(sub) -> None:
    p = add_parser(sub, "info", help="what a measurement file holds (points, ranges, resonance)",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("data", help="measurement file (.zma, CSV/TSV with header, .s1p)")
    add_data_args(p)
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ...estimation.checks import locate_resonance
    from ...io import read_measurement

    meas = read_measurement(args.data, freq_unit=args.freq_unit, phase_unit=args.phase_unit,
                            quantity=args.quantity,
                            magnitude_only=args.magnitude_only).select(args.omega_min, args.omega_max)
    m = meas.meta
    rep = {"magphase": "magnitude and phase", "reim": "real and imaginary parts",
           "dbphase": "dB and phase"}.get(m.get("representation"), m.get("representation"))
    units = "; ".join(f"{k.replace('_', ' ')} {m.get(k)} (from {v})"
                      for k, v in m.get("units_from", {}).items())
    note(args, f"file        {meas.source}  ({m.get('format')})")
    note(args, f"read as     {m.get('quantity')}, {rep}" + (f"; {units}" if units else ""))
    for key in sorted(k for k in m if k not in ("notices", "units_from")):
        detail(args, f"meta        {key}: {m[key]}")
    for text in m.get("notices", ()):
        print(f"notice      {text}")
    print(f"points      {meas.n_points}")
    print(f"frequency   {meas.f_hz[0]:.5g} .. {meas.f_hz[-1]:.5g} Hz  "
          f"({meas.omega[0]:.5g} .. {meas.omega[-1]:.5g} rad/s)")
    absz = abs(meas.Z)
    print(f"|Z|         {absz.min():.5g} .. {absz.max():.5g} ohm")
    res = locate_resonance(meas)
    if res is None:
        print("resonance   none found in this band (zeta, omega0, phi not identifiable)")
    else:
        print(f"resonance   {res.omega / (2 * math.pi):.5g} Hz ({res.omega:.5g} rad/s), "
              f"|Z| = {absz[res.index]:.5g} ohm")
    if meas.phase_absent:
        print("phase       absent: |Z| only, fitted on log|Z| "
              "(the phase shown by plots is a minimum-phase estimate)")
    bench = m.get("bench_fit")
    if bench:
        print(f"bench fit   {_bench_line(bench)}")
    return 0


def _bench_line(bench: dict) -> str:
    """The bench's own fit in display units: ``DATS: fs 25.07 Hz, Re 4.2 Ω, ...``."""
    from ...thiele_small.relations import DISPLAY

    parts = []
    for name, value in bench.get("values", {}).items():
        unit, factor = DISPLAY.get(name, ("", 1.0))
        parts.append(f"{name} {value * factor:.4g}{' ' + unit if unit else ''}")
    curve = bench.get("curve")
    if curve and curve.get("f_hz"):
        parts.append(f"fitted |Z| curve of {len(curve['f_hz'])} points")
    return f"{bench.get('bench')}: " + (", ".join(parts) or "no values")
