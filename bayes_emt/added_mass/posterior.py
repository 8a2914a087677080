"""Joint posterior of an added-mass pair: both recordings sampled with shared physics.

One parameter vector ``(m, c, k, phi_raw, R0, coil..., noise of each run)`` explains both
recordings: the base run sees the moving mass ``m``, the loaded run ``m + Δm``
(:class:`~bayes_emt.added_mass.JointModel` maps it to each run's ``(ζ, ω0, φ̄, R0, coil...)``). The
likelihood is the product of the two runs' likelihoods
(:class:`~bayes_emt.inference.likelihood.Likelihood`, same noise model, each run with its own
``sigma_rel`` and ``sigma_abs``: two recordings need not share an instrument range). The priors of
``m, c, k, phi_raw`` are log-uniform over ten decades
(:data:`~bayes_emt.added_mass.fit.PHYSICAL_PARAMS`); the shared parameters keep the model's priors.

This is stricter than pairing independent posteriors of the two runs
(:func:`~bayes_emt.inference.posterior.physical_from_pair`, the Bayesian version of the paper's two-fit
formulas): there ``ζ`` and ``φ̄`` come from the base run alone, the loaded run contributes only
``ω0'``, and nothing checks that one ``(m, c, k, φ)`` explains both. Here every datum informs
every physical parameter, and a pair that cannot share them shows up as a poor fit (compare
the joint least-squares fit's F-test, :func:`~bayes_emt.added_mass.fit_added_mass`).

The sampler, stopping rule, checkpoints and resume are those of :mod:`bayes_emt.inference.sampling`;
the walkers start around the joint least-squares fit and its covariance.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._json import strict_json
from ..inference.likelihood import (
    Likelihood,
    LikelihoodKind,
    SamplingSpaceDensity,
    _sha256,
    measurement_sha256,
    noise_param_set,
)
from ..inference.posterior import _LOG_LIK_CHUNK, DERIVED, Posterior
from ..measurement import Measurement
from ..models import Model
from ..params import ParamSet
from .fit import PHYSICAL_NAMES, AddedMassResult, JointModel, fit_added_mass

__all__ = ["AddedMassLikelihood", "AddedMassPosterior", "sample_added_mass", "RUNS"]

#: The two runs, in parameter-suffix order.
RUNS = ("base", "loaded")
_MECH_UNITS = {"zeta": "1", "omega0": "rad/s", "phi": "N/(A kg^0.5)"}


def _run_noise(noise: ParamSet, run: str) -> ParamSet:
    """The noise parameters of one run, renamed ``sigma_rel_<run>``, ``sigma_abs_<run>``."""
    return ParamSet(replace(s, name=f"{s.name}_{run}", description=f"{s.description} ({run} run)")
                    for s in noise)


@dataclass(frozen=True, eq=False)
class AddedMassLikelihood(SamplingSpaceDensity):
    """``log p(Y_base, Y_loaded | x)`` for the joint vector ``x`` of :class:`JointModel` plus
    each run's noise scales, vectorised over leading axes.

    Parameters
    ----------
    joint : the pair's :class:`~bayes_emt.added_mass.JointModel` (model, ``delta_m`` [kg], priors).
    base, loaded : the recordings without and with the added mass.
    kind, nu : the noise distribution (:class:`~bayes_emt.inference.likelihood.Likelihood`); a sampled
        ``nu`` is not offered for pairs.
    noise_params : the noise priors of *each* run (names ``sigma_rel``, ``sigma_abs`` and, with
        ``noise="correlated"``, ``sigma_disc``, ``ell``).
    noise : ``"white"`` or ``"correlated"`` (:class:`~bayes_emt.inference.likelihood.Likelihood`).

    Attributes
    ----------
    params : ``joint.params`` then ``sigma_rel_base, sigma_abs_base, sigma_rel_loaded,
        sigma_abs_loaded``.
    runs : the two single-run likelihoods (``base``, ``loaded``), evaluated at the run vectors
        the joint vector implies.
    """

    joint: JointModel
    base: Measurement
    loaded: Measurement
    kind: LikelihoodKind = "gaussian"
    nu: float | None = 4.0
    noise_params: ParamSet | None = None
    noise: str = "white"

    def __post_init__(self):
        if self.kind == "student" and self.nu is None:
            raise ValueError("a sampled Student-t nu is not offered for added-mass pairs; give a number")
        noise = noise_param_set(self.kind, self.nu, self.noise) if self.noise_params is None \
            else self.noise_params
        runs = tuple(Likelihood(self.joint.model, m, self.kind, self.nu, noise, self.noise)
                     for m in (self.base, self.loaded))
        object.__setattr__(self, "noise_params", noise)
        object.__setattr__(self, "runs", runs)
        object.__setattr__(self, "params", self.joint.params + _run_noise(noise, "base")
                           + _run_noise(noise, "loaded"))

    # ---- shape -----------------------------------------------------------------------------
    @property
    def model(self) -> Model:
        return self.joint.model

    @property
    def delta_m(self) -> float:
        return self.joint.delta_m

    @property
    def ndim(self) -> int:
        return len(self.params)

    @property
    def n_points(self) -> tuple[int, int]:
        return self.base.n_points, self.loaded.n_points

    @property
    def sample_nu(self) -> bool:
        return False

    @property
    def label(self) -> str:
        return (f"{self.base.source} + {self.loaded.source} (added {self.delta_m:+g} kg), "
                f"model {self.model.label}")

    def describe(self) -> str:
        return self.runs[0].describe() + ", each run its own sigma_rel and sigma_abs"

    def identity(self) -> dict:
        """What a checkpoint must match to be resumed (both recordings by SHA-256)."""
        ident = self.runs[0].identity()
        data = (measurement_sha256(self.base) + measurement_sha256(self.loaded)).encode()
        ident.update({"model": f"{self.model.label} added-mass pair", "names": list(self.params.names),
                      "delta_m": self.delta_m, "n_points": list(self.n_points),
                      "priors_sha256": _sha256(json.dumps(self.params.to_dict(), sort_keys=True).encode()),
                      "data_sha256": _sha256(data),
                      "source": self.label})
        return ident

    # ---- pieces ----------------------------------------------------------------------------
    def run_thetas(self, x) -> tuple[np.ndarray, np.ndarray]:
        """Each run's full vector (model parameters, ``sigma_rel``, ``sigma_abs``) from ``x (..., k)``."""
        x = np.asarray(x, float)
        p, n = len(self.joint.params), len(self.noise_params)
        tb, tl = self.joint.thetas(x[..., :p])
        return (np.concatenate([tb, x[..., p : p + n]], axis=-1),
                np.concatenate([tl, x[..., p + n : p + 2 * n]], axis=-1))

    def model_thetas(self, x) -> tuple[np.ndarray, np.ndarray]:
        """Each run's model vector ``(ζ, ω0, φ̄, R0, coil...)`` from ``x (..., k)``."""
        k = self.model.ndim
        tb, tl = self.run_thetas(x)
        return tb[..., :k], tl[..., :k]

    # ---- densities ---------------------------------------------------------------------------
    def pointwise(self, x) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood per frequency of each run [nats]: ``((..., F_base), (..., F_loaded))``."""
        tb, tl = self.run_thetas(x)
        return self.runs[0].pointwise(tb), self.runs[1].pointwise(tl)

    def __call__(self, x) -> np.ndarray:
        """Total log-likelihood of both recordings [nats], shape ``x.shape[:-1]``."""
        pb, pl = self.pointwise(x)
        return np.sum(pb, axis=-1) + np.sum(pl, axis=-1)


def _mechanics(model: Model, theta) -> dict[str, np.ndarray]:
    z, w, p = model.mechanics(theta)
    return {"zeta": np.asarray(z, float), "omega0": np.asarray(w, float), "phi": np.asarray(p, float)}


@dataclass(frozen=True, eq=False, repr=False)
class AddedMassPosterior(Posterior):
    """Posterior draws of an added-mass pair (:class:`Posterior` with an
    :class:`AddedMassLikelihood`): the physical ``m, c, k, phi_raw``, the shared coil parameters
    and each run's noise, plus derived per-run ``ζ, ω0, φ̄`` (``_loaded`` suffix for the loaded run)
    and ``L_lf``."""

    fit: Mapping | None = None

    def theta(self) -> np.ndarray:
        """The base run's model vectors ``(n, k_model)`` implied by the draws."""
        return self.likelihood.model_thetas(self.flat())[0]

    def thetas(self) -> tuple[np.ndarray, np.ndarray]:
        """Both runs' model vectors, ``(n, k_model)`` each."""
        return self.likelihood.model_thetas(self.flat())

    def pointwise_log_likelihood(self) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood per draw and frequency of each run, ``(chains, draws, F_run)`` [nats]."""
        flat = self.flat()
        outs = [np.empty((flat.shape[0], n)) for n in self.likelihood.n_points]
        step = _LOG_LIK_CHUNK
        for i in range(0, flat.shape[0], step):
            for out, pw in zip(outs, self.likelihood.pointwise(flat[i : i + step]), strict=True):
                out[i : i + step] = pw
        return tuple(o.reshape(self.draws.shape[:2] + (-1,)) for o in outs)

    def derived(self, extra=None) -> dict[str, np.ndarray]:
        """Per draw ``(chains, draws)``: each run's ``ζ, ω0, φ̄`` and the coil's ``L_lf``."""
        tb, tl = self.likelihood.model_thetas(self.draws)
        out = {}
        for suffix, th in (("", tb), ("_loaded", tl)):
            out.update({f"{k}{suffix}": v for k, v in _mechanics(self.model, th).items()})
        out.update({name: np.asarray(fn(self.model, tb), float) for name, (_, _, fn) in DERIVED.items()})
        return out

    def derived_units(self) -> dict[str, str]:
        units = {f"{k}{s}": u for k, u in _MECH_UNITS.items() for s in ("", "_loaded")}
        units.update({k: v[0] for k, v in DERIVED.items()})
        return units

    def to_json_dict(self) -> dict:
        """The ``bayes-emt sample --loaded`` record: :meth:`Posterior.to_json_dict` plus ``delta_m``
        [kg], both sources, ``physical`` (``m, c, k, phi_raw`` rows) and the joint least-squares fit."""
        rec = super().to_json_dict()
        rec.update({"delta_m": self.likelihood.delta_m,
                    "sources": [self.likelihood.base.source, self.likelihood.loaded.source],
                    "physical": {k: rec["parameters"][k] for k in PHYSICAL_NAMES},
                    "joint_fit": None if self.fit is None else strict_json(dict(self.fit))})
        return rec

    def _attrs(self) -> dict:
        lik = self.likelihood
        return {**self._model_attrs(), **self._run_attrs(), "kind": "added_mass",
                "delta_m_kg": float(lik.delta_m), "source": lik.base.source,
                "source_loaded": lik.loaded.source,
                "measurement_meta": lik.base.meta_json(), "measurement_meta_loaded": lik.loaded.meta_json(),
                "joint_fit": json.dumps(None if self.fit is None else strict_json(dict(self.fit)))}

    def to_datatree(self):
        """ArviZ ``DataTree`` as :meth:`Posterior.to_datatree`, with each run's data on its own
        dimension (``omega_base``, ``omega_loaded``): ``log_likelihood`` holds ``Y_base`` and
        ``Y_loaded`` (``az.loo(dt, var_name="Y_base")``), ``observed_data`` ``Y_<run>_real/imag`` [S],
        ``constant_data`` ``omega_<run>_rad_s``; the attribute ``kind`` is ``added_mass``."""
        import arviz as az

        lik = self.likelihood
        post = {name: self.draws[..., i] for i, name in enumerate(self.names)}
        derived = self.derived()
        post.update(derived)
        ll = dict(zip((f"Y_{r}" for r in RUNS), self.pointwise_log_likelihood(), strict=True))
        obs, const, dims, coords = {}, {}, {}, {"draw": self.steps}
        for run, meas in zip(RUNS, (lik.base, lik.loaded), strict=True):
            d = [f"omega_{run}"]
            coords[d[0]] = meas.omega
            obs[f"Y_{run}_real"], obs[f"Y_{run}_imag"] = meas.Y.real, meas.Y.imag
            const[f"omega_{run}_rad_s"] = meas.omega
            if meas.weights is not None:
                const[f"weights_{run}"] = meas.weights
            for name in ("", "_real", "_imag"):
                dims[f"Y_{run}{name}"] = d
            dims[f"omega_{run}_rad_s"] = dims[f"weights_{run}"] = d
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Found chain dimension to be longer")
            dt = az.from_dict({"posterior": post, "log_likelihood": ll,
                               "sample_stats": {"lp": self.log_prob, "loglik": self.log_lik},
                               "observed_data": obs, "constant_data": const}, dims=dims, coords=coords)
        units = dict(zip(self.names, lik.params.units, strict=True))
        units.update(self.derived_units())
        for name in post:
            dt["posterior"][name].attrs["units"] = units[name]
        for group in ("log_likelihood", "observed_data", "constant_data"):
            for run in RUNS:
                dt[group][f"omega_{run}"].attrs["units"] = "rad/s"
        for name in obs:
            dt["observed_data"][name].attrs["units"] = "S"
        dt.attrs.update(self._attrs())
        return dt


def read_added_mass_posterior(dt) -> AddedMassPosterior:
    """Rebuild an :class:`AddedMassPosterior` from its ``DataTree`` (``kind == "added_mass"``);
    :func:`bayes_emt.api.read_posterior` dispatches here."""
    from ..inference.posterior import stored_model, stored_param_set, stored_record

    a = dt.attrs
    specs = stored_param_set(a)
    model = stored_model(a, ParamSet([]))
    shared = [n for n in model.names if n not in ("zeta", "omega0", "phi")]
    model = model.with_priors({n: specs[n].prior for n in shared})
    joint = JointModel(model, float(a["delta_m_kg"]), physical=ParamSet(specs[:4]))
    meas = []
    for run, meta in zip(RUNS, ("measurement_meta", "measurement_meta_loaded"), strict=True):
        const = dt["constant_data"]
        w = const[f"weights_{run}"].values if f"weights_{run}" in const else None
        Y = dt["observed_data"][f"Y_{run}_real"].values + 1j * dt["observed_data"][f"Y_{run}_imag"].values
        meas.append(Measurement(const[f"omega_{run}_rad_s"].values, Y, weights=w, meta=json.loads(a[meta])))
    p = len(joint.params)
    kind = str(a.get("noise", "white"))
    n = 4 if kind == "correlated" else 2
    noise = ParamSet(replace(s, name=s.name.removesuffix("_base"),
                             description=s.description.removesuffix(" (base run)")) for s in specs[p : p + n])
    nu = None if a["nu"] == "sampled" else float(a["nu"])
    lik = AddedMassLikelihood(joint, meas[0], meas[1], str(a["likelihood"]),
                              None if nu is None or nu < 0 else nu, noise, kind)
    return AddedMassPosterior(lik, **stored_record(dt, specs.names), fit=json.loads(a["joint_fit"]))


def _fit_summary(r: AddedMassResult) -> dict:
    return {"values": r.values, "stderr": r.stderr, "consistency": r.consistency,
            "rms_rel_residual": list(r.rms_rel_residual), "success": r.success}


def sample_added_mass(base: Measurement, loaded: Measurement, delta_m: float, model: Model, *,
                      fit: AddedMassResult | None = None, seed: int = 0, max_steps: int | None = None,
                      checkpoint: str | Path | None = None, resume: bool = False, overwrite: bool = False,
                      progress: bool | None = None, likelihood: LikelihoodKind = "gaussian",
                      nu: float | None = 4.0, noise_params: ParamSet | None = None,
                      physical_params: ParamSet | None = None, settings=None,
                      noise: str = "white") -> AddedMassPosterior:
    """Sample the joint posterior of an added-mass pair (module docstring).

    Parameters
    ----------
    base, loaded : the recordings without and with the added mass (rad/s, S).
    delta_m : mass added for ``loaded`` [kg] (negative: removed).
    model : the coil model both runs share; its ``params`` carry the shared parameters' priors.
    fit : the joint least-squares fit to start from (default :func:`~bayes_emt.added_mass.fit_added_mass`).
    physical_params : priors of ``m, c, k, phi_raw`` (default log-uniform, ten decades).
    Others as :func:`~bayes_emt.inference.sampling.sample_posterior` (``noise_params``: each run's
    noise priors).
    """
    from ..inference.sampling import SamplerSettings, noise_start, run_ensemble, start_ball
    from ..inference.start import extra_noise_start

    if not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"delta_m must be a non-zero mass in kg, got {delta_m!r}")
    settings = SamplerSettings() if settings is None else settings
    t0 = time.perf_counter()
    joint = JointModel(model, float(delta_m), physical_params)
    lik = AddedMassLikelihood(joint, base, loaded, likelihood, nu, noise_params, noise)
    if fit is None:  # also when resuming: the record carries the fit the walkers started from
        fit = fit_added_mass(base, loaded, delta_m, model)

    def start(nwalkers):
        jp = lik.joint.params
        z0 = jp.to_z(jp.vector(fit.values))
        cov = fit.cov_z if fit.cov_z is not None and np.all(np.isfinite(fit.cov_z)) else \
            np.diag((1e-3 * np.maximum(np.abs(z0), 1.0)) ** 2)
        centre, spread = [], []
        run_th = lik.joint.thetas(jp.vector(fit.values)[None, :])
        for rl, th, meas, rms in zip(lik.runs, run_th, (base, loaded), fit.rms_rel_residual, strict=True):
            c, s = noise_start(rms, float(np.min(np.abs(meas.Y))))
            ce, se = extra_noise_start(rl, th[0])
            centre += c + ce
            spread += s + se
        return start_ball(lik, z0, cov, centre, spread, nwalkers, np.random.default_rng(seed))

    run = run_ensemble(lik, start, seed=seed, max_steps=max_steps, checkpoint=checkpoint, resume=resume,
                       overwrite=overwrite, progress=progress, settings=settings)
    run["wall_time"] = time.perf_counter() - t0
    return AddedMassPosterior.from_chain(lik, **run, fit=_fit_summary(fit))
