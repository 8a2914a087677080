"""Reference columns beside a T/S result: the model-free values read off the curve (Small's
method, :mod:`~bayes_emt.thiele_small.model_free`) and the bench's own fit when the recording
carries one (``meas.meta["bench_fit"]``, written by the readers of bench exports that hold one).

The bench's fit record: ``{"bench": "DATS" | "Klippel LPM" | ..., "source": file, "values": {name:
float in SI}}`` with the names and units of :data:`~bayes_emt.thiele_small.relations.UNITS`
(values of 0, "not computed", are left out by the reader), optionally ``"curve": {"f_hz": [...],
"abs_z_ohm": [...]}``. Each of its values is compared with ours: the difference
``100 (bench − ours) / ours`` [%] and whether it lies inside our 90 % interval.

A disagreement between the model and the model-free value beyond both 90 % intervals is reported
as a ``model_free_disagrees`` warning: it is information about the driver or the model (a
frequency-dependent suspension, creep, widens the peak; a lossy coil shifts the phase zero; a box
or a baffle adds a spring), not an error of either.
"""

from __future__ import annotations

import math

from .relations import DISPLAY, UNITS

__all__ = ["bench_comparison", "model_free_record", "disagreements", "bench_model_free_notes",
           "COMPARED_MODEL_FREE", "BENCH_MODEL_FREE_TOLERANCE"]

#: a bench's fs or Qms further than this (relative) from the curve's model-free value gets a line
BENCH_MODEL_FREE_TOLERANCE = 0.03

#: the model-free quantities compared with the model's (the others, Zmax, f1, f2, are shown only)
COMPARED_MODEL_FREE = ("fs", "Qms", "Qes", "Qts", "Mms", "Cms", "Bl")


def bench_comparison(parameters: dict, bench_fit: dict | None) -> dict | None:
    """The bench's values beside ours: ``{"bench", "source", "values": {name: {"bench", "ours",
    "difference_pct", "inside_ci90"}}}`` (SI; ``inside_ci90`` None without our interval), or None
    when there is no bench fit. Names we do not report are kept with ``ours`` None."""
    if not bench_fit or not isinstance(bench_fit, dict):
        return None
    rows = {}
    for name, v in (bench_fit.get("values") or {}).items():
        try:
            b = float(v)
        except (TypeError, ValueError):
            continue
        if name not in UNITS or not math.isfinite(b) or b == 0:
            continue
        p = parameters.get(name)
        ours = None if p is None else p.get("value")
        ci = None if p is None else p.get("ci90")
        diff = None if ours in (None, 0) else 100.0 * (b - ours) / ours
        inside = None if ci is None else bool(ci[0] <= b <= ci[1])
        rows[name] = {"bench": b, "ours": ours, "difference_pct": diff, "inside_ci90": inside}
    out = {"bench": str(bench_fit.get("bench", "bench")), "source": str(bench_fit.get("source", "")),
           "values": rows}
    if isinstance(bench_fit.get("curve"), dict):
        out["curve"] = bench_fit["curve"]
    return out


def model_free_record(meas, parameters: dict, model_label: str, re_meter=None, loaded=(), seed: int = 0,
                      use_phase: bool = True, re_meter_source: str = "ohmmeter reading") -> dict:
    """The ``model_free`` entry of a T/S result: the :class:`~.model_free.ModelFree` record, or
    ``{"refused": reason}`` where Small's method is undefined. Re is the ohmmeter reading when
    given (``re_meter_source`` says what it is), else the model's R0 (median, its 90 % interval as
    ±1.645 sd)."""
    from .definitional import half_width_sd
    from .model_free import ModelFreeUndefined, model_free_ts

    if re_meter is not None:
        re, source = (float(re_meter.value), float(re_meter.sd)), re_meter_source
    else:
        p = parameters.get("Re")
        if p is None:
            return {"refused": "no Re to read r0 = Zmax/Re against"}
        re, source = (float(p["value"]), half_width_sd(p.get("ci90"))), f"model R0 ({model_label})"
    try:
        return model_free_ts(meas, re, re_source=source, loaded=loaded, seed=seed,
                             use_phase=use_phase).to_json_dict()
    except (ModelFreeUndefined, ValueError) as exc:
        return {"refused": str(exc)}


