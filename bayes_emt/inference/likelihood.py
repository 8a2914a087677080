"""The likelihood of a measured admittance, vectorised over parameter sets (walkers).

Noise model (what a metrologist states for an LCR meter or impedance analyser): the real and
imaginary parts of each measured ``Y_k`` carry independent errors of standard deviation

    σ_k = sqrt((σ_rel |Y_k|)² + σ_abs²) / w_k                                          [S]

a *relative* part ``σ_rel`` [1] (accuracy stated relative to the reading; the simulator's
``Y (1 + σ (e_r + j e_i))`` is exactly this with ``σ_abs = 0``) and an absolute floor ``σ_abs``
[S] (noise, cabling, quantisation). ``w_k`` are the measurement's optional per-point weights
(1 when absent), the same weights the least-squares fit applies to its residuals.

``|Y_k|`` is the **measured** magnitude, not the model's. The noise is a property of the
instrument reading, so it must not depend on the candidate parameters: with a model-dependent
scale, a poor parameter set could buy likelihood by predicting a larger |Y| (wider errors), and
the normalising term ``log σ_k`` would then pull the estimate towards larger admittance. At the
0.2 % noise of the paper the measured and true |Y| differ by 0.3 % of σ, a second-order effect;
the calibration script confirms the intervals cover as stated.

Correlation (``noise``): ``white`` is the above, errors independent across frequencies (the
posterior "if the model were exact"); ``correlated`` adds to that noise a model discrepancy of
relative size ``sigma_disc``, correlated over log-frequency (an Ornstein–Uhlenbeck process with an
inferred correlation length ``ell`` [decades], :mod:`bayes_emt.inference.discrepancy`), which is
the white likelihood as ``sigma_disc → 0``.

Both noise scales are sampled, in log space, with proper log-uniform priors
(:data:`NOISE_PARAMS`), identical for every model so evidences stay comparable.

Kinds
-----
``gaussian``: ``log p_k = −log(2π σ_k²) − |r_k|²/(2σ_k²)`` with ``r_k = Y_model − Y_k``;
``student``: the real and imaginary parts are independent Student-t with ``ν`` degrees of freedom
and scale ``σ_k`` (robust to outliers); ``ν`` fixed, or sampled (``nu=None``) with the prior of
:data:`NU_SPEC`.

The pointwise ``log p_k`` (one value per frequency) feeds PSIS-LOO and the discrepancy analysis;
:meth:`Likelihood.normalised_residuals` gives ``r_k/σ_k`` for whiteness tests. Every function
is NaN-free: ``-inf`` outside the prior support or wherever the model cannot be evaluated.

Evaluation (the statistical model above is unchanged by it): the model's admittance at the
measured frequencies goes through a checked fast path when the model has one
(:mod:`bayes_emt.inference.fastpath`: all six of the paper's models, and augmented models whose
terms all offer a kernel on ``s = jω``), and the Gaussian total
``__call__`` sums the noise terms without a logarithm per frequency where the absolute floor is
negligible or dominant (:mod:`bayes_emt.inference.noise`); it equals ``pointwise(θ).sum(-1)`` to
rounding (tests/test_likelihood_fastpath.py: 1e-10 relative in every noise regime).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import special

from ..measurement import Measurement
from ..models import Model
from ..params import NOISE_PARAMS, NU_SPEC, ParamSet, noise_param_set
from ..params.priors import LogUniform, Uniform
from .discrepancy import NOISE_KINDS, NoiseCorrelation, ou_rho
from .fastpath import JwPlan
from .magnitude import MagnitudeOnly
from .noise import GaussianNoiseSums

__all__ = ["NOISE_PARAMS", "NU_SPEC", "Likelihood", "LikelihoodKind", "MagnitudeLikelihood", "NoiseKind",
           "NOISE_KINDS",
           "SamplingSpaceDensity", "noise_param_set", "measurement_sha256"]

LikelihoodKind = Literal["gaussian", "student"]
NoiseKind = Literal["correlated", "white"]

class _BoxPrior:
    """``ParamSet.log_prior_z`` and ``from_z`` in one vectorised pass: log-uniform and uniform
    priors have a constant density in sampling space inside their support, so their columns cost
    one bounds check; other priors go through their specs."""

    def __init__(self, params: ParamSet):
        self.params = params
        self.log_cols = np.array([s.transform == "log" for s in params])
        box = [i for i, s in enumerate(params) if isinstance(s.prior, LogUniform | Uniform)]
        self.box = np.array(box, dtype=np.intp)
        self.lo = np.array([params[i].prior.lower for i in box])
        self.hi = np.array([params[i].prior.upper for i in box])
        self.const = float(sum(-math.log(math.log(p.upper / p.lower)) if isinstance(p, LogUniform)
                               else -math.log(p.upper - p.lower) for p in (params[i].prior for i in box)))
        self.other = [i for i in range(len(params)) if i not in set(box)]

    def __call__(self, z) -> tuple[np.ndarray, np.ndarray]:
        """``(x, log prior in sampling space)`` for sampling-space points ``z (W, k)``."""
        x = z.copy()
        with np.errstate(over="ignore", invalid="ignore"):
            x[:, self.log_cols] = np.exp(z[:, self.log_cols])
            xb = x[:, self.box]
            inside = np.all((xb >= self.lo) & (xb <= self.hi), axis=1)
            lp = np.where(inside, self.const, -np.inf)
            for i in self.other:
                lp = lp + self.params[i].log_prior_z(z[:, i])
        return x, np.where(np.isnan(lp), -np.inf, lp)


class SamplingSpaceDensity:
    """Posterior densities in sampling space for any likelihood with ``params`` (a ParamSet
    carrying the priors) and ``__call__(theta (..., k)) -> total log-likelihood``; shared by
    :class:`Likelihood` and the joint added-mass likelihood."""

    @functools.cached_property
    def _box_prior(self) -> _BoxPrior:
        return _BoxPrior(self.params)

    def log_prob_z(self, z) -> tuple[np.ndarray, np.ndarray]:
        """``(log posterior, log likelihood)`` at sampling-space points ``z`` of shape ``(W, k)``.

        The log posterior is unnormalised and in sampling space (prior with its log-Jacobian, plus
        likelihood, as ``params.log_prior_z`` and ``params.from_z`` define them); both are ``-inf``
        outside the prior support, never NaN. The likelihood is only evaluated where the prior is
        positive.
        """
        z = np.atleast_2d(np.asarray(z, float))
        x, lp = self._box_prior(z)
        post = np.full(z.shape[0], -np.inf)
        ll = np.full(z.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if np.all(ok):
            ll = np.asarray(self(x), float)
            post = np.where(np.isfinite(ll), lp + ll, -np.inf)
        elif np.any(ok):
            ll[ok] = self(x[ok])
            post[ok] = np.where(np.isfinite(ll[ok]), lp[ok] + ll[ok], -np.inf)
        return post, ll

    def log_posterior_z(self, z) -> np.ndarray:
        """Unnormalised log posterior in sampling space, ``(W, k)`` → ``(W,)``."""
        return self.log_prob_z(z)[0]

    def emcee_log_prob(self, z) -> list[tuple[float, float]]:
        """emcee's ``log_prob_fn`` with ``vectorize=True`` and one blob (the total log-likelihood).

        emcee 3.1.6 iterates over what a vectorised function returns and takes ``item[0]`` as the
        walker's log probability and ``item[1:]`` as its blobs, so it needs one ``(lp, blob)``
        pair per walker; returning ``(lp_array, blob_array)`` fails ("incompatible input
        dimensions"; tests/test_likelihood.py checks both).
        """
        post, ll = self.log_prob_z(z)
        return list(zip(post.tolist(), ll.tolist(), strict=True))


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def measurement_sha256(meas: Measurement) -> str:
    """SHA-256 of a measurement's frequencies, admittances and weights (checkpoint identity)."""
    return _sha256(meas.omega.tobytes() + meas.Y.tobytes()
                   + (b"" if meas.weights is None else meas.weights.tobytes()))


@dataclass(frozen=True, eq=False)
class Likelihood(SamplingSpaceDensity):
    """``log p(Y | θ)`` for one measurement and one model.

    Parameters
    ----------
    model : the transducer model (its ``params`` carry the priors).
    meas : the measurement.
    kind : ``"gaussian"`` or ``"student"``.
    nu : Student-t degrees of freedom; ``None`` samples it (prior :data:`NU_SPEC`).
    noise_params : the noise ParamSet (default :func:`noise_param_set`; to change a prior pass
        ``noise_param_set(kind, nu, noise).with_priors(...)``, see :mod:`bayes_emt.inference.priors`).
    noise : ``"white"`` (independent errors; the default of this building block) or
        ``"correlated"`` (the model-discrepancy likelihood of :mod:`bayes_emt.inference.discrepancy`,
        which appends the correlation length ``ell`` to the noise parameters; the default of
        ``sample`` and ``ts``).

    Attributes
    ----------
    params : ``model.params + noise_params``: the sampled vector, noise scales (and ``nu``) last.
        Every method takes *physical* values of shape ``(..., k)`` with ``k = len(params)``, except
        the ``*_z`` methods, which take sampling-space values.
    """

    model: Model
    meas: Measurement
    kind: LikelihoodKind = "gaussian"
    nu: float | None = 4.0
    noise_params: ParamSet | None = None
    noise: NoiseKind = "white"

    def __new__(cls, *args, **kwargs):
        # a magnitude-only recording gets the likelihood on log|Y| (bayes_emt.inference.magnitude)
        meas = kwargs.get("meas", args[1] if len(args) > 1 else None)
        if cls is Likelihood and getattr(meas, "phase_absent", False):
            cls = MagnitudeLikelihood
        return object.__new__(cls)

    def __post_init__(self):
        # a term that depends on the sweep (thermal drift) is configured by the data it explains
        object.__setattr__(self, "model", self.model.bind(self.meas.omega))
        if self.kind not in ("gaussian", "student"):
            raise ValueError(f"unknown likelihood {self.kind!r}; choose gaussian or student")
        if self.kind == "student" and self.nu is not None and not (self.nu > 0 and math.isfinite(self.nu)):
            raise ValueError(f"Student-t degrees of freedom must be a positive number, got {self.nu}")
        if self.noise not in NOISE_KINDS:
            raise ValueError(f"unknown noise {self.noise!r}; choose one of {', '.join(NOISE_KINDS)}")
        default = noise_param_set(self.kind, self.nu, self.noise)
        if self.noise_params is None:
            object.__setattr__(self, "noise_params", default)
        elif self.noise_params.names != default.names:
            raise ValueError(f"noise parameters must be {list(default.names)}, "
                             f"got {list(self.noise_params.names)}")
        object.__setattr__(self, "params", self.model.params + self.noise_params)
        w = np.ones(self.meas.n_points) if self.meas.weights is None else self.meas.weights
        object.__setattr__(self, "_absY", np.abs(self.meas.Y))
        object.__setattr__(self, "_w2", np.asarray(w, float) ** 2)
        object.__setattr__(self, "_plan", JwPlan.build(self.model, self.meas.omega))
        object.__setattr__(self, "_noise", GaussianNoiseSums(self.meas.Y, self._w2))
        if self.correlated and self.kind != "gaussian":
            raise ValueError("the correlated (model-discrepancy) noise needs the gaussian likelihood; "
                             "use noise='white' (--noise white) with a student-t likelihood")
        object.__setattr__(self, "_corr", NoiseCorrelation(self.meas.omega, self._absY / np.sqrt(self._w2))
                           if self.correlated else None)

    @property
    def correlated(self) -> bool:
        """Whether the residual is modelled as a correlated discrepancy (``noise="correlated"``)."""
        return self.noise == "correlated"

    @property
    def sample_nu(self) -> bool:
        """Whether ``nu`` is a sampled parameter (Student-t with ``nu=None``)."""
        return self.kind == "student" and self.nu is None

    @property
    def ndim(self) -> int:
        return len(self.params)

    @property
    def n_points(self) -> int:
        return self.meas.n_points

    @property
    def label(self) -> str:
        """``source, model M`` (progress bars, warnings)."""
        return f"{self.meas.source}, model {self.model.label}"

    def describe(self) -> str:
        """One line naming the noise model (for reports and file attributes)."""
        corr = ("; plus a model discrepancy of relative size sigma_disc correlated over log10 f "
                "(Ornstein-Uhlenbeck, correlation length ell [decades]; both inferred)" if self.correlated
                else "; independent across frequencies (white: as if the model were exact)")
        if self.kind == "gaussian":
            return "gaussian, sigma^2 = (sigma_rel |Y_meas|)^2 + sigma_abs^2 per part" + corr
        nu = "sampled" if self.sample_nu else f"{self.nu:g}"
        return f"student-t (nu {nu}), scale^2 = (sigma_rel |Y_meas|)^2 + sigma_abs^2 per part" + corr

    # ---- pieces ----------------------------------------------------------------------------
    def split(self, theta):
        """``(theta_model, sigma_rel, sigma_abs, nu)`` from physical values ``(..., k)``;
        ``nu`` is an array when sampled, else the fixed float (or None for gaussian)."""
        theta = np.asarray(theta, float)
        k = self.model.ndim
        nu = theta[..., k + 2] if self.sample_nu else self.nu
        return theta[..., :k], theta[..., k], theta[..., k + 1], nu

    def discrepancy(self, theta):
        """``(sigma_disc, ell)`` of physical values ``(..., k)``: the discrepancy's relative size and
        correlation length [decades] (``noise="correlated"``; zeros, i.e. white, otherwise)."""
        theta = np.asarray(theta, float)
        if not self.correlated:
            return np.zeros(theta.shape[:-1]), np.zeros(theta.shape[:-1])
        return theta[..., -2], theta[..., -1]

    def sigma(self, sigma_rel, sigma_abs):
        """Per-frequency std (Student-t: scale) of each part [S], shape ``(..., F)``."""
        a = np.asarray(sigma_rel, float)[..., None] * self._absY
        b = np.asarray(sigma_abs, float)[..., None]
        return np.sqrt((a * a + b * b) / self._w2)

    def model_admittance(self, theta_model) -> np.ndarray:
        """The model's ``Y(jω)`` [S] at the measured frequencies for model parameters ``(..., k_model)``
        (through the fast path when the model has one: :mod:`bayes_emt.inference.fastpath`)."""
        with np.errstate(all="ignore"):
            if self._plan is not None:
                return self._plan.admittance(theta_model)
            return self.model.admittance(self.meas.omega, theta_model)

    def residuals(self, theta):
        """Complex ``Y_model − Y_meas`` [S], shape ``(..., F)``."""
        return self.model_admittance(self.split(theta)[0]) - self.meas.Y

    def scaled_squared_residuals(self, theta_model) -> np.ndarray:
        """``|Y_model − Y_meas|² w_k²/|Y_meas|²`` per frequency for model parameters ``(W, k_model)``:
        what the Gaussian total needs (:mod:`bayes_emt.inference.noise`), ``(W, F)``."""
        th = np.asarray(theta_model, float)
        if self._plan is not None:
            return self._plan.scaled_squared_residuals(th, self.meas.Y, self._noise.scale)
        with np.errstate(all="ignore"):
            r = self.model.admittance(self.meas.omega, th) - self.meas.Y
            return (r.real**2 + r.imag**2) * self._noise.scale**2

    def normalised_residuals(self, theta):
        """Complex ``(Y_model − Y_meas)/σ_k`` (real and imaginary parts ~ N(0, 1) under the
        Gaussian model), shape ``(..., F)``: the input of whiteness and discrepancy tests."""
        _, srel, sabs, _ = self.split(theta)
        with np.errstate(all="ignore"):
            return self.residuals(theta) / self.sigma(srel, sabs)

    def predictive(self, theta, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """``(Y_model, Y_replicated)`` [S] at the measured frequencies, each ``(..., F)``: the model's
        admittance for parameter sets ``theta (..., k)`` and one replicated measurement of each,
        with noise drawn from this likelihood (Gaussian or Student-t parts of scale ``σ_k``; correlated over
        frequency by the AR(1) recursion when ``noise="correlated"``)."""
        th, srel, sabs, nu = self.split(theta)
        Ym = self.model.admittance(self.meas.omega, th)
        sig = self.sigma(srel, sabs)
        if self.kind == "student":
            df = np.broadcast_to(np.asarray(nu, float)[..., None] if self.sample_nu else nu, Ym.shape)
            noise = rng.standard_t(df) + 1j * rng.standard_t(df)
        else:
            noise = rng.standard_normal(Ym.shape) + 1j * rng.standard_normal(Ym.shape)
        rep = Ym + sig * noise
        if self.correlated:  # plus the discrepancy: an OU path by its AR(1) recursion on the grid
            sd, ell = self.discrepancy(theta)
            rho = ou_rho(self._corr.x, ell)
            gain = np.sqrt(-np.expm1(2.0 * np.log(np.maximum(rho, 1e-300))))
            d = rng.standard_normal(Ym.shape) + 1j * rng.standard_normal(Ym.shape)
            for i in range(1, d.shape[-1]):
                d[..., i] = rho[..., i - 1] * d[..., i - 1] + gain[..., i - 1] * d[..., i]
            rep = rep + np.asarray(sd, float)[..., None] * self._corr.absY * d
        return Ym, rep

    # ---- densities ---------------------------------------------------------------------------
    def pointwise(self, theta) -> np.ndarray:
        """Log-likelihood per frequency [nats], shape ``(..., F)``; ``-inf`` where not finite."""
        _, srel, sabs, nu = self.split(theta)
        with np.errstate(all="ignore"):
            r = self.residuals(theta)
            sig = self.sigma(srel, sabs)
            if self.correlated:
                lead = r.shape[:-1]
                sd, ell = self.discrepancy(theta)
                F = self.n_points
                return self._corr.pointwise(r.reshape(-1, F), np.broadcast_to(sig, r.shape).reshape(-1, F),
                                            np.ravel(sd), np.ravel(ell)).reshape(lead + (F,))
            if self.kind == "gaussian":
                ll = -np.log(2 * math.pi * sig * sig) - (r.real**2 + r.imag**2) / (2 * sig * sig)
            else:
                nu = np.asarray(nu, float)[..., None] if self.sample_nu else float(nu)
                c = special.gammaln((nu + 1) / 2) - special.gammaln(nu / 2) - 0.5 * np.log(nu * math.pi)
                t2 = np.log1p((r.real / sig) ** 2 / nu) + np.log1p((r.imag / sig) ** 2 / nu)
                ll = 2 * c - 2 * np.log(sig) - (nu + 1) / 2 * t2
        return np.where(np.isfinite(ll), ll, -np.inf)

    def __call__(self, theta) -> np.ndarray:
        """Total log-likelihood [nats], shape ``theta.shape[:-1]`` (dynesty's ``loglike`` with
        ``params.prior_transform`` as its ``prior_transform``); ``-inf`` where not finite.

        Equal to ``pointwise(theta).sum(-1)``; the Gaussian total is computed without per-point
        logarithms (:mod:`bayes_emt.inference.noise`) from the fast path's scaled residuals.
        """
        if self.kind != "gaussian":
            return np.sum(self.pointwise(theta), axis=-1)
        if self.correlated:
            theta = np.asarray(theta, float)
            lead = theta.shape[:-1]
            flat = theta.reshape(-1, theta.shape[-1])
            _, srel, sabs, _ = self.split(flat)
            sd, ell = self.discrepancy(flat)
            with np.errstate(all="ignore"):
                r = self.model_admittance(flat[:, : self.model.ndim]) - self.meas.Y
                sig = self.sigma(srel, sabs)
            return self._corr.total(r, sig, sd, ell).reshape(lead)
        theta = np.asarray(theta, float)
        lead = theta.shape[:-1]
        flat = theta.reshape(-1, theta.shape[-1])
        th, srel, sabs, _ = self.split(flat)
        if self._plan is not None:
            e = self._plan.scaled_squared_residuals(th, self.meas.Y, self._noise.scale,
                                                    out=self._plan.scratch((th.shape[0], self.n_points)))
        else:
            e = self.scaled_squared_residuals(th)
        return self._noise.total(e, srel, sabs).reshape(lead)

    def identity(self) -> dict:
        """What a checkpoint must match to be resumed by this likelihood (data by SHA-256)."""
        return {"model": self.model.label, "terms": [t.to_dict() for t in self.model.terms],
                "n_turns": self.model.n_turns, "names": list(self.params.names), "likelihood": self.kind,
                "nu": self.nu, "n_points": self.meas.n_points,
                "priors_sha256": _sha256(json.dumps(self.params.to_dict(), sort_keys=True).encode()),
                "data_sha256": measurement_sha256(self.meas), "source": self.meas.source,
                **({"noise": self.noise} if self.correlated else {})}


@dataclass(frozen=True, eq=False)
class MagnitudeLikelihood(MagnitudeOnly, Likelihood):
    """:class:`Likelihood` of a magnitude-only recording, on ``ln|Y|`` (:mod:`.magnitude`)."""
