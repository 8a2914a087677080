"""The discovery's evidence fallback (issue 13): where the Laplace screen fails on a flat direction,
Laplace on the identifiable subspace with the flat directions integrated numerically, checked by
importance sampling; known integrals, agreement with Laplace where Laplace works, a lead
resistance (not identifiable against R0) and a measurement step (non-smooth) get a flagged number,
and null data gives no candidate a significant gain from it."""

import math

import numpy as np
import pytest

from bayes_emt.discovery.locate import Band
from bayes_emt.discovery.name import MIN_DELTA_LOG_Z, rank_candidates
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.evidence.fit_evidence import fit_log_evidence as evidence
from bayes_emt.evidence.fit_evidence import slice_log_integral, subspace_laplace
from bayes_emt.evidence.warp import Warp
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

GRID = np.geomspace(1e1, 1e5, 300)


def test_line_integrals_of_known_shapes():
    box = slice_log_integral(lambda t: np.where((t > -0.3) & (t < 1.7), 0.0, -np.inf))
    assert box == pytest.approx(math.log(2.0), abs=0.01)
    gauss = slice_log_integral(lambda t: -0.5 * (t / 3.0) ** 2)
    assert gauss == pytest.approx(math.log(math.sqrt(2 * math.pi) * 3.0), abs=0.01)
    # one-sided: exp(-t) for t > 0 integrates to 1
    assert slice_log_integral(lambda t: np.where(t >= 0, -t, -np.inf)) == pytest.approx(0.0, abs=0.02)
    # improper (flat forever): no number
    assert math.isnan(slice_log_integral(lambda t: 0.0 * t))


def _gauss_times_step(x):
    """A correlated 2-D Gaussian times a normalised uniform prior on [0, 3] for x2 with a likelihood
    5 nats higher on (1.0, 1.2): piecewise constant in x2, so the Hessian is singular there."""
    x = np.atleast_2d(x)
    cov = np.array([[1.0, 0.8], [0.8, 1.0]]) * 0.01
    P = np.linalg.inv(cov)
    g = -0.5 * np.einsum("ni,ij,nj->n", x[:, :2], P, x[:, :2])
    inside = (x[:, 2] > 0.0) & (x[:, 2] < 3.0)
    step = np.where((x[:, 2] > 1.0) & (x[:, 2] < 1.2), 5.0, 0.0)
    return np.where(inside, g - math.log(3.0) + step, -np.inf)


def test_subspace_laplace_is_exact_on_a_gaussian_times_a_step():
    warp = Warp(np.array([-np.inf, -np.inf, 0.0]), np.array([np.inf, np.inf, 3.0]))
    lz, note, flat = subspace_laplace(_gauss_times_step, ["a", "b", "s"], np.array([0.0, 0.0, 1.1]), warp)
    cov = np.array([[1.0, 0.8], [0.8, 1.0]]) * 0.01
    exact = math.log(2 * math.pi * math.sqrt(np.linalg.det(cov))) + math.log((math.exp(5) * 0.2 + 2.8) / 3)
    assert lz == pytest.approx(exact, abs=0.1)
    assert flat and "s" in flat[0] and "importance sampling" in note


def test_subspace_laplace_gives_no_number_at_a_saddle():
    warp = Warp(np.array([-np.inf, -np.inf]), np.array([np.inf, np.inf]))
    lz, note, _ = subspace_laplace(lambda x: -0.5 * x[:, 0] ** 2 + 0.5 * x[:, 1] ** 2, ["a", "b"],
                                   np.zeros(2), warp)
    assert math.isnan(lz) and "saddle" in note


def test_subspace_laplace_agrees_with_laplace_where_laplace_works():
    model = parse_model_spec("UD")
    meas = simulate(model, PAPER_TABLES["UD"], GRID, noise=0.003, seed=5)
    fit = fit_admittance(meas, model)
    ev = evidence(meas, fit)
    assert ev.method == "laplace" and not ev.fallback
    from bayes_emt.inference.likelihood import Likelihood
    from bayes_emt.inference.sampling import noise_start
    from bayes_emt.inference.start import posterior_mode

    lik = Likelihood(model, meas)
    centre, spread = noise_start(fit.rms_rel_residual, float(np.min(np.abs(meas.Y))))
    z0 = np.r_[fit.z, centre]
    scale = np.zeros((lik.ndim, lik.ndim))
    scale[: model.ndim, : model.ndim] = fit.cov_z
    scale[model.ndim :, model.ndim :] = np.diag(np.square(spread))
    mode = posterior_mode(lik, z0[None, :], scale)
    lz, _note, flat = subspace_laplace(lik.log_posterior_z, list(lik.params.names), mode, Warp.of(lik.params))
    assert flat == () and lz == pytest.approx(ev.log_z, abs=1.0)


def test_lead_resistance_gets_a_flagged_fallback_evidence_and_is_not_identifiable():
    """II data with 0.1 ohm and 2 uH of leads: Rl is not determined against R0, so Laplace fails;
    the fallback gives a finite log Z, says which method and that Rl lies along the flat direction,
    and the candidate is accepted (the fit improves) but not identifiable."""
    truth = parse_model_spec("II+lead_impedance")
    meas = simulate(truth, {**PAPER_TABLES["II"], "Rl": 0.1, "Ll": 2e-6}, GRID, noise=0.002, seed=1)
    base = fit_admittance(meas, parse_model_spec("II"))
    lz0 = evidence(meas, base).log_z
    band = Band(float(GRID[200]), float(GRID[-1]), 200, GRID.size - 1, ("real", "imag"), 100.0, 25.0,
                float(GRID[250]))
    ranked = rank_candidates(meas, base, lz0, band, 0.002, ["lead_impedance"])
    assert len(ranked) == 1
    c = ranked[0]
    assert c.evidence_method == "laplace_subspace" and "Rl" in c.evidence_note
    assert c.accepted and c.delta_log_z > 100
    assert not c.identifiable and "Rl" in c.identifiability


def test_null_data_gives_no_fallback_candidate_a_significant_gain():
    """UD data without any effect, a band at the top: the fallback's candidates (a lead, a step, a
    capacitance) all stay below the acceptance threshold."""
    model = parse_model_spec("UD")
    meas = simulate(model, PAPER_TABLES["UD"], GRID, noise=0.003, seed=11)
    fit = fit_admittance(meas, model)
    lz = evidence(meas, fit).log_z
    band = Band(float(GRID[200]), float(GRID[-1]), 200, GRID.size - 1, ("real", "imag"), 30.0, 25.0,
                float(GRID[250]))
    ranked = rank_candidates(meas, fit, lz, band, 0.003,
                             ["lead_impedance", "measurement_artifact", "winding_capacitance"])
    assert any(c.evidence_method == "laplace_subspace" for c in ranked), "the fallback was not exercised"
    for c in ranked:
        assert not c.accepted
        if c.evidence_method == "refused":  # a step the measured points do not show: no evidence computed
            assert c.physics == "measurement_artifact" and c.patch_problem
        else:
            assert c.delta_log_z < MIN_DELTA_LOG_Z
