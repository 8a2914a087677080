"""The posterior: a frozen record of thinned draws, diagnostics, and its ArviZ ``DataTree``.

Draws are stored in physical units (SPEC §6 names), walkers as ``chain`` and steps as ``draw``.
Burn-in is ``⌈2 τ_max⌉``; the thinning is ``⌊τ_min/2⌋`` or more, so that at most ``max_draws``
draws are kept (the pointwise log-likelihood, one value per draw and frequency, is the large part
of the file).
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field
from importlib import metadata

import numpy as np

from ._atomic import atomic_path
from .likelihood import Likelihood

__all__ = ["Posterior", "load_posterior_datatree"]


def _versions() -> dict:
    out = {}
    for pkg in ("bayes_emt", "emcee", "arviz", "numpy", "scipy"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


@dataclass(frozen=True)
class Posterior:
    """Posterior draws of one model given one measurement.

    Attributes
    ----------
    likelihood : the :class:`~bayes_emt.likelihood.Likelihood` (model, data, noise model).
    draws : (chains, draws, k) physical values, names ``likelihood.params.names``.
    log_prob : (chains, draws) unnormalised log posterior in sampling space.
    tau : (k,) integrated autocorrelation times [steps] on the whole chain.
    ess : (k,) effective sample sizes ``chains · (n_steps − burn) / tau``.
    n_steps, burn, thin : chain length, burn-in and thinning [steps].
    converged : whether the stopping rule was met (see :mod:`bayes_emt.sampling`).
    acceptance : mean acceptance fraction.
    """

    likelihood: Likelihood
    draws: np.ndarray
    log_prob: np.ndarray
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
    history: list = field(default_factory=list)

    @classmethod
    def from_backend(cls, lik, backend, *, tau, converged, seed, message, history, max_draws, wall_time):
        n = backend.iteration
        nwalkers = backend.shape[0]
        burn = min(int(math.ceil(2 * np.max(tau))), n - 1)
        thin = max(1, int(np.min(tau) // 2))
        while nwalkers * ((n - burn - 1) // thin + 1) > max_draws and thin < n:
            thin += 1
        z = backend.get_chain(discard=burn, thin=thin)  # (draws, walkers, k)
        lp = backend.get_log_prob(discard=burn, thin=thin)
        draws = lik.params.from_z(np.swapaxes(z, 0, 1))
        ess = nwalkers * max(n - burn, 0) / tau
        acc = float(np.mean(backend.accepted / max(n, 1)))
        return cls(lik, draws, np.swapaxes(lp, 0, 1), np.asarray(tau, float), ess, int(n), burn, thin,
                   bool(converged), int(seed), message, acc, float(wall_time), list(history))

    # ---- summaries ---------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return self.likelihood.params.names

    @property
    def model(self):
        return self.likelihood.model

    def flat(self) -> np.ndarray:
        """All kept draws as ``(n, k)``."""
        return self.draws.reshape(-1, self.draws.shape[-1])

    def summary_rows(self) -> list[dict]:
        """Median, 5 % and 95 % quantiles, ESS, τ and unit per parameter."""
        q = np.quantile(self.flat(), [0.5, 0.05, 0.95], axis=0)
        return [{"name": s.name, "median": float(q[0, i]), "q05": float(q[1, i]), "q95": float(q[2, i]),
                 "ess": float(self.ess[i]), "tau": float(self.tau[i]), "unit": s.unit}
                for i, s in enumerate(self.likelihood.params)]

    def derived(self) -> dict[str, np.ndarray]:
        """Derived quantities per draw: the coil's inductance at the lowest measured frequency [H]."""
        k = self.model.ndim
        theta = self.flat()[:, :k]
        w = np.array([self.likelihood.meas.omega[0]])
        zc = self.model.coil_impedance(w, theta)[:, 0]
        return {"L_lf": zc.imag / w[0]}

    def to_json_dict(self) -> dict:
        return {"model": self.model.name, "rings": self.model.rings, "converged": self.converged,
                "message": self.message, "n_steps": self.n_steps, "tau_max": float(np.max(self.tau)),
                "burn": self.burn, "thin": self.thin, "n_walkers": int(self.draws.shape[0]),
                "n_draws_kept": int(self.draws.shape[0] * self.draws.shape[1]),
                "acceptance": self.acceptance, "seed": self.seed, "likelihood": self.likelihood.kind,
                "wall_time_s": self.wall_time,
                "parameters": {r["name"]: {k: r[k] for k in ("median", "q05", "q95", "ess", "tau", "unit")}
                               for r in self.summary_rows()}}

    # ---- ArviZ -------------------------------------------------------------------------------
    def to_datatree(self):
        """An ArviZ 1.x ``DataTree``: posterior, log_likelihood (per ``omega``), sample_stats,
        observed_data (Y as real/imag), constant_data (omega [rad/s]) and provenance attrs."""
        import arviz as az

        lik = self.likelihood
        meas = lik.meas
        ll = lik.pointwise(self.draws)
        post = {name: self.draws[..., i] for i, name in enumerate(self.names)}
        attrs = {"model": self.model.name, "model_label": self.model.label,
                 "rings": -1 if self.model.rings is None else self.model.rings,
                 "n_turns": self.model.n_turns, "likelihood": lik.kind, "nu": lik.nu,
                 "priors": json.dumps(lik.params.to_dict()), "units": json.dumps(
                     dict(zip(self.names, lik.params.units, strict=True))),
                 "seed": self.seed, "converged": int(self.converged), "message": self.message,
                 "n_steps": self.n_steps, "burn": self.burn, "thin": self.thin,
                 "tau": json.dumps(dict(zip(self.names, map(float, self.tau), strict=True))),
                 "ess": json.dumps(dict(zip(self.names, map(float, self.ess), strict=True))),
                 "source": meas.source, "versions": json.dumps(_versions()),
                 "inference_library": "emcee"}
        with warnings.catch_warnings():
            # an ensemble has more walkers (chains) than kept draws per walker: expected here
            warnings.filterwarnings("ignore", message="Found chain dimension to be longer")
            dt = az.from_dict(
                {"posterior": post,
                 "log_likelihood": {"Y": ll},
                 "sample_stats": {"lp": self.log_prob},
                 "observed_data": {"Y_real": meas.Y.real, "Y_imag": meas.Y.imag},
                 "constant_data": {"omega_rad_s": meas.omega}},
                dims={"Y": ["omega"], "Y_real": ["omega"], "Y_imag": ["omega"], "omega_rad_s": ["omega"]},
                coords={"omega": meas.omega})
        dt.attrs.update(attrs)
        return dt

    def save(self, path) -> None:
        """Write the DataTree to netCDF atomically."""
        dt = self.to_datatree()
        with atomic_path(path, suffix=".nc") as tmp:
            dt.to_netcdf(tmp)


def load_posterior_datatree(path):
    """Read a saved posterior (``az.from_netcdf``)."""
    import arviz as az

    return az.from_netcdf(path)
