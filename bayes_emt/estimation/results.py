"""Frozen result records shared between stages (no solver state inside)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..io.paramfile import param_record
from ..models import Model

__all__ = ["FitResult"]


@dataclass(frozen=True)
class FitResult:
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
        """The ``bayes-emt fit --json`` record (SPEC §6 names, SI units)."""
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
        }
