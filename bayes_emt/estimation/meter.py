"""An ohmmeter reading of the coil's DC resistance ``R0`` and how it enters a fit or a posterior.

A reading is ``(R_meter, sd)`` [Ω] (``--re OHM[:SD]``, default sd 1 %) and one of two modes:

``"cut"`` (the default)
    The reading alone gives ``R0``: ``R0 ~ N(R_meter, sd)``; the terminal data inform every other
    parameter *given* ``R0``, and do not feed back into it. This is a cut (modular) posterior
    (Plummer 2015, "Cuts in Bayesian graphical models", Statistics and Computing 25:37–43; Jacob,
    Murray, Holmes & Robert 2017, "Better together? Statistical learning in models made of
    modules", arXiv:1708.08719): the reading is a direct measurement of ``R0``, while the terminal
    fit's ``R0`` is an indirect, model-dependent one whose standard error assumes the model is
    right. A coil model that lacks some physics pushes it into ``R0`` (the Dayton LS10-44 in
    ``../shared/realdata``: UD puts ``R0`` at 8.61 ± 0.03 Ω while ``|Z|`` at 1 Hz reads 7.40 Ω), and
    with hundreds of points the data pin that wrong value 3× tighter than a 1 % meter, so Bayes'
    rule (the ``"prior"`` mode) leaves ``R0`` where the wrong model put it. Under the cut every
    model reports the meter's ``R0`` and its other parameters at that ``R0``; the distance between
    the data's ``R0`` and the reading is reported (``info["re"]["conflict_sd"]``) and warned about
    beyond :data:`CONFLICT_SD` standard deviations (code ``re_conflict``).

    Computation, to first order in ``R0 − R_meter`` (exact for a Gaussian posterior; a 1 % reading
    moves the others far less than their own curvature scale): the fit holds ``R0`` at the reading
    (a penalty of standard deviation ``sd·PIN``) and the covariance of the others is their
    conditional one at that ``R0`` plus the reading's variance carried through their regression on
    ``R0``: ``Σ_cut = Σ − c cᵀ/Σ_ii + sd_z² v vᵀ`` with ``c = Σ[:, i]``, ``v = c/Σ_ii`` (``Σ`` the
    data-only covariance, ``i`` the index of ``R0``, ``sd_z`` the reading's sd in sampling space).
    A posterior is sampled with ``R0`` held the same way, then each draw gets a seeded
    ``N(R_meter, sd)`` draw of ``R0`` and moves along ``v`` by the change (:func:`move_draws`).

``"prior"``
    Bayes' rule: a Normal prior on ``R0`` for posteriors and the penalty ``s (R0 − R_meter)/sd``
    for least squares (``s`` the fit's residual scale); the data and the reading both count, each
    by its precision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params import Normal

__all__ = ["Meter", "as_meter", "RE_MODES", "PIN", "CONFLICT_SD", "cut_covariance", "move_draws", "per_ohm",
           "conflict_warning", "held_covariance", "cut_rng"]

RE_MODES = ("cut", "prior")
#: under the cut, ``R0`` is held at the reading with standard deviation ``sd·PIN``
PIN = 1e-3
#: a data-only ``R0`` this many combined standard deviations from the reading is warned about
CONFLICT_SD = 3.0


@dataclass(frozen=True)
class Meter:
    """An ohmmeter reading ``value ± sd`` [Ω] of ``R0`` and how it counts (``mode``: ``"cut"`` or
    ``"prior"``, module docstring)."""

    value: float
    sd: float
    mode: str = "cut"

    def __post_init__(self):
        v, s = float(self.value), float(self.sd)
        if not (math.isfinite(v) and v > 0 and math.isfinite(s) and s > 0):
            raise ValueError("re must be a positive resistance [ohm] with a positive sd, got "
                             f"({self.value!r}, {self.sd!r})")
        if self.mode not in RE_MODES:
            raise ValueError(f"re mode must be one of {', '.join(RE_MODES)}, got {self.mode!r}")
        object.__setattr__(self, "value", v)
        object.__setattr__(self, "sd", s)

    @property
    def cut(self) -> bool:
        return self.mode == "cut"

    @property
    def held_sd(self) -> float:
        """The standard deviation [Ω] of the penalty / prior the fit and sampler use: ``sd·PIN``
        under the cut (``R0`` held at the reading), ``sd`` under ``"prior"``."""
        return self.sd * PIN if self.cut else self.sd

    def prior(self) -> Normal:
        """The Normal prior on ``R0`` the sampler uses (``held_sd`` wide)."""
        return Normal(self.value, self.held_sd)

    def reading_prior(self) -> Normal:
        """The reading itself as a Normal prior, ``N(value, sd)`` (what a cut posterior's record shows)."""
        return Normal(self.value, self.sd)

    def sd_z(self, spec) -> float:
        """The reading's standard deviation in ``spec``'s sampling space (central difference)."""
        return float(abs(spec.to_z(self.value + self.sd) - spec.to_z(self.value - self.sd)) / 2.0)

    def to_dict(self) -> dict:
        return {"value": self.value, "sd": self.sd, "mode": self.mode}


def as_meter(re, mode: str | None = None) -> Meter | None:
    """``re`` as a :class:`Meter`: ``None``; a :class:`Meter`; ohms (1 % sd); ``(ohms, sd)`` or
    ``(ohms, sd, mode)``. ``mode`` overrides the mode when given."""
    if re is None:
        return None
    if isinstance(re, Meter):
        return re if mode is None else Meter(re.value, re.sd, mode)
    if isinstance(re, int | float):
        return Meter(float(re), 0.01 * float(re), mode or "cut")
    try:
        parts = tuple(re)
    except TypeError:
        raise ValueError(f"re must be ohms, (ohms, sd) or (ohms, sd, mode), got {re!r}") from None
    if len(parts) == 2:
        return Meter(parts[0], parts[1], mode or "cut")
    if len(parts) == 3:
        return Meter(parts[0], parts[1], mode or parts[2])
    raise ValueError(f"re must be ohms, (ohms, sd) or (ohms, sd, mode), got {re!r}")


def cut_covariance(cov_z: np.ndarray, i: int, sd_z: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Σ_cut, v, Σ_cond)`` from the data-only covariance ``cov_z`` (module docstring): ``v`` the
    regression of every parameter on parameter ``i`` (``v[i] = 1``), ``Σ_cond`` the covariance given
    parameter ``i`` (row and column ``i`` zero), ``Σ_cut = Σ_cond + sd_z² v vᵀ``."""
    cov = np.asarray(cov_z, float)
    c = cov[:, i].copy()
    cii = float(c[i])
    if not (math.isfinite(cii) and cii > 0):
        raise ValueError("the covariance gives R0 no positive variance: the cut is not defined")
    v = c / cii
    cond = cov - np.outer(c, c) / cii
    cond[i, :] = 0.0
    cond[:, i] = 0.0
    cond = 0.5 * (cond + cond.T)
    return cond + sd_z**2 * np.outer(v, v), v, cond


def conflict_warning(label: str, r0: float, sd_data: float, meter: Meter, dist: float) -> dict | None:
    """The ``re_conflict`` warning when the data's ``R0`` (``r0 ± sd_data`` [Ω], model ``label``) lies
    more than :data:`CONFLICT_SD` combined standard deviations (``dist``) from the reading."""
    if not dist > CONFLICT_SD:
        return None
    held = ("R0 is held at the reading (cut) and the other parameters are estimated at it" if meter.cut
            else "the prior pulls R0 only part of the way (mode prior)")
    return {"code": "re_conflict",
            "short": f"R0 from the data {r0:.4g} ohm vs meter {meter.value:.4g} ohm ({dist:.0f} sd)",
            "message": f"the data with model {label} put R0 at {r0:.5g} +/- {sd_data:.2g} ohm; the "
                       f"ohmmeter reads {meter.value:.5g} +/- {meter.sd:.2g} ohm, {dist:.1f} combined "
                       f"standard deviations apart: {held}. The model puts other physics into R0 (a missing "
                       "coil or mechanical term: try diagnose), or the reading includes the leads."}


def held_covariance(cov_cut: np.ndarray, i: int, per_ohm_v: np.ndarray, sd_z: float,
                    meter: Meter) -> np.ndarray:
    """The sampler's start covariance when it samples with ``R0`` (index ``i``) held: the cut
    covariance ``cov_cut`` (:func:`cut_covariance`) less the reading's variance carried along the
    regression (``per_ohm_v`` per ohm, :func:`per_ohm`), with ``R0`` itself ``sd·PIN`` wide."""
    v = np.asarray(per_ohm_v, float) * (meter.sd / sd_z)
    v[i] = 1.0
    cov = np.array(cov_cut, float) - sd_z**2 * np.outer(v, v)
    cov[i, :] = 0.0
    cov[:, i] = 0.0
    cov[i, i] = (meter.held_sd / meter.sd * sd_z) ** 2
    return 0.5 * (cov + cov.T)


def cut_rng(seed: int) -> np.random.Generator:
    """The stream the cut's draws of the reading come from: its own, derived from the run's seed."""
    return np.random.default_rng([int(seed), 0x0E7E])


def move_draws(x: np.ndarray, params, i: int, per_ohm: np.ndarray, meter: Meter,
               rng: np.random.Generator) -> np.ndarray:
    """Draws ``x (..., K)`` [SI] of ``params``, sampled with ``R0`` (index ``i``) held at the reading,
    moved to the cut posterior: ``R0`` becomes a draw of ``N(value, sd)`` (one per draw, from
    ``rng``) and every other parameter moves in its sampling space by ``per_ohm[j]`` times the change
    of ``R0`` [Ω] (its regression on ``R0``; zero for parameters the fit did not have).

    Working in ohms for ``R0`` keeps this right whatever sampling space ``R0`` has in ``params`` (a
    Normal prior samples it on its own scale, the default prior on its logarithm)."""
    x = np.asarray(x, float)
    r_new = meter.value + rng.normal(0.0, meter.sd, size=x.shape[:-1])
    d = r_new - x[..., i]
    g = np.asarray(per_ohm, float).copy()
    g[i] = 0.0
    z = params.to_z(x) + d[..., None] * g
    out = np.array(params.from_z(z), float)
    out[..., i] = r_new
    return out


def per_ohm(v: np.ndarray, sd_z: float, meter: Meter) -> np.ndarray:
    """The regression ``v`` (per unit of ``R0``'s sampling space, :func:`cut_covariance`) per ohm
    of ``R0`` at the reading: ``v · sd_z / sd``."""
    return np.asarray(v, float) * (sd_z / meter.sd)
