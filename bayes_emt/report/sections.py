"""One context record per report section, built from a run folder's saved outputs.

Each section is a dict ``{"id", "title", "ran", "absent", ...}``: ``ran`` says whether its outputs
exist, ``absent`` says in plain words what was not run (or why) when they do not. Nothing here
computes a result: the numbers are those the commands saved, with the units they saved.
"""

from __future__ import annotations

import math

from . import layout as L
from .load import RunFiles, finite, normalise_warning

__all__ = ["collect_sections", "collect_warnings"]

TWO_PI = 2.0 * math.pi


def _section(sid: str, title: str, ran: bool, absent: str = "", **content) -> dict:
    return {"id": sid, "title": title, "ran": bool(ran), "absent": "" if ran else absent, **content}


def _step_note(run: dict | None, step: str, default: str) -> str:
    """The demo's own words for why ``step`` did not run (``run.json`` ``steps``), else ``default``."""
    for s in (run or {}).get("steps", []):
        if s.get("name") == step and s.get("status") != "ran":
            return f"Not run: {s.get('detail') or s.get('status')}."
    return default


def data_section(rf: RunFiles, run: dict | None) -> dict:
    recs = (run or {}).get("data", [])
    ok = bool(recs)
    return _section("data", "Data", ok, "No data summary was saved (run.json absent).", recordings=recs)


def fits_section(rf: RunFiles, run: dict | None) -> dict:
    fits = rf.json(L.FITS)
    hankel = rf.json(L.HANKEL)
    if not isinstance(fits, dict) or not fits:
        return _section("fits", "Least-squares fits", False,
                        _step_note(run, "fit", "Not run: no fits.json and no fit --json output in this "
                                   "folder."))
    names: list[str] = []
    units: dict[str, str] = {}
    for rec in fits.values():
        for n in rec.get("parameters", {}):
            if n not in names:
                names.append(n)
        units.update(rec.get("units", {}))
    rows = []
    for model, rec in fits.items():
        p, se = rec.get("parameters", {}), rec.get("stderr", {}) or {}
        rows.append({"model": model, "rms_pct": 100.0 * rec["rms_rel_residual"]
                     if finite(rec.get("rms_rel_residual")) else None,
                     "values": [(p.get(n), se.get(n)) for n in names], "success": rec.get("success", True)})
    best = min((r for r in rows if r["rms_pct"] is not None), key=lambda r: r["rms_pct"], default=None)
    return _section("fits", "Least-squares fits", True, names=names, units=[units.get(n, "") for n in names],
                    rows=rows, best=best["model"] if best else None, hankel=hankel,
                    residuals=rf.image(L.RESIDUALS_PNG))


def posterior_section(rf: RunFiles, run: dict | None) -> dict:
    post = rf.json(L.POSTERIOR_JSON)
    if not isinstance(post, dict):  # a sample --out netCDF file alone: its summary, read from it
        post = _posterior_summary(rf)
    # the demo's names, else the figures sample --plot wrote (posterior_<model>_bode.png, ...)
    bode = rf.image(L.POSTERIOR_BODE) or rf.glob_image("posterior_*_bode.png")
    corner = rf.image(L.POSTERIOR_CORNER) or rf.glob_image("posterior_*_corner.png")
    if not isinstance(post, dict) and bode is None:
        return _section("posterior", "Posterior (emcee)", False,
                        _step_note(run, "sample",
                                   "Not run: no posterior.json / posterior.nc and no sample --json "
                                   "output in this folder."))
    post = post or {}
    params = [{"name": k, **v} for k, v in post.get("parameters", {}).items()]
    derived = [{"name": k, **v} for k, v in post.get("derived", {}).items()]
    return _section("posterior", "Posterior (emcee)", True, post=post, params=params, derived=derived,
                    bode=bode, corner=corner, truth=(run or {}).get("truth") or {})


