"""The posterior: a frozen record of thinned draws with diagnostics, and its ArviZ ``DataTree``.

Draws are stored in physical units (the documented names), walkers as ``chain`` and kept steps as
``draw`` (the ``draw`` coordinate is the sampler step, so burn-in and thinning stay visible).
Burn-in is ``⌈2 τ_max⌉`` steps; the thinning ``⌊τ_min/2⌋`` or more, so that at most
``max_draws`` draws are kept: this is ``az.from_emcee(...).isel(draw=slice(burn, None, thin))``
done before the conversion (the whole chain never has to sit in memory in physical units), and
both numbers are recorded in the file.

The saved ``DataTree`` (``Posterior.save``; read back with ``az.from_netcdf`` or
:func:`read_posterior`) holds

* ``posterior``: every sampled parameter (physical units in each variable's ``units``) and the
  derived quantities (:data:`DERIVED`);
* ``log_likelihood``: ``Y`` per draw and frequency (dim ``omega``), for PSIS-LOO and the
  discrepancy analysis;
* ``sample_stats``: ``lp`` (log posterior in sampling space) and ``loglik`` (total log-likelihood);
* ``observed_data``: ``Y_real``, ``Y_imag`` [S] (netCDF has no complex type);
* ``constant_data``: ``omega`` [rad/s] (and the measurement's weights, if any);
* attributes: model, rings, n_turns, terms, likelihood, priors (JSON, every parameter), seed,
  package versions, and the convergence numbers (τ, ESS, steps, burn, thin, verdict history).
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from .._record import Record, Table
from ..models import Model
from ..models.derived import DERIVED
from ..params import ParamSet
from .likelihood import Likelihood

__all__ = ["Posterior", "DERIVED", "read_posterior", "posterior_from_datatree", "physical_from_pair",
           "stored_model", "stored_param_set", "stored_record"]

_LOG_LIK_CHUNK = 64  # draws per vectorised pointwise-likelihood call (memory: chunk × F × terms)


def _versions() -> dict:
    out = {}
    for pkg in ("bayes_emt", "emcee", "arviz", "numpy", "scipy", "xarray"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


#: how a table names the noise kind
_NOISE_WORDS = {"correlated": "with model discrepancy", "white": "white: if the model were exact"}


@dataclass(frozen=True, eq=False, repr=False)
class Posterior(Record):
    """Posterior draws of one model given one measurement (no sampler state inside).

    Attributes
    ----------
    likelihood : the :class:`~bayes_emt.inference.likelihood.Likelihood` (model with priors, data, noise).
    draws : (chains, draws, k) physical values [SI], names ``likelihood.params.names``.
    steps : (draws,) the sampler step of each kept draw.
    log_prob : (chains, draws) unnormalised log posterior in sampling space.
    log_lik : (chains, draws) total log-likelihood [nats].
    tau : (k,) integrated autocorrelation times [steps] on the whole chain.
    ess : (k,) effective sample sizes ``chains · (n_steps − burn) / tau``.
    n_steps, burn, thin : chain length, burn-in and thinning [steps].
    converged : whether the stopping rule was met (:mod:`bayes_emt.inference.sampling`).
    seed : the run's seed.
    message : the stopping rule's verdict in words.
    acceptance : fraction of accepted proposals after burn-in.
    wall_time : seconds spent by the call that produced this record.
    history : the stopping-rule verdict at every check.
    settings : the sampler settings used.
    checkpoint : the HDF5 checkpoint path, if any.
    """

    likelihood: Likelihood
    draws: np.ndarray
    steps: np.ndarray
    log_prob: np.ndarray
    log_lik: np.ndarray
    tau: np.ndarray
    ess: np.ndarray
    n_steps: int
    burn: int
    thin: int
    converged: bool
    seed: int
    message: str
    acceptance: float
    wall_time: float
    history: tuple = ()
    settings: Mapping = field(default_factory=dict)
    checkpoint: str | None = None

    def __post_init__(self):
        for name in ("draws", "steps", "log_prob", "log_lik", "tau", "ess"):
            a = np.array(getattr(self, name))
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "history", tuple(self.history))

    @classmethod
    def from_chain(cls, lik, chain, log_prob, blobs, *, tau, burn: int, max_draws: int,
                   **kwargs) -> Posterior:
        """Burn, thin and convert a sampling-space chain ``(steps, walkers, k)`` (emcee layout)."""
        n, nwalkers = chain.shape[:2]
        burn = int(min(max(burn, 0), n - 1))
        thin = max(1, int(np.min(tau) // 2))
        while nwalkers * ((n - burn - 1) // thin + 1) > max_draws and thin < n:
            thin += 1
        sl = slice(burn, None, thin)
        draws = lik.params.from_z(np.swapaxes(chain[sl], 0, 1))
        ll = np.full(log_prob.shape, np.nan) if blobs is None else np.asarray(blobs, float)
        ess = nwalkers * max(n - burn, 0) / np.asarray(tau, float)
        return cls(lik, draws, np.arange(n)[sl], np.swapaxes(log_prob[sl], 0, 1), np.swapaxes(ll[sl], 0, 1),
                   np.asarray(tau, float), ess, int(n), burn, thin, **kwargs)

    # ---- access --------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return self.likelihood.params.names

    @property
    def model(self) -> Model:
        return self.likelihood.model

    @property
    def n_walkers(self) -> int:
        return int(self.draws.shape[0])

    def flat(self) -> np.ndarray:
        """All kept draws as ``(n, k)`` physical values (model parameters, then noise)."""
        return self.draws.reshape(-1, self.draws.shape[-1])

    def flat_z(self) -> np.ndarray:
        """All kept draws in sampling space ``(n, k)`` (bridge sampling works here)."""
        return self.likelihood.params.to_z(self.flat())

    def theta(self) -> np.ndarray:
        """Model parameters only, ``(n, k_model)`` (input of ``Model`` methods, shunt design)."""
        return self.flat()[:, : self.model.ndim]

    def pointwise_log_likelihood(self) -> np.ndarray:
        """Log-likelihood per draw and frequency ``(chains, draws, F)`` [nats] (PSIS-LOO)."""
        flat = self.flat()
        out = np.empty((flat.shape[0], self.likelihood.n_points))
        for i in range(0, flat.shape[0], _LOG_LIK_CHUNK):
            out[i : i + _LOG_LIK_CHUNK] = self.likelihood.pointwise(flat[i : i + _LOG_LIK_CHUNK])
        return out.reshape(self.draws.shape[:2] + (-1,))

    def predictive(self, n_draws: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Posterior-predictive draws at the measured frequencies: ``(Y_model, Y_replicated)`` [S],
        each ``(n, F)``, for ``n = min(n_draws, kept draws)`` draws chosen without replacement
        (``seed`` fixes the choice and the replicated noise; see ``Likelihood.predictive``)."""
        rng = np.random.default_rng(seed)
        flat = self.flat()
        take = flat[rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)]
        return self.likelihood.predictive(take, rng)

    # ---- summaries -----------------------------------------------------------------------------
    def summary_rows(self, prob: float = 0.9) -> list[dict]:
        """Median, central ``prob`` interval (``q05``/``q95`` for 0.9), ESS, τ and unit per parameter."""
        lo, hi = (1 - prob) / 2, (1 + prob) / 2
        q = np.quantile(self.flat(), [0.5, lo, hi], axis=0)
        return [{"name": s.name, "median": float(q[0, i]), "q05": float(q[1, i]), "q95": float(q[2, i]),
                 "ess": float(self.ess[i]), "tau": float(self.tau[i]), "unit": s.unit}
                for i, s in enumerate(self.likelihood.params)]

    def derived(self, extra: Mapping[str, tuple[str, str, Callable]] | None = None) -> dict[str, np.ndarray]:
        """Derived quantities per draw, ``(chains, draws)`` each: :data:`DERIVED` plus ``extra``
        (same form: name → (unit, description, f(model, theta))). Pairs of runs (added mass) go
        through :func:`physical_from_pair`."""
        th = self.draws[..., : self.model.ndim]
        return {name: np.asarray(fn(self.model, th), float)
                for name, (_, _, fn) in {**DERIVED, **(extra or {})}.items()}

    def to_json_dict(self) -> dict:
        """The ``bayes-emt sample --json`` record."""
        return {"model": self.model.spec, "rings": self.model.rings, "converged": bool(self.converged),
                "message": self.message, "n_steps": self.n_steps, "tau_max": float(np.max(self.tau)),
                "burn": self.burn, "thin": self.thin, "n_walkers": self.n_walkers,
                "n_draws_kept": int(self.draws.shape[0] * self.draws.shape[1]),
                "acceptance": self.acceptance, "seed": self.seed, "likelihood": self.likelihood.kind,
                "noise": self.likelihood.noise,
                "wall_time_s": self.wall_time,
                "parameters": {r["name"]: {k: r[k] for k in ("median", "q05", "q95", "ess", "tau", "unit")}
                               for r in self.summary_rows()},
                "derived": {name: {"median": float(np.median(v)), "q05": float(np.quantile(v, 0.05)),
                                   "q95": float(np.quantile(v, 0.95)), "unit": self.derived_units()[name]}
                            for name, v in self.derived().items()}}

    def derived_units(self) -> dict[str, str]:
        """Unit of each quantity :meth:`derived` returns."""
        return {k: v[0] for k, v in DERIVED.items()}

    # ---- what a person reads -------------------------------------------------------------------
    def headline(self) -> str:
        state = "converged" if self.converged else "NOT converged"
        return (f"{self.model.label} posterior, {state}: {self.n_steps} steps x {self.n_walkers} walkers, "
                f"{int(self.draws.shape[0] * self.draws.shape[1])} draws kept, seed {self.seed}")

    def tables(self) -> list[Table]:
        rows = tuple((r["name"], r["median"], r["q05"], r["q95"], r["unit"], r["ess"], r["tau"])
                     for r in self.summary_rows())
        units = self.derived_units()
        drows = tuple((f"{k} (derived)", float(np.median(v)), float(np.quantile(v, 0.05)),
                       float(np.quantile(v, 0.95)), units[k], "", "")
                      for k, v in self.derived().items() if np.all(np.isfinite(v)))
        note = (f"{'converged' if self.converged else 'NOT CONVERGED'}: {self.message}; burn {self.burn}, "
                f"thin {self.thin}, acceptance {self.acceptance:.2f}, {self.wall_time:.1f} s")
        return [Table(f"{self.model.label}: posterior median and central 90 % interval "
                      f"({self.likelihood.kind} likelihood, {_NOISE_WORDS[self.likelihood.noise]})",
                      ("parameter", "median", "5 %", "95 %", "unit", "ESS", "tau [steps]"), rows + drows,
                      (note,))]

    # ---- ArviZ -----------------------------------------------------------------------------------
    def _run_attrs(self) -> dict:
        """File attributes of the sampler run: seed, convergence numbers, settings, versions."""
        names = list(self.names)
        return {"priors": json.dumps(self.likelihood.params.to_dict()),
                "units": json.dumps(dict(zip(names, self.likelihood.params.units, strict=True))),
                "seed": int(self.seed), "converged": int(self.converged), "message": self.message,
                "n_steps": int(self.n_steps), "burn": int(self.burn), "thin": int(self.thin),
                "n_walkers": self.n_walkers, "acceptance": float(self.acceptance),
                "tau": json.dumps(dict(zip(names, map(float, self.tau), strict=True))),
                "ess": json.dumps(dict(zip(names, map(float, self.ess), strict=True))),
                "tau_max": float(np.max(self.tau)), "history": json.dumps(list(self.history)),
                "settings": json.dumps(dict(self.settings)), "wall_time_s": float(self.wall_time),
                "versions": json.dumps(_versions()), "inference_library": "emcee",
                "checkpoint": self.checkpoint or ""}

    def _model_attrs(self) -> dict:
        lik, model = self.likelihood, self.model
        return {"model": model.spec, "model_label": model.label,
                "rings": -1 if model.rings is None else int(model.rings),
                "n_turns": -1.0 if model.n_turns is None else float(model.n_turns),
                "terms": json.dumps([t.to_dict() for t in model.terms]),
                "model_record": json.dumps(model.to_dict()), "likelihood": lik.kind,
                "nu": "sampled" if lik.sample_nu else (-1.0 if lik.nu is None else float(lik.nu)),
                "noise": lik.noise, "noise_model": lik.describe()}

    def _attrs(self) -> dict:
        meas = self.likelihood.meas
        return {**self._model_attrs(), **self._run_attrs(), "kind": "single",
                "source": meas.source, "measurement_meta": meas.meta_json()}

    def to_datatree(self):
        """The ArviZ 1.x ``xarray.DataTree`` described in the module docstring."""
        import arviz as az

        lik, meas = self.likelihood, self.likelihood.meas
        post = {name: self.draws[..., i] for i, name in enumerate(self.names)}
        derived = self.derived()
        post.update(derived)
        const = {"omega_rad_s": meas.omega}
        if meas.weights is not None:
            const["weights"] = meas.weights
        with warnings.catch_warnings():
            # an ensemble has more walkers (chains) than kept draws per walker: expected here
            warnings.filterwarnings("ignore", message="Found chain dimension to be longer")
            dt = az.from_dict(
                {"posterior": post,
                 "log_likelihood": {"Y": self.pointwise_log_likelihood()},
                 "sample_stats": {"lp": self.log_prob, "loglik": self.log_lik},
                 "observed_data": {"Y_real": meas.Y.real, "Y_imag": meas.Y.imag},
                 "constant_data": const},
                dims={"Y": ["omega"], "Y_real": ["omega"], "Y_imag": ["omega"], "omega_rad_s": ["omega"],
                      "weights": ["omega"]},
                coords={"omega": meas.omega, "draw": self.steps})
        units = dict(zip(self.names, lik.params.units, strict=True))
        units.update(self.derived_units())
        for name, unit in units.items():
            dt["posterior"][name].attrs["units"] = unit
        for group in ("log_likelihood", "observed_data", "constant_data"):
            dt[group]["omega"].attrs["units"] = "rad/s"
        dt["constant_data"]["omega_rad_s"].attrs["units"] = "rad/s"
        for name in ("Y_real", "Y_imag"):
            dt["observed_data"][name].attrs["units"] = "S"
        dt.attrs.update(self._attrs())
        return dt

    def save(self, path: str | Path) -> Path:
        """Write the DataTree to netCDF atomically (a crash never leaves half a file)."""
        dt = self.to_datatree()
        with atomic_path(path, suffix=".nc") as tmp:
            dt.to_netcdf(tmp)
        return Path(path)


