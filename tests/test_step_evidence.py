"""A model holding an instrument step: its step frequency marginalised over the intervals between
measured points (bayes_emt.evidence.step_intervals)."""

import math

import numpy as np

from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.evidence import step_intervals
from bayes_emt.evidence.fit_evidence import fit_log_evidence, fit_start
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec
from bayes_emt.reference import PAPER_TABLES

# the concealed benchmark's recall grid: 500 points over 10-1e5 rad/s, 0.2 % noise, switch at 3000 rad/s
GRID = np.geomspace(1e1, 1e5, 500)
ART = parse_model_spec("UD+measurement_artifact")


def _case(phase_x, mag_x, seed):
    vals = {**PAPER_TABLES["UD"], "omegas": 3000.0, "delta_s": mag_x * 0.002, "psi_s": phase_x * 0.002}
    meas = simulate(ART, vals, GRID, noise=0.002, seed=seed)
    return meas, vals


def test_a_clear_step_has_an_evidence_where_the_subspace_fallback_gave_none():
    """UD plant, phase step 25x and magnitude step 3x the noise, seed 2: the subspace fallback's
    importance sampling kept 4 effective draws of 4000 and gave no number, so the step was no
    candidate in the first round of its diagnosis; the interval sum gives one, and it does not
    depend on which interval the fit put the step in (the fit moved one point up: the same sum
    within 0.05 nats, since the likelihood is constant inside an interval)."""
    meas, vals = _case(25, 3, 2)
    fit = fit_admittance(meas, ART, initial=vals, warm=True)
    ev = fit_log_evidence(meas, fit)
    assert ev.method == step_intervals.STEP_METHOD and math.isfinite(ev.log_z) and not ev.fallback
    base = fit_log_evidence(meas, fit_admittance(meas, parse_model_spec("UD")))
    assert ev.log_z - base.log_z > 500  # the step the data show: hundreds of nats
    k = int(np.searchsorted(meas.omega, fit.parameters["omegas"]))
    moved = {**fit.parameters, "omegas": float(np.sqrt(meas.omega[k] * meas.omega[k + 1]))}
    other = fit_admittance(meas, ART, initial=moved, warm=True)
    assert other.parameters["omegas"] != fit.parameters["omegas"]
    assert abs(fit_log_evidence(meas, other).log_z - ev.log_z) < 0.05


def test_the_walk_outward_loses_nothing_a_wider_sum_would_add(monkeypatch):
    """The sum stops when an interval's term falls 10 nats below the largest; summing 8 intervals
    on each side instead changes log Z by less than 1e-3 nats (a weak step: phase 5x the noise,
    whose neighbouring intervals weigh most)."""
    meas, vals = _case(5, 1, 1)
    fit = fit_admittance(meas, ART, initial=vals, warm=True)
    lik = Likelihood(fit.model, meas)
    z0, scale, warp = fit_start(lik, fit)

    def run():
        return step_intervals.step_interval_evidence(meas, lik, lik.log_posterior_z, fit.parameters["omegas"],
                                                     z0, scale, warp, "omegas")[0]

    walk = run()
    monkeypatch.setattr(step_intervals, "DROP_INTERVAL", math.inf)
    monkeypatch.setattr(step_intervals, "MAX_INTERVALS", 8)
    assert abs(run() - walk) < 1e-3
