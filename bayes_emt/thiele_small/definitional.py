"""Definitional uncertainty: the spread between the field's standard procedures for one T/S value.

A Thiele–Small parameter is defined by the lumped low-frequency model of a driver. A real driver is
not that model (creep, a lossy coil, a surround that is not a spring), so the standard procedures
give different values for the same quantity from the same curve: a full-band fit of a coil model,
Small's three-point method at the impedance peak, a bench's Re read off its lowest rows. That
difference is not noise that more points would average away; it is the uncertainty of the
quantity's definition on this driver (*definitional uncertainty*, JCGM 200:2012 (VIM) 2.27), and a
posterior that assumes one model is exact leaves it out. On the public truth corpus it is most of
the distance between our values and other benches' (the documentation's truth page).

Here it is estimated per recording and per quantity as the between-method standard deviation of the
two methods' values ``a`` (the model mixture) and ``b`` (Small's model-free value on the same
curve and Re; for Re the low-frequency plateau reading (:mod:`bayes_emt.estimation.plateau`)
against the model's R0), the random-effects ("dark uncertainty") estimate for two methods
(DerSimonian & Laird 1986; Thompson & Ellison 2011, Accred. Qual. Assur. 16:483;
:mod:`bayes_emt.estimation.dark_uncertainty`):

    τ² = max(0, (a − b)²/2 − (u_a² + u_b²)/2),

``u`` each method's own standard uncertainty (its 90 % half-width / 1.645). The question the
default interval answers is the one a user asks when comparing with a datasheet or another bench:
where does a further competent method's value of this quantity fall? Under the two-method
random-effects model that is the predictive for a new method (Higgins, Thompson & Spiegelhalter
2009, the prediction interval of a random-effects meta-analysis;
:func:`bayes_emt.estimation.dark_uncertainty.another_method`): centred on the two methods'
mid-point, spread by ``1.5 τ² + (u_a² + u_b²)/4``. The reported interval holds it and the model's
own interval together (never narrower than the model's; the value is the model's). No constant is
tuned: τ is zero when the methods agree within their own uncertainties, and the interval is then
the model's. EBP = fs/Qes takes the two relative τ in quadrature and Small's fs/Qes as its second
value. With added masses the model-free column's mass-shift Mms, Cms and Bl are the second method
for those three (``total`` only); the other quantities (Le, Vas, η0, ...) keep the model's interval.

Two parts make up ``a − b``: Small's method's own bias on a curve the model describes exactly
(``b_model − a``, ``b_model`` Small's value on the model's fitted curve: the conventions differ,
e.g. fs at zero mechanical reactance against fs at the phase zero, which a lossy coil moves) and
what the model does not explain (``b − b_model``). ``intervals="total"`` (the default) counts both,
since a second bench reports the quantity by its own convention; ``intervals="misfit"`` only the
second (``b`` replaced by ``a + b − b_model``), the spread that remains if the model's convention is
the one wanted.

The first part is a definitional uncertainty only when the model does not describe the driver: when
it does, the quantity is completely defined by the model (fs is its mechanical resonance, not the
phase zero a lossy coil moves), and Small's bias on that curve is that method's error, not a spread
of the measurand. So ``total`` counts it (and the added-mass mass-shift values, which have no model
curve to correct them by) only when the main model's free-air residual is structured, by the fit's
own calibrated test (:func:`curve_residual_structure`: the residual far above the noise the data
show, in long same-sign stretches, the criterion of the ``model_inadequate`` warning, which fired on
0 of 61 fits of the simulating model and on every real recording); otherwise ``total`` is ``misfit``
and the note says why.

fs has two model-free definitions, the phase zero and the |Z| peak (they differ by the coil's
reactance at resonance; benches that fit a model land near the peak), so for fs there are three
methods (:func:`bayes_emt.thiele_small.model_free.fs_definitions`, each with the curve's noise
alone), τ their ``k``-method estimate and the predictive their mean with ``(1 + 1/k) τ²``.
Re likewise has two readings of the recording's low-frequency plateau beside the fit's R0 (when the
bench swept that low): with the model's motional part taken off, and as the bench reads it, its
|Z| with nothing taken off (DATS's ``R(e)``; :mod:`bayes_emt.estimation.plateau`). Creep and coil
losses keep a woofer's real part rising towards DC, so the two differ by 0-2.4 % on the truth corpus's
bench exports (none on the tweeters); with
``misfit`` the raw reading, corrected by its bias on the model's curve, is the first and counts once.

On the truth corpus (16 recordings, 82 references) the default held 66/82 (80 %) at a median
half-width of 4.0 % (Re by two methods: 64/82, 4.4 %; two methods for fs: 61/82, 4.3 %; centred on
the model with sd τ, before the predictive: 53/82, 3.7 %); the model alone 4/82 at 0.6 %. Before the residual
test, on simulated drivers whose model is exact, ``total`` over-covered the model's own convention
(a lossy coil biases Small's fs and Qms: fs intervals 8-21 times the model's, every fs inside).
"""