def read_posterior(path: str | Path) -> Posterior:
    """Rebuild a single-recording :class:`Posterior` from a file written by :meth:`Posterior.save`
    (:func:`bayes_emt.api.read_posterior` reads every kind)."""
    import arviz as az

    return posterior_from_datatree(az.from_netcdf(path), where=str(path))


def posterior_from_datatree(dt, *, where: str = "posterior") -> Posterior:
    """Rebuild a :class:`Posterior` from its saved ``DataTree``.

    The model comes back from its name, rings, turns and stored priors; a model the registry
    cannot rebuild (e.g. augmented by the discrepancy step) raises ``ValueError``.
    """
    from ..measurement import Measurement

    a = dt.attrs
    if a.get("kind") != "single":
        raise ValueError(f"{where}: a {a.get('kind')!r} posterior, not a single-recording one; read it "
                         "with bayes_emt.read_posterior, which knows every kind")
    specs = stored_param_set(a)
    model = stored_model(a, specs, where=where)
    k = model.ndim
    omega = dt["constant_data"]["omega_rad_s"].values
    Y = dt["observed_data"]["Y_real"].values + 1j * dt["observed_data"]["Y_imag"].values
    w = dt["constant_data"]["weights"].values if "weights" in dt["constant_data"] else None
    meas = Measurement(omega, Y, weights=w, meta=json.loads(a["measurement_meta"]))
    nu = None if a["nu"] == "sampled" else float(a["nu"])
    lik = Likelihood(model, meas, str(a["likelihood"]), None if nu is None or nu < 0 else nu,
                     ParamSet(specs[k:]), str(a.get("noise", "white")))
    return Posterior(lik, **stored_record(dt, specs.names))