def _posterior_summary(rf: RunFiles) -> dict | None:
    """The ``sample --json`` summary of the folder's posterior netCDF file, when no JSON summary
    was saved (``None`` when there is no such file; a problem line when it cannot be read)."""
    from .figures import posterior_nc

    if "posterior_summary" in rf.cache:  # read once per report
        return rf.cache["posterior_summary"]
    rf.cache["posterior_summary"] = None
    nc = posterior_nc(rf.root)
    if nc is None:
        return None
    from ..api import read_posterior

    try:
        post = read_posterior(nc)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        rf.problems.append(f"{nc}: could not be read as a posterior ({first})")
        return None
    rec = post.to_json_dict()
    if not post.converged:
        rec["warnings"] = [{"code": "not_converged", "message": post.message}]
    rf.cache["posterior_summary"] = rec
    return rec


def evidence_section(rf: RunFiles, run: dict | None) -> dict:
    cmp = rf.json(L.COMPARISON)
    if not isinstance(cmp, dict) or not cmp.get("models"):
        return _section("evidence", "Model comparison by evidence", False,
                        _step_note(run, "compare", "Not run: no comparison.json and no compare --json "
                                   "output in this folder."))
    methods = [m for m in ("nested", "bridge", "laplace")
               if any(m in x.get("by_method", {}) for x in cmp["models"])]
    rows = []
    for m in cmp["models"]:
        cells = []
        for k in methods:
            v = m.get("by_method", {}).get(k) or {}
            cells.append((v.get("log_evidence"), v.get("err")))
        rows.append({"name": m["name"], "k": m.get("n_params"), "logz": m.get("log_evidence"),
                     "err": m.get("log_evidence_err"), "cells": cells, "loo": m.get("elpd_loo"),
                     "loo_se": m.get("elpd_loo_se"), "seconds": m.get("evidence_seconds")})
    pairs = [{"pair": k, **v} for k, v in (cmp.get("bayes_factor_details") or {}).items()]
    return _section("evidence", "Model comparison by evidence", True, cmp=cmp, methods=methods, rows=rows,
                    pairs=pairs, chart=rf.image(L.EVIDENCE_PNG))


def shunt_section(rf: RunFiles, run: dict | None) -> dict:
    shunts = rf.json(L.SHUNTS)
    if not isinstance(shunts, dict) or not shunts:
        return _section("shunt", "RC shunt per model", False,
                        _step_note(run, "shunt", "Not run: no shunts.json and no shunt --json output in "
                                   "this folder."))
    rows = []
    for model, d in shunts.items():
        ev = next((v for k, v in d.items() if k.startswith("evaluated_on_")), None)
        on = next((k[len("evaluated_on_"):] for k in d if k.startswith("evaluated_on_")), None)
        if ev is None and isinstance(d.get("evaluated_on"), dict):  # shunt --evaluate-on's record
            ev, on = d["evaluated_on"], str(d["evaluated_on"].get("params", ""))
        rows.append({"model": model, "Rs": d.get("Rs"), "Cs": d.get("Cs"), "att": d.get("attenuation_db"),
                     "on": on, "ev": ev or {}})
    figs = [(cap, rf.glob_image(pat)) for pat, cap in
            (("shunt_*_receptance.png", "receptance without and with the shunt against frequency [Hz]"),
             ("shunt_*_attenuation_map.png", "attenuation over the (Rs, Cs) plane around the optimum"))]
    return _section("shunt", "RC shunt per model", True, rows=rows,
                    figures=[(c, uri) for c, uri in figs if uri])


