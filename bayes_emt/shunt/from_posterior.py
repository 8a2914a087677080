"""The posterior → robust-shunt route as one call: :func:`robust_shunt` takes what a user holds
(one :class:`~bayes_emt.inference.posterior.Posterior` or several, and how to weigh them) and
returns a frozen :class:`RobustShuntResult` (JSON, summary table, reader back).

Weights: ``"evidence"`` (posterior model probabilities from the log evidences given as ``log_z``:
a list in the posteriors' order, or a mapping model label → log Z [nats], e.g. from a comparison;
equal prior odds; an object carrying such a mapping as ``.log_z`` or ``.log_evidence`` also does),
``"equal"``, or a list of non-negative numbers (normalised). The evidence is never computed here.

The numbers are :func:`~bayes_emt.shunt.robust.design_robust_shunt`'s (draws through
:func:`~bayes_emt.shunt.draws.sample_mixture`, the ESS fraction from the posteriors' ESS); this
module only gathers the inputs and packs the result.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .._json import strict_json
from .._record import register_kind
from ..errors import DataFormatError
from .bound import auto_epsilon
from .draws import mixture_weights, sample_mixture, split_halves
from .r0_spread import widen_r0
from .records import html_table, read_json_record, table
from .robust import RobustShunt, design_robust_shunt

__all__ = ["RobustShuntResult", "robust_shunt", "read_robust_shunt", "posterior_weights"]


def posterior_weights(models, weights="evidence", log_z=None) -> tuple[np.ndarray, list, str]:
    """Mixture weights for posteriors of ``models`` (module docstring): ``(weights, log Z per model
    or None, note)``."""
    n = len(models)
    labels = [m.label for m in models]
    if log_z is not None and not isinstance(log_z, Mapping | list | tuple | np.ndarray):
        # a comparison result: its mapping model label -> log Z under a usual name
        table = next((getattr(log_z, a) for a in ("log_z", "log_evidence", "log_evidences")
                      if isinstance(getattr(log_z, a, None), Mapping)), None)
        if table is None:
            raise TypeError("log_z must be a list of log evidences, a mapping model label -> log Z, or an "
                            "object with such a mapping as .log_z or .log_evidence")
        log_z = table
    if log_z is not None:
        if isinstance(log_z, Mapping):
            missing = [lb for lb in labels if lb not in log_z]
            if missing:
                have = ", ".join(map(str, log_z))
                raise ValueError(f"log_z has no entry for {', '.join(missing)} (has: {have})")
            lzs = [float(log_z[lb]) for lb in labels]
        else:
            lzs = [None if v is None else float(v) for v in log_z]
            if len(lzs) != n:
                raise ValueError(f"log_z has {len(lzs)} values for {n} posteriors; give one per posterior")
    else:
        lzs = [None] * n
    if isinstance(weights, str):
        if weights == "evidence":
            if n > 1 and all(v is None for v in lzs):
                raise ValueError('weights="evidence" needs the log evidences: pass log_z=[...] (one per '
                                 'posterior) or a mapping model label -> log Z, or weights="equal"')
            w, note = mixture_weights(lzs)
            return w, lzs, note
        if weights == "equal":
            w, note = mixture_weights([None] * n)
            return w, lzs, note
        raise ValueError(f'weights must be "evidence", "equal" or a list of numbers, got {weights!r}')
    w = np.asarray(list(weights), float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be {n} non-negative finite numbers, not all zero; "
                         f"got {list(weights)}")
    return w / w.sum(), lzs, "weights as given"


def _arr(v) -> list:
    return [None if not math.isfinite(x) else float(x) for x in np.asarray(v, float)]


@dataclass(frozen=True, eq=False)
class RobustShuntResult:
    """Nominal and robust RC shunt over posterior draws (:func:`robust_shunt`).

    Attributes
    ----------
    nominal, robust : the two shunts' reports: ``Rs`` [Ω], ``Cs`` [F], ``attenuation_db`` summary
        (median, 5 %, 95 % [dB] on the held-back draws), ``p_unstable`` and its interval,
        ``stability_margin_ohm`` and the ``r0_uncertainty_ohm`` it was compared with, ...
    Rs, Cs, attenuation_db : ``(n,)`` each draw's own H∞-optimal Rs [Ω], Cs [F], attenuation [dB].
    nominal_attenuation_db, robust_attenuation_db : ``(n,)`` the two shunts on every draw [dB]
        (+inf where unstable).
    held : ``(n,)`` True for the held-back draws the report is computed on.
    warnings : tuple of strings (codes in brackets, e.g. ``[stability_margin_below_uncertainty]``).
    report : the whole JSON report (``shunt --posterior --json``).
    detail : the in-memory :class:`~bayes_emt.shunt.robust.RobustShunt` (for the plots; ``None``
        when read back from JSON).
    """

    nominal: dict
    robust: dict
    Rs: np.ndarray
    Cs: np.ndarray
    attenuation_db: np.ndarray
    nominal_attenuation_db: np.ndarray
    robust_attenuation_db: np.ndarray
    held: np.ndarray
    warnings: tuple = ()
    report: dict = field(default_factory=dict)
    detail: RobustShunt | None = field(default=None, repr=False, compare=False)

    @classmethod
    def from_robust(cls, res: RobustShunt) -> RobustShuntResult:
        rep = res.to_json_dict()
        return cls(rep["nominal"], rep["robust"], np.asarray(res.optimum_Rs), np.asarray(res.optimum_Cs),
                   np.asarray(res.optimum_attenuation), np.asarray(res.nominal.attenuation),
                   np.asarray(res.robust.attenuation), np.asarray(res.held), tuple(res.warnings), rep, res)

    kind: ClassVar[str] = "robust_shunt"

    @classmethod
    def from_json_dict(cls, rec: dict, *, where: str = "robust-shunt result") -> RobustShuntResult:
        """Rebuild from :meth:`to_json_dict` (``detail`` is ``None``)."""
        if not isinstance(rec, dict) or not {"nominal", "robust", "draws"} <= set(rec):
            raise DataFormatError(f"{where}: not a robust-shunt result (needs 'nominal', 'robust' and "
                                  "'draws')")
        rec = {k: v for k, v in rec.items() if k != "kind"}
        d = rec.pop("draws")
        warns = tuple(rec.pop("warnings", ()))
        return cls(rec["nominal"], rec["robust"], _back(d["Rs"]), _back(d["Cs"]), _back(d["attenuation_db"]),
                   _back(d["nominal_attenuation_db"], True), _back(d["robust_attenuation_db"], True),
                   np.array(d["held"], bool), warns, {**rec, "warnings": list(warns)}, None)

    @property
    def p_unstable(self) -> dict:
        """P(unstable) on the held-back draws of each shunt."""
        return {"nominal": self.nominal["p_unstable"], "robust": self.robust["p_unstable"]}

    @property
    def stability_margin_ohm(self) -> dict:
        """Each shunt's margin to the instability threshold at the nominal point [Ω]."""
        return {name: getattr(self, name).get("stability_margin_ohm") for name in ("nominal", "robust")}

    def __repr__(self) -> str:
        r = self.robust
        return (f"RobustShuntResult(robust Rs={_g(r['Rs'])} ohm, Cs={_g(r['Cs'])} F, "
                f"P(unstable)={_g(r['p_unstable'], '.3g')}, {self.Rs.size} draws"
                + (f", {len(self.warnings)} warning(s)" if self.warnings else "") + ")")

    def summary(self) -> str:
        """Plain-text table with units, then the warnings."""
        rows = []
        for name in ("nominal", "robust"):
            d = getattr(self, name)
            a = d["attenuation_db"]
            att = f"{_g(a['median'], '.3f')} ({_g(a['q05'], '.3f')} .. {_g(a['q95'], '.3f')})"
            rows.append((name, _g(d["Rs"]), _g(d["Cs"]), att, _g(d["p_unstable"], ".3g"),
                         _g(d.get("stability_margin_ohm"), ".4g"), _g(d.get("r0_uncertainty_ohm"), ".4g")))
        lines = [f"robust RC shunt over {self.Rs.size} posterior draws (report on {int(self.held.sum())} "
                 "held back)"]
        lines += table(rows, ("shunt", "Rs [ohm]", "Cs [F]", "attenuation [dB] median (5 %..95 %)",
                              "P(unstable)", "margin [ohm]", "R0 uncertainty [ohm]"))
        q = [np.quantile(v[np.isfinite(v)], [0.5, 0.05, 0.95]) if np.isfinite(v).any() else [math.nan] * 3
             for v in (self.Rs, self.Cs, self.attenuation_db)]
        lines.append(f"each draw's own optimum, median (5 %..95 %): Rs {q[0][0]:.5g} ({q[0][1]:.5g} .. "
                     f"{q[0][2]:.5g}) ohm, Cs {q[1][0]:.5g} ({q[1][1]:.5g} .. {q[1][2]:.5g}) F, attenuation "
                     f"{q[2][0]:.3f} ({q[2][1]:.3f} .. {q[2][2]:.3f}) dB")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        return html_table(self.summary())

    def to_json_dict(self) -> dict:
        """The report plus the per-draw arrays (strict JSON: non-finite numbers as null)."""
        return strict_json({"kind": self.kind, **{k: v for k, v in self.report.items() if k != "kind"},
                            "warnings": list(self.warnings),
                            "draws": {"Rs": _arr(self.Rs), "Cs": _arr(self.Cs),
                                      "attenuation_db": _arr(self.attenuation_db),
                                      "nominal_attenuation_db": _arr(self.nominal_attenuation_db),
                                      "robust_attenuation_db": _arr(self.robust_attenuation_db),
                                      "held": [bool(h) for h in self.held]}})

    def to_json(self) -> str:
        return json.dumps(self.to_json_dict(), indent=2, allow_nan=False)

    def save(self, path) -> None:
        """Write :meth:`to_json` atomically (read back with :func:`read_robust_shunt`)."""
        from .._atomic import atomic_write_text

        atomic_write_text(path, self.to_json() + "\n")


