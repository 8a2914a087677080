"""Frozen result records shared between stages (no solver state inside)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .._record import Record, Table
from ..io.paramfile import model_from_record, param_record
from ..models import Model
from ..models.derived import DERIVED, derived_values

__all__ = ["FitResult"]


@dataclass(frozen=True, repr=False)
class FitResult(Record):
    """A deterministic (least-squares) estimate.

    Attributes
    ----------
    model : the fitted :class:`~bayes_emt.models.Model`.
    theta : (k,) physical parameter values, SI, in ``model.names`` order.
    cov_z : (k, k) covariance of the estimate in *sampling space* (``model.params.to_z``: log for
        positive parameters), from the Jacobian at the optimum scaled by the residual variance;
        ``None`` when singular.
    chi2 : weighted sum of squared residuals of the final step (relative-residual weighting).
    rms_rel_residual : ``sqrt(mean |Y_fit - Y|² / |Y|²)`` over all points.
    n_points : number of frequencies used.
    success : whether the optimiser reported convergence.
    message : the optimiser's message (or why the fallback was taken).
    initial : (k,) the automatic initial estimate the fit started from.
    info : extra, JSON-serialisable details (steps, timings, method).
    warnings : what makes the estimate untrustworthy, as ``{"code", "message"}`` records
        (:mod:`bayes_emt.estimation.adequacy`: ``model_inadequate``, ``parameter_at_bound``,
        ``not_identifiable``, ``resonance_outside_data``); empty when nothing was found.
    """

    model: Model
    theta: np.ndarray
    cov_z: np.ndarray | None
    chi2: float
    rms_rel_residual: float
    n_points: int
    success: bool = True
    message: str = ""
    initial: np.ndarray | None = None
    info: dict = field(default_factory=dict)
    warnings: tuple[dict, ...] = ()

    kind = "fit"

    @property
    def warning_codes(self) -> tuple[str, ...]:
        """The codes of :attr:`warnings`, in order."""
        return tuple(w["code"] for w in self.warnings)

    @property
    def parameters(self) -> dict[str, float]:
        return self.model.as_dict(self.theta)

    @property
    def z(self) -> np.ndarray:
        """The estimate in sampling space."""
        return self.model.params.to_z(self.theta)

    @property
    def stderr(self) -> dict[str, float]:
        """Standard errors of the physical values [SI] (delta method through the transform)."""
        if self.cov_z is None:
            return {n: float("nan") for n in self.model.names}
        sd_z = np.sqrt(np.clip(np.diag(self.cov_z), 0, None))
        out = {}
        for spec, x, s in zip(self.model.params, self.theta, sd_z, strict=True):
            out[spec.name] = float(abs(x) * s if spec.transform == "log" else s)
        return out

    def to_json_dict(self) -> dict:
        """The ``bayes-emt fit --json`` record (SI units)."""
        return {
            **param_record(self.model, self.theta),
            "stderr": {k: (None if not np.isfinite(v) else v) for k, v in self.stderr.items()},
            "units": dict(zip(self.model.names, self.model.params.units, strict=True)),
            "rms_rel_residual": float(self.rms_rel_residual),
            "chi2": float(self.chi2),
            "n_points": int(self.n_points),
            "success": bool(self.success),
            "message": self.message,
            "warnings": [{"code": str(w["code"]), "message": str(w["message"])} for w in self.warnings],
            "derived": derived_values(self.model, self.theta),
            "derived_units": {k: v[0] for k, v in DERIVED.items()},
            "cov_z": None if self.cov_z is None else np.asarray(self.cov_z, float).tolist(),
        }

    @classmethod
    def from_json_dict(cls, rec: Mapping) -> FitResult:
        """The fit a :meth:`to_json_dict` record (``fit --json``, :meth:`save`) describes: model,
        values, covariance (when the record has one), residual figures and warnings."""
        model, theta = model_from_record(rec, where="fit record")
        cov = rec.get("cov_z")
        cov_z = None if cov is None else np.asarray(cov, float)
        if cov_z is not None and cov_z.shape != (model.ndim, model.ndim):
            raise ValueError(f"cov_z has shape {cov_z.shape}, the model has {model.ndim} parameters")
        return cls(model, theta, cov_z, float(rec.get("chi2", float("nan"))),
                   float(rec.get("rms_rel_residual", float("nan"))), int(rec.get("n_points", 0)),
                   bool(rec.get("success", True)), str(rec.get("message", "")),
                   warnings=tuple({"code": w["code"], "message": w["message"]}
                                  for w in rec.get("warnings", ())))

    # ---- what a person reads -------------------------------------------------------------------
    def headline(self) -> str:
        w = f", {len(self.warnings)} warning(s)" if self.warnings else ""
        return (f"{self.model.label} fit of {self.n_points} points, rms relative residual "
                f"{100 * self.rms_rel_residual:.3g} %{w}")

    def tables(self) -> list[Table]:
        se = self.stderr
        rows = tuple((s.name, float(v), se[s.name], s.unit, s.description)
                     for s, v in zip(self.model.params, self.theta, strict=True))
        d = derived_values(self.model, self.theta)
        drows = tuple((k, v, "", DERIVED[k][0], DERIVED[k][1]) for k, v in d.items() if np.isfinite(v))
        notes = (f"rms relative residual {100 * self.rms_rel_residual:.4g} % over {self.n_points} points; "
                 + ("optimiser converged" if self.success
                    else f"optimiser did NOT converge: {self.message}"),)
        out = [Table(f"{self.model.label}: least-squares estimate (standard errors from the Jacobian)",
                     ("parameter", "value", "std. error", "unit", "meaning"), rows + drows, notes)]
        if self.warnings:
            out.append(Table("warnings", ("code", "message"),
                             tuple((w["code"], w["message"]) for w in self.warnings)))
        return out