def robust_section(rf: RunFiles, run: dict | None) -> dict:
    rob = rf.json(L.ROBUST)
    figs = [(cap, rf.image(name)) for name, cap in L.ROBUST_PNGS]
    figs = [(c, uri) for c, uri in figs if uri]
    if not isinstance(rob, dict) or "robust" not in rob:
        return _section("robust", "Robust shunt over the posterior", False,
                        _step_note(run, "robust_shunt", "Not run: no robust_shunt.json in this folder "
                                   "(bayes-emt shunt --posterior RUN.nc --json robust_shunt.json)."))
    designs = [{"name": n, **rob[n]} for n in ("nominal", "robust") if isinstance(rob.get(n), dict)]
    per_draw = [{"name": n, "unit": u, **(rob.get("per_draw", {}).get(n) or {})}
                for n, u in (("Rs", "Ω"), ("Cs", "F"), ("attenuation_db", "dB"))]
    return _section("robust", "Robust shunt over the posterior", True, rob=rob, designs=designs,
                    per_draw=per_draw, figures=figs, why=(rob.get("why") or {}).get("text"),
                    r0=(rob.get("r0") or {}).get("statement"), driver=_driver_rows(rob),
                    bound=_bound_text(rob))


def _driver_rows(rob: dict) -> list[dict]:
    """Rows ``(what, resonance [Hz], Q, peak reduction [dB])``, each a summary (median, q05, q95)
    or None: the driver on open terminals and on a zero-impedance source, then each shunt."""
    drv = rob.get("driver") or {}
    if not drv:
        return []
    rows = [{"what": "driver, open terminals", "q_name": "Qms", "hz": drv.get("fs_hz"), "q": drv.get("qms"),
             "red": None},
            {"what": "driver, zero-impedance source", "q_name": "Qts", "hz": drv.get("resonance_hz"),
             "q": drv.get("qts"), "red": None}]
    for n in ("nominal", "robust"):
        d = rob.get(n) or {}
        rows.append({"what": f"{n} shunt", "q_name": "Qts'", "hz": d.get("damped_resonance_hz"),
                     "q": d.get("qts_damped"), "red": d.get("resonance_peak_reduction_db")})
    return rows


def _bound_text(rob: dict) -> str | None:
    b = (rob.get("robust") or {}).get("p_unstable_bound")
    if not isinstance(b, dict) or not b.get("per_model"):
        return None
    parts = "; ".join(f"{lb}: {v['n_unstable']} of {v['n_checked']} unstable, "
                      f"P(unstable) ≤ {v['upper_bound']:.3g}" for lb, v in b["per_model"].items())
    need = ("no finite number of draws shows it" if b.get("draws_needed") is None else
            f"showing it needs {b['draws_needed']} such draws, none unstable")
    verdict = "shown" if b.get("shown") else "not shown"
    return (f"P(unstable) ≤ {b['epsilon']:g} is {verdict} for the robust shunt on the draws its choice "
            f"never saw ({parts}; {100 * b['confidence']:.0f} % one-sided exact binomial bound; {need}).")


def diagnosis_section(rf: RunFiles, run: dict | None) -> dict:
    diag = rf.json(L.DIAGNOSIS)
    resid = rf.image(L.DIAGNOSIS_RESIDUALS)
    figs = []
    bode = rf.image("diagnosis_bode.png")  # diagnose --plot DIR, DIR the run folder
    if bode:
        figs.append(("diagnosis bode", bode))
    folder = rf.path(L.DIAGNOSIS_DIR)
    if folder.is_dir():
        for p in sorted(folder.glob("*.png")):
            uri = rf.image(p)
            if uri:
                figs.append((p.stem.replace("_", " "), uri))
    if not isinstance(diag, dict):
        return _section("diagnosis", "Discrepancy diagnosis", False,
                        _step_note(run, "diagnose", "Not run: no diagnosis.json in this folder "
                                   "(bayes-emt diagnose DATA --json diagnosis.json)."), residuals=resid)
    findings = []
    units = _fit_units(rf)
    for f in diag.get("findings", []):
        band_hz = f.get("band_hz")
        band_rad = f.get("band_rad_s")
        if band_hz is None and band_rad:
            band_hz = [b / TWO_PI for b in band_rad]
        findings.append({**f, "band_hz": band_hz, "band_rad_s": band_rad,
                         "param_rows": _param_rows(f.get("parameters") or {}, units)})
    unexplained = []
    for u in diag.get("unexplained", []):
        band = u.get("band_rad_s")
        unexplained.append({**u, "band_hz": [b / TWO_PI for b in band] if band else None})
    return _section("diagnosis", "Discrepancy diagnosis", True, diag=diag, findings=findings,
                    unexplained=unexplained, rms=diag.get("rms_rel_residual") or {}, residuals=resid,
                    figures=figs, recording=(run or {}).get("diagnosed"))