def _g(v, spec=".5g") -> str:
    if v is None:
        return "-"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return format(v, spec)


def _back(v, inf_for_null=False) -> np.ndarray:
    return np.array([(math.inf if inf_for_null else math.nan) if x is None else x for x in v], float)


def read_robust_shunt(path) -> RobustShuntResult:
    """Read :meth:`RobustShuntResult.save` output back (``detail`` is ``None``)."""
    return RobustShuntResult.from_json_dict(read_json_record(path, "robust-shunt result"), where=str(path))


def robust_shunt(posteriors, *, weights: str | Sequence[float] = "evidence",
                 log_z: Sequence[float] | Mapping[str, float] | None = None, n_draws: int = 1000,
                 seed: int = 0, risk: str = "cvar", alpha: float = 0.9, epsilon: float | str = "auto",
                 confidence: float = 0.95, nominal=None, sampled=None,
                 ohmmeter_tolerance: float | None = None, sources: Sequence[str] | None = None,
                 boundary_points: int = 0,
                 progress: bool = False, time_budget: float | None = None,
                 r0: str = "total") -> RobustShuntResult:
    """Nominal and robust RC shunt from one posterior or a mixture of several (module docstring).

    Parameters
    ----------
    posteriors : a :class:`~bayes_emt.inference.posterior.Posterior`, or a list of them (one per model).
    weights : ``"evidence"`` (needs ``log_z`` when several), ``"equal"``, or numbers (normalised).
    log_z : log evidences [nats]: a list in the posteriors' order, or a mapping model label → log Z.
    n_draws : draws of the mixture (≥ 2). seed : the draw choice and the design/held-back split.
    risk, alpha, epsilon, confidence : as :func:`~bayes_emt.shunt.robust.design_robust_shunt`;
        ``epsilon="auto"`` (default): the smallest bound of
        :data:`~bayes_emt.shunt.bound.EPSILON_LADDER` the draws the choice never sees can show
        (:func:`~bayes_emt.shunt.bound.auto_epsilon`; the rule and the counts are in
        ``report["epsilon_choice"]``). With 1000 draws from a posterior keeping ~2000, about 1500
        draws stay unseen: 1e-3 needs 2995, so ``auto`` takes 2e-3 (1497 needed) or 5e-3.
    nominal : the point estimate of the nominal design: a fit (anything with ``model`` and
        ``theta``) or ``(model, theta, description)``; default the heaviest model's posterior median.
    sampled : a :class:`~bayes_emt.shunt.batch.plant.SampledShunt` (digital realisation) entering
        every draw's stability.
    ohmmeter_tolerance : [Ω], compared with the stability margins besides the posterior's R0 spread.
    sources : names of the posteriors (file paths) for the messages; default the model labels.
    boundary_points : Cs grid of the stability-boundary data (plots; 0: none).
    progress : print a line on stderr as each stage starts (and every 2 s within the long ones).
    time_budget : [wall s] for the robust choice; past it the best shunt so far, with a warning.
    r0 : ``"total"`` (default): each model's R0 draws widened by the spread between the fit's R0 and
        the recording's low-frequency plateau where the recording has one
        (:mod:`bayes_emt.shunt.r0_spread`), so designs, stability and margins see the R0 ``ts``
        reports; ``"model"``: the posterior's R0 as it is (if the model were exact).
    """
    if r0 not in ("total", "model"):
        raise ValueError(f'r0 must be "total" or "model", got {r0!r}')
    posts = list(posteriors) if isinstance(posteriors, list | tuple) else [posteriors]
    if not posts:
        raise ValueError("no posterior given")
    models = [p.model for p in posts]
    labels = [m.label for m in models]
    if len(set(labels)) != len(labels):
        raise ValueError(f"each model may be given once: {', '.join(labels)}")
    names = list(sources) if sources is not None else labels
    if len(names) != len(posts):
        raise ValueError(f"{len(names)} source names for {len(posts)} posteriors")
    w, lzs, note = posterior_weights(models, weights, log_z)
    notes = [note]
    ess = 1.0
    for name, p in zip(names, posts, strict=True):
        if not p.converged:
            notes.append(f"{name}: the posterior did not converge ({p.message}): its draws may not "
                         "represent it")
        n_kept = p.draws.shape[0] * p.draws.shape[1]
        ess = min(ess, float(np.min(p.ess)) / n_kept)
    groups, warns = sample_mixture([(p.model, p.theta(), name) for p, name in zip(posts, names, strict=True)],
                                   w, n_draws, seed=seed, log_evidences=lzs)
    spreads = []
    if r0 == "total":
        groups, spreads = widen_r0(groups, [p.likelihood.meas for p in posts], seed)
        notes.extend(s.line() for s in spreads)
        if not spreads and any("R0" in p.model.params.names for p in posts):
            notes.append("R0 is the posterior's alone (if the model were exact): the recording has no "
                         "rows below the fitted band to read a second Re from; an ohmmeter reading "
                         "(--ohmmeter-tolerance) is compared with the margins when given")
    eps_choice = None
    if isinstance(epsilon, str):
        if epsilon != "auto":
            raise ValueError(f'epsilon must be a number in [0, 1) or "auto", got {epsilon!r}')
        live = [g for g in groups if g.n > 0]
        unseen = {g.label: (g.available - d.size if g.available >= g.n else 0)
                  for g, (d, _) in zip(live, split_halves(live, seed=seed), strict=True)}
        epsilon, eps_choice = auto_epsilon(unseen, confidence, ess)
    if nominal is not None and not isinstance(nominal, tuple):
        nominal = (nominal.model, np.asarray(nominal.theta, float), f"fit ({nominal.model.label})")

    def tell(text):
        print(f"bayes-emt shunt: {text}", file=sys.stderr, flush=True)

    res = design_robust_shunt(groups, nominal=nominal, risk=risk, alpha=alpha, epsilon=epsilon,
                              confidence=confidence, seed=seed, sampled=sampled, ess_fraction=ess,
                              boundary_points=boundary_points, notes=notes + warns,
                              ohmmeter_tolerance=ohmmeter_tolerance, progress=tell if progress else None,
                              time_budget=time_budget, r0_spread=spreads)
    out = RobustShuntResult.from_robust(res)
    out.report["epsilon_choice"] = eps_choice or {"rule": "epsilon as given", "epsilon": epsilon}
    return out


register_kind(RobustShuntResult)