def disagreements(parameters: dict, model_free: dict | None, spread_included: bool = True) -> list[dict]:
    """``model_free_disagrees`` warnings: the quantities whose model value and model-free value
    are apart by more than both 90 % intervals (the intervals do not overlap)."""
    if not model_free or "parameters" not in model_free:
        return []
    out = []
    for name in COMPARED_MODEL_FREE:
        p, q = parameters.get(name), model_free["parameters"].get(name)
        if not p or not q or p.get("ci90") is None or q.get("ci90") is None:
            continue
        (a0, a1), (b0, b1) = p["ci90"], q["ci90"]
        if a1 < b0 or b1 < a0:
            unit, f = DISPLAY[name]
            u = f" {unit}" if unit else ""
            diff = 100.0 * (q["value"] - p["value"]) / p["value"]
            short = (f"model-free {name} {q['value'] * f:.4g}{u} and the model's {p['value'] * f:.4g}{u} "
                     "differ by "
                     f"{diff:+.1f} %, beyond both methods' own 90 % intervals")
            note = " (ci90 includes this spread: definitional uncertainty)" if spread_included else ""
            out.append({"code": "model_free_disagrees", "short": short,
                        "message": short + note + ": information, not an error (creep or a "
                        "frequency-dependent suspension widens the peak, a lossy coil moves the phase "
                        "zero, a box or baffle adds stiffness; Small's method assumes a plain "
                        "mass-spring-damper)"})
    return out


def bench_model_free_notes(meas, model_free: dict | None, bench_fit: dict | None, *, use_phase: bool = True,
                           seed: int = 0) -> list[dict]:
    """One ``bench_model_free_differ`` line for each of fs and Qms where the bench's value is more
    than :data:`BENCH_MODEL_FREE_TOLERANCE` from Small's value off the same curve, saying what
    explains it: the curve read with the bench's own Re (Qms depends on Re through r0), a split
    peak, and otherwise the bench's model fit (its fs and Qms are its model's, not the peak's)."""
    from .model_free import ModelFreeUndefined, model_free_ts

    if not model_free or "parameters" not in model_free or not bench_fit:
        return []
    vals = bench_fit.get("values") or {}
    name_b = str(bench_fit.get("bench", "the bench"))
    out = []
    for name in ("fs", "Qms"):
        b, q = vals.get(name), model_free["parameters"].get(name)
        if not b or q is None or abs(q["value"] / b - 1) <= BENCH_MODEL_FREE_TOLERANCE:
            continue
        why = []
        re_b = vals.get("Re")
        if name == "Qms" and re_b:
            try:
                alt = model_free_ts(meas, float(re_b), re_source=f"{name_b} Re", n_draws=20, seed=seed,
                                    use_phase=use_phase)["Qms"]
                why.append(f"with {name_b}'s own Re {float(re_b):.4g} ohm the curve gives {alt:.4g} "
                           f"({100 * (b / alt - 1):+.1f} %)")
            except (ModelFreeUndefined, ValueError):
                pass
        why += [n for n in model_free.get("inputs", {}).get("notes", []) if n.startswith("split")]
        if not why or name == "fs":
            what = "phase zero" if name == "fs" else "peak width"
            why.append(f"{name_b}'s {name} is its model fit's, not the {what} of the curve")
        short = (f"{name_b}'s {name} {b:.4g} is {100 * (b / q['value'] - 1):+.1f} % from the curve's "
                 f"model-free {q['value']:.4g}: " + "; ".join(why))
        out.append({"code": "bench_model_free_differ", "short": short, "message": short})
    return out