def stored_model(attrs, specs: ParamSet, *, where: str = "posterior") -> Model:
    """The model of a saved run, rebuilt from its stored terms (:meth:`Model.to_dict`) with the stored
    priors of its parameters (the first ``model.ndim`` of ``specs``)."""
    from ..models import model_from_dict

    if "model_record" in attrs:
        model = model_from_dict(json.loads(attrs["model_record"]), where=where)
    else:  # written before models were stored by their terms
        rings = None if int(attrs["rings"]) < 0 else int(attrs["rings"])
        model = model_from_dict({"spec": str(attrs["model"]), "rings": rings,
                                 "n_turns": float(attrs["n_turns"])}, where=where)
    return model.with_priors({s.name: s.prior for s in specs[: model.ndim]})


def stored_param_set(attrs) -> ParamSet:
    """The sampled parameters with their priors, from a saved DataTree's ``priors`` attribute."""
    from ..params import ParamSpec, prior_from_dict

    return ParamSet(ParamSpec(d["name"], d["unit"], d["label"], prior_from_dict(d["prior"]),
                              d["description"]) for d in json.loads(attrs["priors"]))


def stored_record(dt, names) -> dict:
    """The :class:`Posterior` fields other than ``likelihood`` from a saved DataTree."""
    a, post, ss = dt.attrs, dt["posterior"], dt["sample_stats"]
    tau, ess = json.loads(a["tau"]), json.loads(a["ess"])
    return {"draws": np.stack([post[n].transpose("chain", "draw").values for n in names], axis=-1),
            "steps": post["draw"].values, "log_prob": ss["lp"].transpose("chain", "draw").values,
            "log_lik": ss["loglik"].transpose("chain", "draw").values,
            "tau": np.array([tau[n] for n in names]), "ess": np.array([ess[n] for n in names]),
            "n_steps": int(a["n_steps"]), "burn": int(a["burn"]), "thin": int(a["thin"]),
            "converged": bool(int(a["converged"])), "seed": int(a["seed"]), "message": str(a["message"]),
            "acceptance": float(a["acceptance"]), "wall_time": float(a["wall_time_s"]),
            "history": tuple(json.loads(a["history"])), "settings": json.loads(a["settings"]),
            "checkpoint": str(a["checkpoint"]) or None}