from __future__ import annotations

import math

import numpy as np

from ..estimation.adequacy import residual_structure
from ..estimation.dark_uncertainty import (
    Z90,
    another_method,
    between_method_sd,
    between_methods_sd,
    half_width_sd,
    widen,
)

__all__ = ["Z90", "DEFINITIONAL_METHOD", "between_method_sd", "curve_residual_structure", "half_width_sd",
           "widen"]

DEFINITIONAL_METHOD = (
    "definitional uncertainty (VIM 2.27): the model's own interval together with the value a further "
    "method would report, the random-effects predictive from the model's value a and Small's model-free "
    "value b (Re: the fit's R0 and the low-frequency plateau reading): centred on (a+b)/2, variance "
    "1.5 tau^2 + (u_a^2+u_b^2)/4, tau^2 = max(0, (a-b)^2/2 - (u_a^2+u_b^2)/2) (DerSimonian-Laird for two "
    "methods; Higgins, Thompson & Spiegelhalter 2009 for the prediction); fs: the model, the phase zero and "
    "the |Z| peak as three methods (their mean, (1 + 1/k) tau^2 + sum u^2/k^2, tau^2 = max(0, s^2 - "
    "mean u^2)); Re likewise: the fit's R0 and the low-frequency plateau read with and without the model's "
    "motional part, where the recording has one")

#: the quantities Small's method gives beside the model
_COMPARED = ("fs", "Qms", "Qes", "Qts")