#: quantities a diagnosis reports that carry no unit field but are dimensionless
_DIMENSIONLESS = {"zeta", "Qms", "Qes", "Qts", "zeta2", "zetab", "relative_change"}


def _fit_units(rf: RunFiles) -> dict[str, str]:
    units: dict[str, str] = {}
    fits = rf.json(L.FITS)
    if isinstance(fits, dict):
        for rec in fits.values():
            if isinstance(rec, dict):
                units.update(rec.get("units") or {})
    return units


def _unit_of(name: str, entry, units: dict[str, str]) -> str:
    if isinstance(entry, dict) and entry.get("unit"):
        return str(entry["unit"])
    if name in units:
        return units[name]
    if name.endswith("_hz"):
        return "Hz"
    if name.endswith("_rad_s"):
        return "rad/s"
    return "1" if name in _DIMENSIONLESS else ""


def _param_rows(params: dict, units: dict[str, str], group: str = "") -> list[dict]:
    """A diagnosis finding's ``parameters`` as flat rows ``{group, name, value, stderr, before,
    after, relative_change, unit}``: the diagnosis schema leaves their layout open (a number, a
    ``{value, stderr, unit}`` record, or groups of those such as ``added`` / ``moved``)."""
    rows = []
    for name, v in params.items():
        if isinstance(v, dict) and not any(k in v for k in ("value", "median", "before", "after")):
            rows += _param_rows(v, units, group=name)
            continue
        rec = v if isinstance(v, dict) else {"value": v}
        rows.append({"group": group, "name": name, "unit": _unit_of(name, rec, units),
                     "value": rec.get("value", rec.get("median")), "stderr": rec.get("stderr"),
                     "before": rec.get("before"), "after": rec.get("after"),
                     "relative_change": rec.get("relative_change")})
    return rows


def ts_section(rf: RunFiles, run: dict | None) -> dict:
    """The Thiele–Small table: ``ts.json`` if saved (values, 90 % intervals, model spread), else
    the free-air set at the best least-squares fit (Small 1972 relations, no intervals)."""
    from ..thiele_small import read_thiele_small
    from ..thiele_small.relations import DISPLAY, NAMES, free_air

    rec = rf.json(L.TS)
    if isinstance(rec, dict) and "parameters" in rec:
        try:
            ts = read_thiele_small(rec)
        except Exception as exc:  # noqa: BLE001 - a bad file is reported, the report still renders
            rf.problems.append(f"{L.TS}: {exc}")
        else:
            # the model-free and bench columns beside ours when the record carries them
            rows = [r[:4] + ts.reference_cells(r[0]) + r[4:] for r in ts.rows()]
            head = ("parameter", "value", "90 % interval", "model spread", *ts.reference_head(), "unit")
            return _section("ts", "Thiele–Small parameters", True, rows=rows, head=head, model=ts.model,
                            method=ts.method.replace("_", " "), intervals=True,
                            uncertainty=ts.inputs.get("uncertainty", "posterior"),
                            figure=_ts_figure(rf, ts) or rf.glob_image("ts_fit.png"),
                            notes=ts.reference_notes())
    fits = rf.json(L.FITS)
    if isinstance(fits, dict) and fits:
        from ..io.paramfile import model_from_record

        ok = {m: r for m, r in fits.items() if finite(r.get("rms_rel_residual"))}
        if ok:
            best = min(ok, key=lambda m: ok[m]["rms_rel_residual"])
            try:
                model, theta = model_from_record(ok[best], where=f"{L.FITS}: {best}")
                vals = free_air(model, theta[None, :])
            except Exception as exc:  # noqa: BLE001
                rf.problems.append(f"{L.FITS}: {best}: no T/S set ({exc})")
            else:
                rows = [(n, f"{float(vals[n][0]) * DISPLAY[n][1]:.4g}", "-", "-", DISPLAY[n][0])
                        for n in NAMES if n in vals]
                return _section("ts", "Thiele–Small parameters", True, rows=rows, model=best,
                                method="free air, best least-squares fit", intervals=False, uncertainty="")
    return _section("ts", "Thiele–Small parameters", False,
                    "Not run: no ts.json and no fit to derive the free-air set from.")


