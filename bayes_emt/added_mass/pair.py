"""Two recordings of one transducer in one joint fit, the mechanics of each its own.

A second recording of the same transducer (another session, another mounting, a mass of unknown
size on the cone) shares the coil, the terms that describe it and every other term that belongs
to the device, but not its mechanics: one joint vector ``(shared..., ζ_a, ω0_a, φ̄_a, ζ_b, ω0_b,
φ̄_b)`` explains both (:class:`PairModel`). The parameters that may differ between the recordings
are the model's mechanical ones by default and any others named (``per_run``; e.g. ``R0``, which
follows the coil's temperature from one session to the next). With a known added mass the stricter
shared physical ``m, c, k, φ`` of :class:`~bayes_emt.added_mass.multi.MultiMassModel` applies
instead.

:func:`fit_pair` is the joint least-squares fit of either (any joint model with ``model``,
``params``, ``thetas`` and ``start``): each run's residuals divided by its own separate-fit scale,
as :func:`~bayes_emt.added_mass.multi.fit_multi_mass` does; it starts the joint evidence
(:mod:`bayes_emt.evidence.joint`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..estimation.results import FitResult
from ..inference.likelihood import SamplingSpaceDensity
from ..measurement import Measurement
from ..models import Model
from ..params import ParamSet
from .fit import solve_joint
from .multi import JointRuns, joint_bounds_z, rms_rel, run_scales, scaled_residuals

__all__ = ["PairModel", "PairFit", "PairLikelihood", "fit_pair", "run_models", "RUN_SUFFIXES", "MECHANICS"]

#: the model's mechanical parameters (a run's resonance, damping and mass-normalised coupling)
MECHANICS = ("zeta", "omega0", "phi")
#: the two recordings' suffixes of their own parameters
RUN_SUFFIXES = ("_a", "_b")


@dataclass(frozen=True)
class PairModel:
    """Two recordings, the first of ``model``, the second of ``other`` (default the same model): the
    parameters both models have are shared, except ``per_run`` (each recording its own); a
    parameter only one model has is that recording's. Own parameters are named with
    :data:`RUN_SUFFIXES` and keep their model's prior. Joint vector: the shared parameters in
    ``model``'s order, then the first recording's own, then the second's."""

    model: Model
    other: Model | None = None
    per_run: tuple[str, ...] = MECHANICS
    params: ParamSet = field(init=False)
    shared: tuple[str, ...] = field(init=False)
    own: tuple[tuple[str, ...], tuple[str, ...]] = field(init=False)

    def __post_init__(self):
        other = self.model if self.other is None else self.other
        object.__setattr__(self, "other", other)
        missing = [n for n in self.per_run if n not in self.model.names or n not in other.names]
        if missing:
            raise ValueError(f"models {self.model.label} and {other.label} do not both have {missing} "
                             "to give each recording")
        shared = tuple(n for n in self.model.names if n in other.names and n not in self.per_run)
        own = (tuple(n for n in self.model.names if n not in shared),
               tuple(n for n in other.names if n not in shared))
        object.__setattr__(self, "shared", shared)
        object.__setattr__(self, "own", own)
        specs = [self.model.params[n] for n in shared]
        for m, names, s in zip((self.model, other), own, RUN_SUFFIXES, strict=True):
            specs += [replace(m.params[n], name=n + s) for n in names]
        object.__setattr__(self, "params", ParamSet(specs))

    @property
    def models(self) -> tuple[Model, Model]:
        """Each recording's model."""
        return self.model, self.other

    @property
    def names(self) -> tuple[str, ...]:
        return self.params.names

    @property
    def deltas(self) -> tuple[float, ...]:
        """No known mass change (the interface of :class:`~bayes_emt.added_mass.multi.MultiMassModel`)."""
        return ()

    def thetas(self, x) -> list[np.ndarray]:
        """Each recording's model vector ``(..., ndim)`` from the joint ``x (..., p)``."""
        x = np.asarray(x, float)
        out, at = [], len(self.shared)
        for m, names in zip(self.models, self.own, strict=True):
            cols = [x[..., self.shared.index(n)] if n in self.shared else x[..., at + names.index(n)]
                    for n in m.names]
            out.append(np.stack(cols, axis=-1))
            at += len(names)
        return out

    def start(self, fits: Sequence[FitResult], shared_from: int | None = None) -> np.ndarray:
        """A joint vector from the two separate fits: each recording's own parameters from its fit,
        the shared ones from fit ``shared_from`` or (``None``) averaged in sampling space (geometric
        mean of positive ones)."""
        use = fits if shared_from is None else [fits[shared_from]]
        zs = np.mean([[self.model.params[n].to_z(f.parameters[n]) for n in self.shared] for f in use],
                     axis=0)
        avg = [float(self.model.params[n].from_z(z)) for n, z in zip(self.shared, zs, strict=True)]
        own = [f.parameters[n] for f, names in zip(fits, self.own, strict=True) for n in names]
        return np.array(avg + own, float)

    def starts(self, fits: Sequence[FitResult]) -> list[np.ndarray]:
        """The joint fit's starts: the shared parameters from each recording's fit, and averaged
        (two fits that disagree about a shared term average to values neither holds)."""
        return [self.start(fits, i) for i in range(len(fits))] + [self.start(fits)]


