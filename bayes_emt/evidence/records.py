"""Frozen result records of a model comparison, with the JSON form of ``bayes-emt compare``.

JSON schema, with extra fields after the required ones::

    {"models": [{"name", "rings", "log_evidence", "log_evidence_err",
                 "by_method": {method: {"log_evidence", "err", ...}},
                 "elpd_loo", "elpd_loo_se", ...}],
     "best", "bayes_factors": {"A/B": ln B [nats]}, "warnings": [...], ...}

``log_evidence`` of a model combines its independent estimators (nested sampling and bridge
sampling; Laplace is a screen and never enters, nor does an estimate marked ``excluded``: one
far below the evidence lower bound, :mod:`.bound`) by inverse-variance weighting, each method's
error taken as the larger of its own error estimate and its spread over repeats; the combined
error is the weighted one, raised to half the estimators' difference when they disagree by more
than their errors allow. All log evidences are natural logs [nats].
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from .._record import Record, Table
from .scale import SCALE_REFERENCE, bayes_factor, verbal

__all__ = ["ModelEvidence", "Comparison", "combine_methods", "DISAGREEMENT_NATS"]

DISAGREEMENT_NATS = 1.0  # estimators further apart than this are flagged
_COMBINED = ("nested", "bridge")


def _method_err(m: Mapping) -> float:
    err = m.get("err")
    err = math.inf if err is None else float(err)
    spread = m.get("spread")
    return max(err, float(spread)) if spread is not None and math.isfinite(float(spread)) else err


def combine_methods(by_method: Mapping[str, Mapping]) -> tuple[float, float]:
    """``(log Z, err)`` [nats] from the nested and bridge entries of ``by_method`` (module docstring)."""
    vals, errs = [], []
    for name in _COMBINED:
        m = by_method.get(name)
        if (m is None or m.get("excluded") or m.get("log_evidence") is None
                or not math.isfinite(float(m["log_evidence"]))):
            continue
        vals.append(float(m["log_evidence"]))
        errs.append(max(_method_err(m), 1e-6))
    if not vals:
        return math.nan, math.nan
    w = [1.0 / e**2 for e in errs]
    mean = sum(wi * v for wi, v in zip(w, vals, strict=True)) / sum(w)
    err = math.sqrt(1.0 / sum(w))
    if len(vals) > 1:
        err = max(err, 0.5 * (max(vals) - min(vals)))
    return mean, err


@dataclass(frozen=True)
class ModelEvidence:
    """The evidence of one model spec given one measurement.

    Attributes
    ----------
    name : the model spec as given (``"UD"``, ``"NL"``, ``"NL+winding_capacitance"``).
    label : the model's label (``"NL(5)"``); rings : ring count (NL/UL) or ``None``.
    n_params : sampled parameters (model and noise).
    by_method : method → ``{"log_evidence", "err", ...}`` [nats] (nested, bridge, laplace).
    log_evidence, log_evidence_err : combined estimate [nats] (:func:`combine_methods`).
    elpd_loo, elpd_loo_se : PSIS-LOO expected log pointwise predictive density and its standard
        error [nats] (``az.loo`` on the per-frequency log-likelihood), or ``None``.
    widened : prior sensitivity: ``{"log_evidence", "delta"}`` with every prior width doubled.
    seconds, calls : wall time [s] and likelihood calls per stage.
    converged : whether the emcee posterior met its stopping rule.
    key : identity of the run (data, model, priors, settings, seed) for resuming.
    warnings : what makes a number untrustworthy.
    lower_bound : the evidence lower bound from the emcee draws (``{"log_evidence", "err", ...}``
        [nats], :mod:`.bound`), a check on ``by_method``, or ``{}``.
    posterior_file : the emcee posterior saved by the run (netCDF; ``""`` when none was saved).
    """

    name: str
    label: str
    rings: int | None
    n_params: int
    by_method: dict
    log_evidence: float
    log_evidence_err: float
    elpd_loo: float | None = None
    elpd_loo_se: float | None = None
    widened: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    calls: dict = field(default_factory=dict)
    converged: bool = True
    key: str = ""
    warnings: tuple[str, ...] = ()
    lower_bound: dict = field(default_factory=dict)
    posterior_file: str = ""

    @property
    def seconds_total(self) -> float:
        return float(sum(self.seconds.values()))

    def to_json_dict(self) -> dict:
        return {"name": self.name, "rings": self.rings, "log_evidence": _num(self.log_evidence),
                "log_evidence_err": _num(self.log_evidence_err), "by_method": self.by_method,
                "elpd_loo": _num(self.elpd_loo), "elpd_loo_se": _num(self.elpd_loo_se),
                "label": self.label, "n_params": self.n_params, "units": "nats",
                "prior_widths_doubled": self.widened, "seconds": self.seconds,
                "evidence_seconds": self.seconds_total, "calls": self.calls, "converged": self.converged,
                "key": self.key, "warnings": list(self.warnings), "lower_bound": self.lower_bound,
                "posterior_file": self.posterior_file}

    @classmethod
    def from_json_dict(cls, d: Mapping) -> ModelEvidence:
        def num(x):
            return math.nan if x is None else float(x)

        return cls(d["name"], d["label"], d["rings"], int(d["n_params"]), dict(d["by_method"]),
                   num(d["log_evidence"]), num(d["log_evidence_err"]),
                   None if d.get("elpd_loo") is None else float(d["elpd_loo"]),
                   None if d.get("elpd_loo_se") is None else float(d["elpd_loo_se"]),
                   dict(d.get("prior_widths_doubled", {})), dict(d.get("seconds", {})),
                   dict(d.get("calls", {})), bool(d.get("converged", True)), d.get("key", ""),
                   tuple(d.get("warnings", ())), dict(d.get("lower_bound") or {}),
                   str(d.get("posterior_file") or ""))


def _num(x):
    return None if x is None or not math.isfinite(float(x)) else float(x)


@dataclass(frozen=True, repr=False)
class Comparison(Record):
    """Evidence of every candidate, Bayes factors, prior sensitivity and (optionally) the NL ring
    count by evidence beside Hankel's.

    Attributes
    ----------
    models : one :class:`ModelEvidence` per candidate, in the order given.
    source, data_sha256, n_points : the measurement.
    rings : ``{"by_evidence", "hankel", ...}`` when NL ring counts were compared, else ``{}``.
    settings : the run's settings (seed, estimator knobs).
    warnings : comparison-level warnings (model-level ones are collected too).
    """

    models: tuple[ModelEvidence, ...]
    source: str = ""
    data_sha256: str = ""
    n_points: int = 0
    rings: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    kind = "comparison"

    def _valid(self) -> list[ModelEvidence]:
        return [m for m in self.models if math.isfinite(m.log_evidence)]

    @property
    def best(self) -> str | None:
        """The candidate with the highest log evidence."""
        valid = self._valid()
        return max(valid, key=lambda m: m.log_evidence).name if valid else None

    def _pairs(self, widened: bool = False) -> dict[str, dict]:
        out = {}
        recs = []
        for m in self._valid():
            lz = m.widened.get("log_evidence", math.nan) if widened else m.log_evidence
            recs.append({"name": m.name, "log_evidence": lz, "log_evidence_err": m.log_evidence_err})
        for i, a in enumerate(recs):
            for b in recs[i + 1 :]:
                out[f"{a['name']}/{b['name']}"] = bayes_factor(a, b)
        return out

    def bayes_factors(self) -> dict[str, float]:
        """``{"A/B": ln(Z_A/Z_B)}`` [nats] for every pair, in the order the models were given."""
        return {k: v["log_bayes_factor"] for k, v in self._pairs().items()}

    def surviving(self) -> dict[str, bool]:
        """Per pair: whether its verdict (favoured model, or inconclusive) stays the same with every
        prior width doubled."""
        now, wide = self._pairs(), self._pairs(widened=True)
        return {k: (now[k]["favours"] == wide[k]["favours"]) for k in now if k in wide}

    def all_warnings(self) -> list[str]:
        out = list(self.warnings)
        for m in self.models:
            out += [w if w.startswith(m.name) else f"{m.name}: {w}" for w in m.warnings]
        return out

    def to_json_dict(self) -> dict:
        best = self.best
        verdict = None
        ranked = sorted(self._valid(), key=lambda m: -m.log_evidence)
        if len(ranked) > 1:
            top, second = ranked[0], ranked[1]
            d = top.log_evidence - second.log_evidence
            word = verbal(d, math.hypot(top.log_evidence_err, second.log_evidence_err))
            close = [m.name for m in ranked[1:] if verbal(top.log_evidence - m.log_evidence,
                                                          math.hypot(top.log_evidence_err,
                                                                     m.log_evidence_err)) == "inconclusive"]
            verdict = (f"inconclusive against {', '.join(close)}" if close
                       else f"{word} against the runner-up {second.name} (ln B = {d:.2f} nats)")
        return {"models": [m.to_json_dict() for m in self.models], "best": best,
                "bayes_factors": self.bayes_factors(), "warnings": self.all_warnings(),
                "best_verdict": verdict,
                "bayes_factor_details": self._pairs(), "scale": SCALE_REFERENCE,
                "prior_sensitivity": {"widths": "every prior width doubled in sampling space "
                                                "(bayes_emt.evidence.sensitivity)",
                                      "bayes_factors": {k: v["log_bayes_factor"]
                                                        for k, v in self._pairs(widened=True).items()},
                                      "survives": self.surviving()},
                "rings": self.rings, "source": self.source, "data_sha256": self.data_sha256,
                "n_points": self.n_points, "settings": self.settings, "units": "nats",
                "evidence_seconds": {m.name: m.seconds_total for m in self.models},
                "comparison_warnings": list(self.warnings)}

    @classmethod
    def from_json_dict(cls, d: Mapping) -> Comparison:
        """The comparison a :meth:`to_json_dict` record (``compare --json``, :meth:`save`) holds."""
        return cls(tuple(ModelEvidence.from_json_dict(m) for m in d["models"]), d.get("source", ""),
                   d.get("data_sha256", ""), int(d.get("n_points", 0)), dict(d.get("rings") or {}),
                   dict(d.get("settings") or {}), tuple(d.get("comparison_warnings", ())))

    def merged(self, *others: Comparison) -> Comparison:
        """One comparison of this one's models and ``others``' (same measurement), in that order."""
        for o in others:
            if o.data_sha256 != self.data_sha256:
                raise ValueError(f"cannot merge comparisons of different data ({o.source} and {self.source})")
        models = self.models + tuple(m for o in others for m in o.models)
        return Comparison(models, self.source, self.data_sha256, self.n_points, self.rings, self.settings,
                          self.warnings + tuple(w for o in others for w in o.warnings))

    @property
    def log_evidence(self) -> dict[str, float]:
        """``{name: log Z}`` [nats], the combined estimate of each candidate."""
        return {m.name: m.log_evidence for m in self.models}

    # ---- what a person reads -------------------------------------------------------------------
    def headline(self) -> str:
        best = self.best
        return (f"{len(self.models)} models compared by evidence on {self.n_points} points; best: "
                f"{best if best else 'none'}")

    def tables(self) -> list[Table]:
        methods = [k for k in ("nested", "bridge", "laplace") if any(k in m.by_method for m in self.models)]
        best = max((m.log_evidence for m in self._valid()), default=math.nan)

        def by(m, k):
            v = m.by_method.get(k, {})
            return v.get("log_evidence") if not v.get("excluded") else None

        rows = tuple((m.name, m.n_params, m.log_evidence, m.log_evidence_err, m.log_evidence - best,
                      *(by(m, k) for k in methods), m.elpd_loo, m.widened.get("delta"),
                      "yes" if m.converged else "NO", m.seconds_total)
                     for m in self.models)
        cols = ("model", "k", "log Z [nats]", "+-", "ln B vs best", *(f"{k} [nats]" for k in methods),
                "elpd_loo [nats]", "dlogZ widths x2", "chain converged", "time [s]")
        rec = self.to_json_dict()
        notes = [f"best: {rec['best']} ({rec['best_verdict'] or 'no verdict'}); scale: {SCALE_REFERENCE}"]
        if self.rings:
            notes.append(f"NL ring count: {self.rings.get('agreement', self.rings.get('by_evidence'))} "
                         f"(evidence rule: {self.rings.get('rule', '')})")
        out = [Table("model comparison by evidence (natural logs)", cols, rows, tuple(notes))]
        det, surv = rec["bayes_factor_details"], rec["prior_sensitivity"]["survives"]
        if det:
            out.append(Table("Bayes factors", ("pair A/B", "ln B [nats]", "+-", "verdict", "favours",
                                                "survives widths x2"),
                             tuple((k, v["log_bayes_factor"], v["err"], v["verdict"], v["favours"] or "-",
                                    "yes" if surv.get(k) else "no") for k, v in det.items())))
        if rec["warnings"]:
            out.append(Table("warnings", ("message",), tuple((w,) for w in rec["warnings"])))
        return out
