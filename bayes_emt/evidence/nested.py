"""log Z by nested sampling (Skilling 2006) with dynesty: from the prior to the posterior.

The evidence ``Z = ∫ L(θ) π(θ) dθ`` is integrated over the prior mass ``X``: live points drawn
from the prior (``ParamSet.prior_transform``: unit cube → physical values) are replaced one at a
time by a point of higher likelihood, the prior mass shrinking by ``≈ e^{-1/n_live}`` per
iteration. Its failure mode differs from bridge sampling's: it needs no posterior draws and no
starting point, but it can miss posterior mass the constrained sampler fails to reach, and its
statistical error is ``≈ sqrt(H / n_live)`` nats with ``H`` the information (KL divergence of the
posterior from the prior), reported by dynesty as ``logzerr``. The number of iterations is about
``n_live · H`` (plus ``n_live`` for the last live points), each costing ``walks`` likelihood calls
for a random walk, so the run time scales with ``n_live · H · walks`` calls.

Likelihood calls are batched (:class:`~bayes_emt.evidence.batching.BatchingPool`): dynesty's
``queue_size`` proposals run in lockstep and their points are evaluated in one vectorised call
of ``target(x (n, k)) -> (n,)`` (e.g. :class:`~bayes_emt.inference.likelihood.Likelihood`).

Defaults (:class:`NestedSettings`): ``bound="multi"`` (Feroz et al. 2009 multi-ellipsoids) with
``sample="rwalk"`` (random walks inside the bound) of ``walks = 100`` steps per new point, 100
live points, a queue of 16; the run stops when the estimated evidence left in the live points is
below ``dlogz = 0.1`` nat, and the live points are then added. A run that hits ``max_calls``
first is flagged ``converged = False``.

Why 100 walks, not dynesty's ``20 + k``: on the transducer likelihoods (decade-wide log-uniform
priors, curved ridges in the prior-dominated phase) short walks leave new points correlated
with their starts and log Z comes out low. Measured on model I (200 points, 0.2 % noise, 7
parameters), against bridge sampling's 2640.60 ± 0.02 nats: 27 walks gave −4.7 and −3.7 nats
(n_live 100, seeds 1, 2) and −1.2, −3.5, −4.0 (n_live 200); 100 walks gave −2.5 and −0.5
(n_live 100). On a correlated 7-D Gaussian in a wide box (H = 61 nats), 27 walks are unbiased
(+0.6, +0.3, −0.3 standard errors), so the bias is the target's geometry, not the sampler code.
The cost is ``≈ n_live · H · walks`` calls: about 0.6 M for model I (H ≈ 55 nats).
Known failure of runs from the prior: a 15-D product of log-normals
under uniform priors (skewed, mass near the cube's corner) comes out low with these defaults:
(log Z − truth)/logzerr = −7.2, −12.4, −0.6, −2.9, −6.0 for seeds 1, 2, 3, 4, 7, while the
correlated Gaussian in a box and the linear-Gaussian at 15-D pass with the same settings
(tests/test_evidence_known.py); at 10-D it is already −4.0, −1.4, +1.1 (seeds 1, 2, 3), so no
dimension threshold separates it from the 7–9-parameter models. The dead points' log X, compared
with the exact X(L), go wrong between log X ≈ −17 and −29, where the constrained region is most
skewed in the unit cube (tails to u ≈ 0.5, bulk at u ≈ 0.05): 100 steps do not decorrelate a new
point from its start there. Walks 300 recover it (−0.9, −2.5, −0.7, +1.9, +0.4) at 3× the calls,
and so does slice sampling, ``sample="slice"`` (batched here, :class:`~.batching.BatchSliceSampler`:
−0.4, +0.8, −0.8, +2.3, +2.3 on seeds 1, 2, 3, 4, 7, with 2.2× the evaluations and 2.6× the time;
the Gaussian in a box and the linear-Gaussian pass with it too). Neither is the default: the
17-parameter NL model's nested run on the bundled data takes 158 s with the random walk and 522 s
with slice sampling, against the 10-minute budget for six models. Neither move is reliable on
the NL models at 0.2 % noise: on the bundled data slice sampling gives 27499.4 ± 1.3 nats, 529
below bridge sampling's 28028.3 ± 0.03, and the random walk misses NL(1)–NL(7) of simulated ring
data by 20–3700 nats; the comparison's lower bound (:mod:`.bound`) catches such runs.
Changes at the same cost did not fix it (target acceptance 0.234 or 0.15,
faster scale tuning, ``bound="single"``); ``bound="none"`` did, but put model I 160 and 1560 nats
below the default runs. For skewed posteriors of positive parameters under *uniform* priors in ≳
10-D, use ``sample="slice"`` (``--sample slice``) or ``walks ≈ 20·k`` (``--walks``), or give such
parameters log-uniform priors.

What ``bayes-emt compare`` runs by default is therefore not this from-the-prior run but the same
sampler with the prior repartitioned onto the emcee draws (:mod:`.repartition`; same log Z, an
information of 1.6–14 nats instead of 47–134): there all three 15-D problems and the NL models
pass with these defaults (bundled NL(5): 28028.28 ± 0.24 nats against bridge sampling's 28028.33,
68 000 evaluations in 9 s). The from-the-prior run stays for ``--nested-prior prior``: it does not
depend on the chain, and it is what can find a mode the chain missed.

Checkpoint and resume: dynesty's own state file (a pickle written atomically every
``checkpoint_every`` seconds and at the end) beside a JSON identity (data, priors, settings,
seed). ``resume`` refuses a checkpoint whose identity differs, so only files this function wrote
are unpickled. The finished run is a frozen :class:`NestedRun`, saved as a netCDF ``DataTree``
(dead points, weights, evidence trace) plus its JSON summary (:meth:`NestedRun.save`).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from .._atomic import atomic_path, atomic_write_text
from ..errors import ConvergenceWarning
from .batching import BatchingPool, BatchRWalkSampler, BatchSliceSampler, Relay, register, unregister

__all__ = ["NestedSettings", "NestedRun", "run_nested", "read_nested"]

SampleMethod = Literal["rwalk", "rslice", "slice", "unif"]


@dataclass(frozen=True)
class NestedSettings:
    """Knobs of :func:`run_nested`.

    Attributes
    ----------
    n_live : live points (statistical error ``≈ sqrt(H/n_live)`` nats).
    sample : dynesty's proposal inside the bound (``rwalk`` and ``slice``, batched; ``rslice``,
        ``unif``).
    bound : dynesty's bounding distribution (``multi``, ``single``, ``none``, ...).
    walks : random-walk steps per new point (``rwalk``; module docstring for the default).
    slices : slice-sampling steps per new point (``rslice``/``slice``; ``None``: dynesty's default).
    queue_size : proposals evaluated together in one vectorised call.
    dlogz : stop when the evidence left in the live points is below this [nats].
    max_calls : likelihood-call budget (``None``: no budget).
    checkpoint_every : seconds between checkpoint writes.
    """

    n_live: int = 100
    sample: SampleMethod = "rwalk"
    bound: str = "multi"
    walks: int = 100
    slices: int | None = None
    queue_size: int = 16
    dlogz: float = 0.1
    max_calls: int | None = None
    checkpoint_every: float = 60.0

    def __post_init__(self):
        if self.n_live < 2:
            raise ValueError(f"n_live must be at least 2, got {self.n_live}")
        if self.sample not in ("rwalk", "rslice", "slice", "unif"):
            raise ValueError(f"unknown nested sampling method {self.sample!r}; choose rwalk, rslice, "
                             "slice or unif")
        if self.walks < 2:
            raise ValueError(f"walks must be at least 2, got {self.walks}")
        if self.queue_size < 1:
            raise ValueError(f"queue_size must be at least 1, got {self.queue_size}")
        if not self.dlogz > 0:
            raise ValueError(f"dlogz must be positive, got {self.dlogz}")


@dataclass(frozen=True, eq=False)
class NestedRun:
    """A finished nested-sampling run (no sampler state inside).

    Attributes
    ----------
    names, units : the sampled parameters (physical values, SI).
    log_z, log_z_err : log evidence and its standard error [nats] (dynesty's ``logzerr``).
    information : ``H`` [nats], the KL divergence of the posterior from the prior.
    samples : (n, k) dead points then final live points, physical values.
    log_l : (n,) their log-likelihoods [nats].
    log_vol : (n,) log prior volume at each dead point.
    log_wt : (n,) log importance weights (``log_wt − log_z`` normalises them).
    n_calls : likelihood calls dynesty counted (proposals outside the cube included).
    n_evaluations, n_batches : points evaluated and vectorised calls made by this process.
    n_iter : nested-sampling iterations.
    converged : whether the ``dlogz`` criterion was met before ``max_calls``.
    seed, settings, wall_time : provenance [s for the time].
    message : one line saying how the run ended.
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    log_z: float
    log_z_err: float
    information: float
    samples: np.ndarray
    log_l: np.ndarray
    log_vol: np.ndarray
    log_wt: np.ndarray
    n_calls: int
    n_evaluations: int
    n_batches: int
    n_iter: int
    converged: bool
    seed: int
    settings: dict = field(default_factory=dict)
    wall_time: float = 0.0
    message: str = ""

    def __post_init__(self):
        for name in ("samples", "log_l", "log_vol", "log_wt"):
            a = np.array(getattr(self, name), float)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "units", tuple(self.units))

    def weights(self) -> np.ndarray:
        """Normalised posterior weights of :attr:`samples`."""
        w = np.exp(self.log_wt - np.max(self.log_wt))
        return w / w.sum()

    def to_json_dict(self) -> dict:
        return {"method": "nested", "log_evidence": self.log_z, "err": self.log_z_err,
                "information_nats": self.information, "n_calls": self.n_calls,
                "n_evaluations": self.n_evaluations, "n_batches": self.n_batches, "n_iter": self.n_iter,
                "converged": self.converged, "seed": self.seed, "settings": dict(self.settings),
                "wall_time_s": self.wall_time, "message": self.message, "names": list(self.names),
                "units": list(self.units)}

    def to_datatree(self):
        """An ``xarray.DataTree`` with group ``nested`` (dims ``sample``, ``param``) and the JSON
        summary in the root attributes."""
        import xarray as xr

        ds = xr.Dataset(
            {"samples": (("sample", "param"), self.samples), "log_l": ("sample", self.log_l),
             "log_vol": ("sample", self.log_vol), "log_wt": ("sample", self.log_wt)},
            coords={"param": list(self.names)})
        ds["param_unit"] = ("param", list(self.units))
        ds["log_l"].attrs["units"] = "nats"
        return xr.DataTree.from_dict({"/": xr.Dataset(attrs={"kind": "nested_sampling",
                                                             "summary": json.dumps(self.to_json_dict())}),
                                      "/nested": ds})

    def save(self, path: str | Path) -> Path:
        """Write the DataTree (netCDF) to ``path`` and the JSON summary beside it (``.json``),
        both atomically."""
        path = Path(path)
        dt = self.to_datatree()
        with atomic_path(path, suffix=".nc") as tmp:
            dt.to_netcdf(tmp)
        atomic_write_text(path.with_suffix(".json"), json.dumps(self.to_json_dict(), indent=2))
        return path


def read_nested(path: str | Path) -> NestedRun:
    """A :class:`NestedRun` from a file written by :meth:`NestedRun.save`."""
    import xarray as xr

    dt = xr.open_datatree(path)
    try:
        if dt.attrs.get("kind") != "nested_sampling":
            raise ValueError(f"{path}: not a bayes_emt nested-sampling file")
        s = json.loads(dt.attrs["summary"])
        ds = dt["nested"].to_dataset().load()
    finally:
        dt.close()
    return NestedRun(tuple(s["names"]), tuple(s["units"]), s["log_evidence"], s["err"],
                     s["information_nats"], ds["samples"].values, ds["log_l"].values, ds["log_vol"].values,
                     ds["log_wt"].values, s["n_calls"], s["n_evaluations"], s["n_batches"], s["n_iter"],
                     s["converged"], s["seed"], s["settings"], s["wall_time_s"], s["message"])


def target_identity(target) -> dict:
    """What a checkpoint of ``target`` must match: its ``identity()``, else its names and priors."""
    if hasattr(target, "identity"):
        return target.identity()
    return {"names": list(target.params.names), "priors": target.params.to_dict()}


def _identity(target, seed: int, settings: NestedSettings) -> dict:
    return {**target_identity(target), "seed": int(seed), "nested": asdict(settings)}


#: seconds between progress lines when ``progress`` is a callable
PROGRESS_EVERY_S = 5.0


def _lines(tell, label: str):
    """dynesty's ``print_func``: a line to ``tell`` at most every :data:`PROGRESS_EVERY_S` seconds."""
    t0 = last = time.monotonic()

    def print_func(itresult, niter, ncall, *args, dlogz=None, **kwargs):
        nonlocal last
        now = time.monotonic()
        if now - last >= PROGRESS_EVERY_S:
            last = now
            tell(f"nested {label}: iteration {niter}, {ncall} calls, log Z {float(itresult.logz):.1f}, "
                 f"remaining dlogz {float(itresult.delta_logz):.3g} (stops below {dlogz}) ({now - t0:.0f} s)")

    return print_func


def run_nested(target, *, seed: int = 0, settings: NestedSettings = NestedSettings(),
               checkpoint: str | Path | None = None, resume: bool = False,
               progress=False) -> NestedRun:
    """log Z of ``target`` by static nested sampling (module docstring).

    Parameters
    ----------
    target : has ``params`` (a ParamSet with proper priors) and ``__call__(x (n, k)) -> (n,)``,
        the total log-likelihood [nats] of physical values; optionally ``identity()`` (a
        JSON-able dict that a checkpoint must match), ``label`` and ``prior_transform`` (unit cube
        → physical values; default ``params.prior_transform``; a
        :class:`~.repartition.RepartitionedTarget` brings its own).
    seed : seeds ``rstate = numpy.random.default_rng(seed)``.
    settings : :class:`NestedSettings`.
    checkpoint : dynesty state file (its identity goes to ``<checkpoint>.json``); ``None``: none.
    resume : continue the run in ``checkpoint`` (same identity), else start afresh (an existing
        checkpoint is replaced).
    progress : dynesty's progress line on stderr, or a ``callable(str)`` told the iteration, calls
        and log Z every :data:`PROGRESS_EVERY_S` seconds (for redirected output).
    """
    import dynesty

    t0 = time.perf_counter()
    params = target.params
    k = len(params)
    ident = _identity(target, seed, settings)
    key = "nested-" + hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:16]
    ptform = getattr(target, "prior_transform", params.prior_transform)
    pool = BatchingPool(target, ptform, settings.queue_size)
    register(key, pool)
    label = getattr(target, "label", "target")
    try:
        sampler = None
        if checkpoint is not None:
            checkpoint = Path(checkpoint)
            side = checkpoint.with_name(checkpoint.name + ".json")
            if resume and checkpoint.exists():
                stored = json.loads(side.read_text()) if side.exists() else None
                if stored != json.loads(json.dumps(ident, default=str)):
                    raise ValueError(f"{checkpoint}: cannot resume: the checkpoint belongs to a different "
                                     "run (data, priors, model, seed or settings)")
                sampler = dynesty.NestedSampler.restore(str(checkpoint), pool=pool)
            else:
                atomic_write_text(side, json.dumps(ident, default=str))
        if sampler is None:
            kwargs = {}
            method = settings.sample
            if method == "rwalk":
                method = BatchRWalkSampler(walks=settings.walks)
            elif method == "slice":
                method = BatchSliceSampler(slices=settings.slices or 3)  # dynesty's default: 3
            elif settings.slices is not None:
                kwargs["slices"] = settings.slices
            sampler = dynesty.NestedSampler(
                Relay(key, "loglike"), Relay(key, "prior_transform"), k, nlive=settings.n_live,
                bound=settings.bound, sample=method, rstate=np.random.default_rng(seed),
                pool=pool, queue_size=settings.queue_size,
                use_pool={"prior_transform": False}, **kwargs)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=RuntimeWarning)  # exp of -inf log weights
            sampler.run_nested(dlogz=settings.dlogz, maxcall=settings.max_calls,
                               print_progress=bool(progress),
                               print_func=_lines(progress, label) if callable(progress) else None,
                               checkpoint_file=None if checkpoint is None else str(checkpoint),
                               checkpoint_every=settings.checkpoint_every,
                               resume=bool(resume and checkpoint is not None and checkpoint.exists()))
        res = sampler.results
    finally:
        unregister(key)
    log_z = float(res["logz"][-1])
    err = float(res["logzerr"][-1])
    ncall = int(np.sum(res["ncall"]))
    converged = settings.max_calls is None or ncall < settings.max_calls
    message = (f"converged: {res['niter']} iterations, {ncall} likelihood calls, H = "
               f"{float(res['information'][-1]):.1f} nats" if converged else
               f"stopped at the call budget {settings.max_calls} before dlogz {settings.dlogz} was reached")
    if hasattr(target, "repartition"):
        message += "; prior repartitioned onto posterior draws: log_l is log(L pi / pi~), not log L"
    if not converged:
        warnings.warn(f"{label}: nested sampling {message}", ConvergenceWarning, stacklevel=2)
    if not math.isfinite(log_z):
        raise RuntimeError(f"{label}: nested sampling gave a non-finite log evidence")
    return NestedRun(tuple(params.names), tuple(params.units), log_z, err, float(res["information"][-1]),
                     res["samples"], res["logl"], res["logvol"], res["logwt"], ncall, pool.n_calls,
                     pool.n_batches, int(res["niter"]), bool(converged), int(seed), asdict(settings),
                     time.perf_counter() - t0, message)