def _curve_impedances(curve: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(data, model)`` complex impedances [Ω] of a T/S result's ``curve`` record (|Z| and phase in
    degrees, :mod:`.curve`)."""
    def z(mag, ph):
        return np.asarray(curve[mag], float) * np.exp(1j * np.deg2rad(np.asarray(curve[ph], float)))

    return z("data_abs_z_ohm", "data_phase_deg"), z("fit_abs_z_ohm", "fit_phase_deg")


def curve_residual_structure(curve: dict | None) -> dict | None:
    """The fit's residual test (:func:`~bayes_emt.estimation.adequacy.residual_structure`) on the T/S
    result's ``curve`` record (the main model's curve against the free-air data): ``{"structured",
    "runs_z", "rho_max"}``, or ``None`` when the record has no fitted curve or too few points."""
    if not curve or "fit_abs_z_ohm" not in curve or len(curve.get("f_hz", ())) < 20:
        return None
    zd, zf = _curve_impedances(curve)
    with np.errstate(all="ignore"):
        e = (1.0 / zf - 1.0 / zd) * np.abs(zd)  # (Y_fit - Y_data)/|Y_data|, as the fit's test reads it
    if not np.all(np.isfinite(e)):
        return None
    rs = residual_structure(e)
    return {"structured": bool(rs.structured()), "runs_z": float(rs.runs_z), "rho_max": rs.rho_max}


def small_on_curve(curve: dict | None, re, *, use_phase: bool, seed: int) -> tuple[dict, dict] | None:
    """Small's method on the T/S result's ``curve`` record: ``(on the data, on the model's curve)``,
    both at the curve's frequencies with the same Re (``(value, sd)`` [Ω]); each
    ``{name: (value, u)}``, ``u`` the standard uncertainty of its resampled 90 % interval. ``None``
    when Small's method is undefined on either."""
    from ..measurement import Measurement
    from .model_free import ModelFreeUndefined, fs_definitions, model_free_ts

    if not curve or "fit_abs_z_ohm" not in curve:
        return None
    f = np.asarray(curve["f_hz"], float)
    out = []
    for z in _curve_impedances(curve):
        meas = Measurement.from_impedance(2 * math.pi * f, z)
        try:
            mf = model_free_ts(meas, re, use_phase=use_phase, n_draws=200, seed=seed)
        except (ModelFreeUndefined, ValueError):
            return None
        vals = {n: (float(q["value"]), half_width_sd(q.get("ci90"))) for n, q in mf.parameters.items()}
        try:  # fs by each of its two model-free definitions, each with its noise alone
            defs = fs_definitions(meas, use_phase=use_phase, seed=seed)
        except (ModelFreeUndefined, ValueError):
            defs = {}
        vals.update({f"fs_{k}": v for k, v in defs.items()})
        out.append(vals)
    return out[0], out[1]


def add_definitional(params: dict, pooled: dict, small: tuple[dict, dict] | None, plateau,
                     seed: int, corrected: bool = False, mass_shift: dict | None = None,
                     why: str = "") -> list[dict]:
    """Widen ``params[name]["ci90"]`` in place by the definitional uncertainty (module docstring):
    ``pooled[name] = (draws, weights | None)`` are the mixture's draws the interval came from,
    ``small`` Small's values on the data and on the model's curve (:func:`small_on_curve`),
    ``plateau`` the Re reading (or None), ``mass_shift`` the model-free column's added-mass values
    ``{"Mms"|"Cms"|"Bl": (value, u)}`` (second method for those; not with ``corrected``, which
    has no model curve of the loaded recordings to correct them by). Each widened entry gets
    ``ci90_model`` (the interval before) and ``definitional_sd`` (τ, SI). Returns the
    ``definitional_uncertainty`` note (an empty list when nothing was widened), ``why`` (a clause
    saying why Small's value was or was not corrected) added to its message."""
    from .mixture import weighted_quantiles

    rng = np.random.default_rng([int(seed), 2027])
    taus: dict[str, float] = {}
    # the other methods' values and standard uncertainties per quantity (the predictive's centre)
    second: dict[str, list[tuple[float, float]]] = {}
    if small is not None:
        on_data, on_model = small
        for name in _COMPARED:
            p = params.get(name)
            # fs has two model-free definitions (the phase zero, the |Z| peak): two methods beside the
            # model, each with its noise alone; otherwise Small's value (for fs its interval spans both)
            keys = ([k for k in ("fs_phase_zero", "fs_peak") if k in on_data and k in on_model]
                    if name == "fs" else [])
            keys = keys if len(keys) == 2 else [name]
            if not p or not all(k in on_data and k in on_model for k in keys):
                continue
            others = []
            for k in keys:
                (c, u_c), (m, _) = on_data[k], on_model[k]
                if not corrected:
                    m = p["value"]
                # Small's value corrected by its own bias on the model's curve: another method
                others.append((p["value"] + (c - m), u_c))
            taus[name] = between_methods_sd([p["value"]] + [b for b, _ in others],
                                            [half_width_sd(p.get("ci90"))] + [u for _, u in others])
            second[name] = others
    for name, (c, u_c) in ({} if corrected else (mass_shift or {})).items():
        p = params.get(name)
        if p:
            taus[name] = between_method_sd(p["value"], c, half_width_sd(p.get("ci90")), u_c)
            second[name] = [(c, u_c)]
    if plateau is not None and "Re" in params:
        p = params["Re"]
        # the plateau read with the model's motional part taken off and, unless the model's convention
        # is the one wanted (``corrected``: the raw reading less its bias on the model's curve is the
        # first), as a bench reads it: its |Z| with nothing taken off
        others = [(plateau.meter.value, plateau.meter.sd)]
        if not corrected and plateau.raw is not None:
            others.append((plateau.raw.value, plateau.raw.sd))
        taus["Re"] = between_methods_sd([p["value"]] + [b for b, _ in others],
                                        [half_width_sd(p.get("ci90"))] + [u for _, u in others])
        second["Re"] = others
    if "EBP" in params and "fs" in taus and "Qes" in taus:
        rel = math.hypot(taus["fs"] / params["fs"]["value"], taus["Qes"] / params["Qes"]["value"])
        taus["EBP"] = rel * params["EBP"]["value"]
        # Small's EBP: its fs (the definitions' mean) over its Qes
        bf = float(np.mean([b for b, _ in second["fs"]]))
        uf = float(np.sqrt(np.mean([u * u for _, u in second["fs"]])))
        (bq, uq), = second["Qes"]
        second["EBP"] = [(bf / bq, bf / bq * math.hypot(uf / bf, uq / bq))]
    widened = []
    for name, tau in taus.items():
        p = params.get(name)
        if p is None or name not in pooled or not tau > 0:
            continue
        v, w = pooled[name]
        x = another_method(v, second[name], tau, rng)
        lo, hi = (weighted_quantiles(x, w, [0.05, 0.95]) if w is not None
                  else np.quantile(x[np.isfinite(x)], [0.05, 0.95]))
        own = p.get("ci90") or [p["value"], p["value"]]
        p["ci90_model"] = p.get("ci90")
        # the model's own interval and where another method's value falls, together
        p["ci90"] = [float(min(lo, own[0], p["value"])), float(max(hi, own[1], p["value"]))]
        p["definitional_sd"] = float(tau)
        widened.append(f"{name} {100 * tau / abs(p['value']):.2g} %")
    if not widened:
        return []
    return [{"code": "definitional_uncertainty",
             "short": "intervals hold where another method's value falls, from the spread between "
                      "methods (" + ", ".join(widened) + "); ci90_model is the model alone",
             "message": "the 90 % intervals hold the model's own interval and where a further method's "
                        "value falls (the definitional uncertainty of each quantity: the spread between "
                        "the model and Small's model-free method"
                        + (" corrected by that method's own bias on the model's curve" if corrected
                           else (" (and the added-mass mass shift)" if mass_shift else ""))
                        + "; Re: the fit's R0 and the plateau read with and without the model's motional "
                          "part), as a standard deviation: "
                        + ", ".join(widened) + (f" ({why})" if why else "") + "; the model's own interval "
                        "(if it were exact) is ci90_model (intervals='model' reports it as ci90)"}]
