"""The public verbs: the front door. Each takes what a user holds (a path or a
:class:`~bayes_emt.measurement.Measurement`, model spec strings, fits, posteriors) and returns a
frozen result with ``.summary()`` (a table with units), a notebook display, ``.save()`` and a
reader back (:func:`load`)::

    import bayes_emt as be
    meas = be.load_paper_bench()                        # or be.read("speaker.zma")
    fit = be.fit(meas, "UD")                            # automatic start, two-step least squares
    post = be.sample(meas, fit=fit, seed=1)             # emcee posterior seeded by the fit
    cmp = be.compare(meas, ["UD", "NL(5)"], seed=1)     # log Z by bridge and nested sampling
    shunt = be.robust_shunt(post, seed=1)               # RC shunt over the posterior's draws
    diag = be.diagnose(meas, fit=fit, seed=1)           # what the model leaves out, named

Everything numerical lives in the layers below; a verb converts its inputs, calls one of them and
returns its record.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from ._record import read_record, record_from_dict
from .discovery.diagnose import SEARCH_PER_DECADE, Diagnosis
from .discovery.diagnose import diagnose as _diagnose
from .estimation.fitting import fit_admittance
from .estimation.meter import as_meter
from .estimation.results import FitResult
from .evidence.compare import CompareSettings, compare_models
from .evidence.nested import NestedSettings
from .evidence.records import Comparison
from .evidence.rings import expand_rings, parse_rings, ring_choice
from .inference.meter_cut import sample_with_meter
from .inference.posterior import Posterior, posterior_from_datatree
from .inference.sampling import SamplerSettings, sample_posterior
from .io import read_measurement
from .io.datasets import load_concealed_bench, load_paper_bench
from .measurement import Measurement
from .models import Model, build_model
from .shunt import RobustShuntResult, ShuntDesign, design_rc_shunt
from .shunt import robust_shunt as _robust_shunt
from .shunt.design import design_from_json_dict
from .thiele_small import ThieleSmall, thiele_small
from .thiele_small.result import read_thiele_small

__all__ = ["read", "fit", "sample", "compare", "robust_shunt", "design_shunt", "diagnose", "read_posterior",
           "ts", "load", "as_model", "as_measurement", "load_paper_bench", "load_concealed_bench"]


def as_model(model: Model | str | FitResult, *, rings: int | None = None) -> Model:
    """A :class:`~bayes_emt.models.Model` from a model, a spec string (``"UD"``, ``"NL(5)"``,
    ``"UD+suspension_creep"``; ``rings`` for a bare ``"NL"``/``"UL"``) or a fit (its model)."""
    if isinstance(model, FitResult):
        return model.model
    if isinstance(model, Model):
        return model
    if not isinstance(model, str):
        raise TypeError(f"a model is a spec string such as 'UD' or 'NL(5)', a Model or a fit, not "
                        f"{type(model).__name__}")
    return build_model(model, rings=rings)


def as_measurement(data: Measurement | str | Path, **options) -> Measurement:
    """A measurement from itself or from a file path (:func:`read`)."""
    if isinstance(data, Measurement):
        if options:
            raise TypeError(f"reading options {sorted(options)} apply to a file path, not a Measurement")
        return data
    return read(data, **options)


def read(path: str | Path, **options) -> Measurement:
    """Read a measurement file (``.zma``, CSV/TSV with a header, Touchstone): see
    :func:`~bayes_emt.io.read_measurement` for ``freq_unit``, ``phase_unit`` and ``quantity``."""
    return read_measurement(path, **options)


def fit(meas: Measurement | str | Path, model: Model | str = "UD", *, rings: int | None = None,
        exclude_band=None, **options) -> FitResult:
    """Automatic initial estimate + two-step least squares of ``model`` (a spec string or Model)
    to ``meas`` (:func:`~bayes_emt.estimation.fitting.fit_admittance` for ``options``: ``re=(ohm,
    sd)`` an ohmmeter reading, ...); ``exclude_band=[(f1_hz, f2_hz), ...]`` leaves those points out."""
    return fit_admittance(as_measurement(meas).exclude_bands(exclude_band), as_model(model, rings=rings),
                          **options)


def sample(meas: Measurement | str | Path, model: Model | str | None = None, *, fit: FitResult | None = None,
           rings: int | None = None, seed: int = 0, re=None, **options) -> Posterior:
    """The posterior of ``model`` (default: ``fit``'s model) by emcee, started from ``fit`` (fitted
    here when not given); :func:`~bayes_emt.inference.sampling.sample_posterior` for ``options``
    (``max_steps``, ``checkpoint``, ``resume``, ``likelihood``, ``settings``, ...). ``re=(ohm, sd)``
    an ohmmeter reading of R0, a cut by default, ``(ohm, sd, "prior")`` Bayes' rule
    (:mod:`~bayes_emt.estimation.meter`)."""
    if model is None and fit is None:
        raise TypeError("sample: give a model spec (e.g. 'UD') or a fit")
    m = fit.model if model is None else as_model(model, rings=rings)
    if fit is not None and fit.model.label != m.label:
        raise ValueError(f"sample: the fit is of {fit.model.label}, the model asked for is {m.label}")
    meter = as_meter(re)
    if meter is not None:
        return sample_with_meter(as_measurement(meas), m, meter, fit=fit, seed=seed, **options)
    return sample_posterior(as_measurement(meas), m, fit=fit, seed=seed, **options)


def compare(meas: Measurement | str | Path, models: Sequence[str | Model] = ("I", "II", "III", "UD", "NL(5)"),
            *, seed: int = 0, methods: Sequence[str] = ("laplace", "bridge", "nested"),
            rings: Sequence[int] | str | None = None, max_steps: int | None = None,
            nested: NestedSettings | None = None, nested_prior: str = "posterior", nested_repeats: int = 1,
            loo: bool = True, sensitivity: bool = True, results: str | Path | None = None,
            workdir: str | Path | None = None,
            progress=False, on_model=None, deadline: float | None = None) -> Comparison:
    """Evidence of each model (spec strings or Models): log Z by bridge sampling on its emcee
    posterior and by nested sampling (its prior repartitioned onto those draws), Laplace beside,
    Bayes factors on Kass & Raftery's scale, PSIS-LOO and prior sensitivity
    (:func:`~bayes_emt.evidence.compare.compare_models`). ``results``: a JSON file written after
    every model (a re-run with the same file resumes). ``rings`` (``"1-7"``, ``[2, 3, 5]``): every
    NL/UL spec once per ring count, and with several counts the ring count by evidence beside
    Hankel's. ``on_model(model_evidence, reused)`` is called as each model finishes. ``progress``: bars,
    or a ``callable(str)`` told every few seconds; ``deadline``: a :func:`time.monotonic` instant
    the models share (each emcee chain stops at its share, nested sampling is not started after
    it; both say so)."""
    meas = as_measurement(meas)
    if isinstance(models, str | Model):
        models = [models]
    counts = parse_rings(rings) if isinstance(rings, str) else None if rings is None else tuple(rings)
    named = [(m if isinstance(m, str) else m.label, as_model(m)) for m in models]
    specs, ringed = expand_rings(named, counts)
    labels = [m.label for _, m in specs]
    if len(set(labels)) != len(labels):
        raise ValueError(f"compare: each model once, got {', '.join(labels)}")
    sampler = SamplerSettings() if max_steps is None else SamplerSettings(max_steps=int(max_steps))
    settings = CompareSettings(seed=seed, methods=tuple(methods), sampler=sampler,
                               nested=nested or NestedSettings(), nested_prior=nested_prior,
                               nested_repeats=nested_repeats, loo=loo, sensitivity=sensitivity)
    cmp = compare_models(meas, specs, settings=settings, results=results, workdir=workdir, progress=progress,
                         on_model=on_model, deadline=deadline)
    if ringed and counts is not None and len(counts) > 1:
        group = [m for m in cmp.models if m.rings is not None and m.name.rsplit("(", 1)[0] == ringed[0]]
        cmp = dataclasses.replace(cmp, rings=ring_choice(meas, group, max_rings=max(7, max(counts))))
        if results is not None:
            cmp.save(results)
    return cmp


def diagnose(meas: Measurement | str | Path, model: Model | str | None = None, *,
             fit: FitResult | None = None, seed: int = 0, max_rounds: int = 4,
             time_budget: float | None = 240.0, setup: str = "unknown", exclude_band=None,
             progress=None, also=(), per_decade: float | None = SEARCH_PER_DECADE,
             search_also: bool = True) -> Diagnosis:
    """Locate where ``model`` (or ``fit``'s model, reusing that fit; neither: the base model the
    evidence prefers) and ``meas`` differ beyond the noise, name the catalogue physics that
    explains each band, and add it (:func:`~bayes_emt.discovery.diagnose.diagnose`).
    ``time_budget`` [wall-clock s from the call] stops the search, abandoning the candidates still
    running, and a warning says what was cut (``None`` or ``0``: no limit, the same result on any
    machine); ``setup``
    (``"free-air"``, ``"sealed"``, ``"vented"``, ``"shaker"``, ``"unknown"``) removes physics the
    setup cannot have (no port in free air); ``exclude_band=[(f1_hz, f2_hz), ...]`` leaves out a narrow
    feature no lumped model explains. ``also=[(recording, delta_m_kg), ...]``: second recordings of the
    same transducer (``delta_m_kg`` the mass added for it, ``None`` for the same driver at another
    level or session); each finding is checked on them and one they do not need is flagged
    (:func:`~bayes_emt.discovery.joint.check_with`, the diagnosis's ``joint`` records); with
    ``search_also`` (default) each is diagnosed too with the same settings, and a term only it names is
    fitted on ``meas`` and flagged when ``meas`` does not need it (:func:`~bayes_emt.discovery.joint.
    search_other`; about doubles the time). ``per_decade``: the search's point density (a denser sweep
    is thinned; ``None``: every point)."""
    from .discovery.joint import with_second_recordings

    m = None if model is None else as_model(model)
    data = as_measurement(meas)
    # the search's settings, which a second recording's own diagnosis (search_also) shares
    settings = dict(seed=seed, max_rounds=max_rounds, time_budget=time_budget, setup=setup,
                    exclude_band=exclude_band, per_decade=per_decade)
    d = _diagnose(data, m, fit=fit, progress=progress, **settings)
    pairs = [a if isinstance(a, tuple | list) else (a, None) for a in also]
    if not pairs:
        return d
    search = settings if search_also else None
    return with_second_recordings(d, data.exclude_bands(exclude_band),
                                  [(as_measurement(r), None if dm is None else float(dm)) for r, dm in pairs],
                                  search=search)


def robust_shunt(posteriors: Posterior | Sequence[Posterior], *, weights: str | Sequence[float] = "evidence",
                 comparison: Comparison | None = None, nominal: FitResult | None = None,
                 n_draws: int = 1000, seed: int = 0, **options) -> RobustShuntResult:
    """The nominal and the robust RC shunt over the draws of one posterior or a mixture of several
    (one per model): every draw's own optimal Rs [Ω], Cs [F] and attenuation [dB], the robust
    shunt's CVaR of the attenuation with P(unstable) ≤ ``epsilon`` (chosen on half the draws,
    reported on the other half), both shunts' stability margins against R0's uncertainty
    (:func:`~bayes_emt.shunt.robust_shunt` for ``options``). ``weights="evidence"`` weighs the
    models by the log Z of ``comparison`` (a :func:`compare` result); ``nominal`` the fit the
    nominal shunt is designed on (default: the heaviest posterior's median)."""
    posts = list(posteriors) if isinstance(posteriors, list | tuple) else [posteriors]
    log_z = None
    if comparison is not None:
        log_z = {m.label: m.log_evidence for m in comparison.models}
        missing = [p.model.label for p in posts if p.model.label not in log_z]
        if missing:
            raise ValueError(f"robust_shunt: the comparison has no log Z for {', '.join(missing)} "
                             f"(it has {', '.join(log_z)})")
    elif weights == "evidence" and len(posts) > 1:
        raise ValueError('robust_shunt: weights="evidence" over several posteriors needs their log Z: '
                         'give comparison=be.compare(...), or weights="equal" or a list of numbers')
    return _robust_shunt(posts, weights=weights, log_z=log_z, nominal=nominal, n_draws=n_draws, seed=seed,
                         **options)


def ts(data: Measurement | str | Path, model: Model | str = "UD", **options) -> ThieleSmall:
    """Thiele–Small parameters with 90 % intervals, units and their spread across adequate coil
    models: free air alone (fs, Re, Le, Qms, Qes, Qts), with ``loaded=[(recording, delta_m_kg), ...]``
    one joint posterior of every added-mass recording (Bl, Mms, Cms, Kms, Rms), with
    ``box=(recording, volume_m3)`` the added-volume method, with ``sd`` [m²] Vas, η0, SPL and EBP;
    ``re=(ohm, sd)`` an ohmmeter reading of the DC resistance
    (:func:`~bayes_emt.thiele_small.thiele_small` for every option)."""
    return thiele_small(data, model, **options)


def design_shunt(fit_or_model: FitResult | Model, theta=None, **options) -> ShuntDesign:
    """The H∞-optimal RC shunt (:func:`~bayes_emt.shunt.design_rc_shunt`) for a fit, or for a model
    and its parameter vector."""
    if isinstance(fit_or_model, FitResult):
        return design_rc_shunt(fit_or_model.model, fit_or_model.theta, **options)
    return design_rc_shunt(fit_or_model, theta, **options)


def read_posterior(path: str | Path):
    """Any saved posterior (:meth:`Posterior.save`, the added-mass pair's too), by its ``kind``."""
    import arviz as az

    dt = az.from_netcdf(path)
    if dt.attrs.get("kind") == "added_mass":
        from .added_mass.posterior import read_added_mass_posterior

        return read_added_mass_posterior(dt)
    return posterior_from_datatree(dt, where=str(path))


def load(path: str | Path):
    """Any saved result: a posterior (netCDF) or a JSON record written by a result's ``.save()`` or
    a command's ``--json`` (a fit, a comparison, a diagnosis, a shunt design, a robust shunt, T/S),
    by its ``kind`` (older files without one: by their fields)."""
    import json

    p = Path(path)
    if p.suffix.lower() in (".nc", ".nc4", ".netcdf"):
        return read_posterior(p)
    try:
        rec = json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return read_record(p)  # its one-line error names the file
    if isinstance(rec, dict) and "kind" not in rec:  # files written before these records had a kind
        if {"method", "parameters", "inputs"} <= set(rec):
            return read_thiele_small(rec)
        if {"nominal", "robust"} <= set(rec):
            return RobustShuntResult.from_json_dict(rec, where=str(p))
        if {"Rs", "Cs"} <= set(rec):
            return design_from_json_dict(rec, where=str(p))
    return record_from_dict(rec, where=str(p))