@dataclass(frozen=True)
class PairFit:
    """Joint least-squares fit of two (or more) recordings (:func:`fit_pair`): the joint model,
    its vector ``theta`` [SI], covariance ``cov_z`` in sampling space (``None`` when singular), each
    run's model vector, residual scale of its separate fit and rms relative residual, ``chi2`` of
    the scaled residuals."""

    joint: object
    theta: np.ndarray
    cov_z: np.ndarray | None
    run_thetas: tuple[np.ndarray, ...]
    noise_rel: tuple[float, ...]
    rms_rel_residual: tuple[float, ...]
    chi2: float
    success: bool

    @property
    def values(self) -> dict:
        return dict(zip(self.joint.params.names, map(float, self.theta), strict=True))


def run_models(joint, n: int) -> tuple[Model, ...]:
    """Each run's model under ``joint``: its ``models`` (:class:`PairModel`) or ``model`` for all."""
    return tuple(getattr(joint, "models", None) or (joint.model,) * n)


def fit_pair(runs: Sequence[Measurement], joint, fits: Sequence[FitResult], *,
             max_nfev: int | None = None) -> PairFit:
    """Joint least-squares fit of ``runs`` under ``joint`` (a :class:`PairModel`, or a
    :class:`~bayes_emt.added_mass.multi.MultiMassModel` with its masses), started from the runs'
    separate ``fits`` of ``joint.model`` (which also set each run's residual scale; a
    :class:`PairModel` from each of its :meth:`PairModel.starts`, the best kept): minimises
    ``Σ_runs Σ_ω |Y_model − Y|²/(|Y|² s_run²)`` in sampling space within the priors' support."""
    models = run_models(joint, len(runs))
    if len(fits) != len(runs) or any(f.model.names != m.names for f, m in zip(fits, models, strict=True)):
        raise ValueError("a joint fit needs one separate fit per recording, of "
                         + ", ".join(m.label for m in models))
    _, noise = run_scales(models, runs, fits)
    batch = scaled_residuals(joint, models, runs, noise)
    lo, hi = joint_bounds_z(joint)
    starts = joint.starts(fits) if hasattr(joint, "starts") else [joint.start(fits)]
    best = None
    for x0 in starts:
        z0 = joint.params.clip_inside(joint.params.to_z(x0))
        got = solve_joint(batch, joint.params, joint.params.from_z(z0), lo, hi, max_nfev)
        if best is None or float(got[1] @ got[1]) < float(best[1] @ best[1]):
            best = got
    sol, r, cov, x, _se = best
    ths = joint.thetas(x)
    return PairFit(joint, np.asarray(x, float), cov, tuple(ths), tuple(noise), rms_rel(models, runs, ths),
                   float(r @ r), bool(sol.status > 0))


@dataclass(frozen=True, eq=False)
class PairLikelihood(JointRuns, SamplingSpaceDensity):
    """``Σ_runs log p(Y_run | θ_run(x))`` for the joint vector of ``joint`` (a :class:`PairModel` or a
    :class:`~bayes_emt.added_mass.multi.MultiMassModel`) plus each run's white Gaussian noise
    scales (``sigma_rel_run<i>``, ``sigma_abs_run<i>``, the noise priors of :mod:`bayes_emt.params`),
    each run under its own model."""

    joint: object
    runs: tuple[Measurement, ...]

    def __post_init__(self):
        self._set_runs(run_models(self.joint, len(self.runs)), "white")
