"""One log evidence for several recordings of one transducer under a shared model.

The density is the product of the recordings' likelihoods at the run vectors a joint vector
implies (the shared parameters once, each recording's own parameters and noise scales apart:
:class:`~bayes_emt.added_mass.pair.PairModel`, or the physical ``m, c, k, φ`` of a known added mass,
:class:`~bayes_emt.added_mass.multi.MultiMassModel`, both under
:class:`~bayes_emt.added_mass.multi.MultiMassLikelihood`), and the priors are the one parameter-spec
mechanism's (:mod:`bayes_emt.params`): the model's for every shared and per-recording parameter, the
noise priors for each recording's ``sigma_rel`` and ``sigma_abs``. Its evidence

    Z_joint = ∫ p(Y_a | θ_a(x)) p(Y_b | θ_b(x)) p(x) dx

is what "the two recordings share this model" is worth: a term both recordings need with the same
values raises it by roughly the sum of what each gains alone, paying its Occam factor once; a term
one recording does without, or that the other needs with other values (another feature there),
is paid for by the recording it does not fit.

:func:`joint_log_evidence` takes it by the Laplace approximation at the posterior mode
(:func:`~bayes_emt.evidence.laplace.laplace_evidence`, Tierney & Kadane 1986; Kass & Raftery 1995
eq. 5), started at the joint least-squares fit with each recording's noise scales from its
residual, the noise coordinates logit-mapped; when the screen fails (a flat direction), by the
subspace fallback of :mod:`.fit_evidence` at the posterior's mode, as for one recording. A pair
holding one instrument step (the step frequency one joint parameter) has it marginalised over the
intervals between measured points (:mod:`.step_intervals`): those of every recording whose model
holds the step, since the joint likelihood jumps at each of their points.
"""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np

from ..inference.start import extra_noise_start, noise_start, posterior_mode
from .fit_evidence import Evidence, blocked, fallback_evidence, laplace_screen, subspace_laplace
from .step_intervals import STEP_METHOD, step_interval_evidence, step_parameter
from .warp import Warp

__all__ = ["joint_log_evidence", "joint_start"]


def joint_start(density, fit) -> tuple[np.ndarray, np.ndarray, int]:
    """``(z0, scale, p)``: the joint least-squares ``fit`` (``theta`` [SI], ``cov_z``,
    ``rms_rel_residual`` per run) in ``density``'s sampling space with each run's noise scales
    started from its residual, a covariance to whiten by (the fit's; a 0.1 % guess per coordinate
    when it has none) and the number ``p`` of joint model parameters before the noise ones."""
    jp = density.joint.params
    p = len(jp)
    z_head = jp.to_z(np.asarray(fit.theta, float))
    z0, spread = [z_head], []
    for lik, th, rms in zip(density.liks, density.joint.thetas(np.asarray(fit.theta, float)[None, :]),
                            fit.rms_rel_residual, strict=True):
        c, s = noise_start(float(rms), float(np.min(np.abs(lik.meas.Y))))
        ce, se = extra_noise_start(lik, th[0])
        z0.append(np.asarray(c + ce, float))
        spread += s + se
    z0 = np.concatenate(z0)
    cov = fit.cov_z
    if cov is None or not np.all(np.isfinite(cov)):
        cov = np.diag((1e-3 * np.maximum(np.abs(z_head), 1.0)) ** 2)
    scale = np.zeros((z0.size, z0.size))
    scale[:p, :p] = cov
    scale[p:, p:] = np.diag(np.square(spread))
    return z0, scale, p


def joint_log_evidence(density, fit, seed: int = 0) -> Evidence:
    """The Laplace log evidence [nats] of the joint ``density`` (module docstring) started at its
    joint least-squares ``fit``; the subspace fallback (``method`` ``"laplace_subspace"``) when the
    screen fails, ``nan`` with ``method`` ``"failed"`` when that fails too. ``seed``: the
    fallback's importance-sampling draws."""
    z0, scale, p = joint_start(density, fit)
    log_q = blocked(density.log_posterior_z)
    # the noise coordinates logit-mapped (a fit cannot tell whether their posterior presses against a
    # bound), and every other bounded one whose fit lies within 3 standard errors of a bound (a
    # hypothesis that fits one recording badly can push a term's parameter there)
    sd = np.sqrt(np.clip(np.diag(scale), 0, None))
    near = Warp.near_bounds(density.params, z0, z0, sd, n_sd=3.0).mask
    warp = Warp.of(density.params, mask=(np.arange(z0.size) >= p) | near)
    step = _joint_step(density)
    if step is not None:
        name, grid = step
        value = float(np.asarray(fit.theta, float)[density.params.index(name)])
        got = step_interval_evidence(SimpleNamespace(omega=grid), density, log_q, value, z0, scale, warp,
                                     name)
        if got is not None:
            return Evidence(got[0], STEP_METHOD, got[1], ((name,),))
    ev, why, mode = laplace_screen(log_q, density.params, z0, scale, warp)
    if ev is not None:
        return ev
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mode = posterior_mode(density, np.array([mode, z0]), scale + 1e-12 * np.eye(z0.size))
            lz, note, flat = subspace_laplace(log_q, list(density.params.names), mode,
                                              Warp.of(density.params), seed=seed)
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as e:
        return Evidence(float("nan"), "failed", f"{why}; fallback failed: {e}")
    return fallback_evidence(lz, note, flat, why)


def _joint_step(density) -> tuple[str, np.ndarray] | None:
    """``(joint parameter name, grid [rad/s])`` of the pair's one step frequency: the sorted union of
    the frequencies of every recording whose model holds the step; ``None`` when the pair holds
    no step, or more than one step parameter."""
    models = [lik.model for lik in density.liks]
    steps = {step_parameter(m) for m in models} - {None}
    if len(steps) != 1:
        return None
    (base,) = steps
    names = [n for n in density.joint.params.names if n == base or n.startswith(base + "_")]
    if len(names) != 1:
        return None
    grid = np.unique(np.concatenate([lik.meas.omega for lik, m in zip(density.liks, models, strict=True)
                                     if step_parameter(m) == base]))
    return names[0], grid