def _ts_figure(rf: RunFiles, ts) -> str | None:
    """The T/S fit figure (the one ``ts --plot`` writes) drawn in memory from the result's saved
    curve, as a data URI (nothing is written into the folder); ``None`` without a curve."""
    if not ts.curve:
        return None
    import base64
    import io

    from ..plotting.thiele_small import plot_ts_fit

    try:
        fig = plot_ts_fit(ts)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=90)
    except (ValueError, KeyError, TypeError) as exc:
        rf.problems.append(f"T/S: the fitted curve could not be drawn ({exc})")
        return None
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def collect_sections(rf: RunFiles, run: dict | None) -> list[dict]:
    """Every section, in reading order (the Thiele–Small table first)."""
    return [ts_section(rf, run), data_section(rf, run), fits_section(rf, run), evidence_section(rf, run),
            posterior_section(rf, run), shunt_section(rf, run), robust_section(rf, run),
            diagnosis_section(rf, run)]


def collect_warnings(rf: RunFiles, run: dict | None) -> list[dict]:
    """Every warning the saved outputs carry, with the output it came from (shown on top)."""
    out = [normalise_warning(w, "demo") for w in (run or {}).get("warnings", [])]
    fits = rf.json(L.FITS)
    if isinstance(fits, dict):
        for model, rec in fits.items():
            out += [normalise_warning(w, f"fit {model}") for w in rec.get("warnings", [])]
            if rec.get("success") is False:
                out.append(normalise_warning(f"the optimiser did not converge: {rec.get('message')}",
                                             f"fit {model}"))
    cmp = rf.json(L.COMPARISON)
    if isinstance(cmp, dict):
        out += [normalise_warning(w, "evidence") for w in cmp.get("warnings", [])]
    post = rf.json(L.POSTERIOR_JSON)
    if not isinstance(post, dict):
        post = _posterior_summary(rf)
    if isinstance(post, dict):
        if post.get("converged") is False:
            out.append(normalise_warning(f"the posterior did NOT converge: {post.get('message')}; its "
                                         "intervals are not to be trusted", "posterior"))
        out += [normalise_warning(w, "posterior") for w in post.get("warnings", [])]
    for name, src in ((L.ROBUST, "robust shunt"), (L.DIAGNOSIS, "diagnosis")):
        rec = rf.json(name)
        if isinstance(rec, dict):
            out += [normalise_warning(w, src) for w in rec.get("warnings", [])]
    ts = rf.json(L.TS)
    if isinstance(ts, dict):
        out += [normalise_warning(w, "T/S") for w in ts.get("warnings", [])]
    # one entry per (code, band, short hint): the same finding about several models or outputs is
    # listed once with its sources; the full texts stay available under it
    from .._warnlines import group_warnings

    return [{"source": ", ".join(g["sources"]), "code": g["code"], "band": g["band"].strip(),
             "message": g["short"], "full": g["messages"]} for g in group_warnings(out)]