def physical_from_pair(base: Posterior, loaded: Posterior, delta_m: float, *,
                       seed: int = 0) -> dict[str, np.ndarray]:
    """Posterior draws of the physical ``m, c, k, phi_raw`` [kg, N s/m, N/m, N/A] from an
    added-mass pair (paper, Appendix B): ``m = Δm ω0'²/(ω0² − ω0'²)``, ``k = m ω0²``, ``c = 2 ζ m ω0``,
    ``φ = φ̄ √m``, with ``ζ, ω0, φ̄`` of the base run and ``ω0'`` of the run with ``delta_m`` [kg]
    added.

    The two recordings are independent, so their joint posterior is the product and randomly
    paired draws (``seed``) are draws of it. Draws implying a non-positive mass give NaN.
    A joint posterior with shared physical parameters (``added_mass.JointModel``) is the
    stricter alternative.
    """
    if not (math.isfinite(delta_m) and delta_m != 0):
        raise ValueError(f"delta_m must be a non-zero mass in kg, got {delta_m!r}")
    rng = np.random.default_rng(seed)
    zeta, w0, phib = base.model.mechanics(base.theta())
    w1 = loaded.model.mechanics(loaded.theta())[1]
    w1 = w1[rng.integers(w1.size, size=w0.size)]
    with np.errstate(divide="ignore", invalid="ignore"):
        m = delta_m * w1**2 / (w0**2 - w1**2)
        ok = (m > 0) & (m + delta_m > 0)
        m = np.where(ok, m, np.nan)
        return {"m": m, "c": 2 * zeta * m * w0, "k": m * w0**2, "phi_raw": phib * np.sqrt(m)}
