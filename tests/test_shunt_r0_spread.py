"""The robust shunt's R0 is the honest one: the posterior's R0 draws widened by the spread between the
fit's R0 and the recording's low-frequency plateau (bayes_emt/shunt/r0_spread.py), and a design whose
stability margin falls inside that interval is flagged.

Simulated driver (UD, the T/S simulator's default driver, 300 points 10 Hz-2 kHz,
0.5 % noise) with posterior draws 0.1 % around its least-squares fit, and a low band of 12 rows
(1 Hz .. fs/6) written by a driver whose coil resistance is 8 % below the fit's R0 (the GRS woofer's
DATS file shows 10.9 %: fit R0 4.643 ohm against its plateau 4.138 ohm) or equal to it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.inference.posterior import Posterior
from bayes_emt.models import parse_model_spec
from bayes_emt.shunt.draws import DrawGroup
from bayes_emt.shunt.from_posterior import robust_shunt
from bayes_emt.shunt.r0_spread import r0_spread, widen_r0
from bayes_emt.shunt.safety import MARGIN_CODE
from bayes_emt.thiele_small.relations import free_air
from bayes_emt.thiele_small.simulate import simulate_driver

SPEC = "UD"


@pytest.fixture(scope="module")
def driver():
    model = parse_model_spec(SPEC)
    sim = simulate_driver(SPEC, deltas=(), seed=3, n_points=300)
    fit = fit_admittance(sim.free, model)
    fs = float(free_air(fit.model, fit.theta[None, :])["fs"][0])
    return model, sim, fit, fs


def _low_band(model, theta, fs, r0_factor):
    """12 rows 1 Hz .. fs/6 of the fitted driver with its R0 scaled by ``r0_factor`` (0.01 % noise)."""
    th = np.array(theta, float)
    th[model.names.index("R0")] *= r0_factor
    f = np.geomspace(1.0, fs / 6, 12)
    z = 1.0 / model.admittance(2 * math.pi * f, th[None, :])[0]
    z = z * (1 + 1e-4 * np.random.default_rng(0).standard_normal(z.size))
    return {"f_hz": list(map(float, f)), "abs_ohm": list(map(float, np.abs(z))),
            "phase_deg": list(map(float, np.degrees(np.angle(z))))}


def _posterior(model, meas, theta, rel=1e-3, n_chains=8, n_draws=25, seed=0):
    lik = Likelihood(model, meas)
    k = theta.size
    rng = np.random.default_rng(seed)
    th = theta * (1 + rel * rng.standard_normal((n_chains * n_draws, k)))
    noise = np.tile([0.005, 1e-9][: lik.ndim - k], (th.shape[0], 1))
    draws = np.concatenate([th, noise], axis=1).reshape(n_chains, n_draws, -1)
    zeros = np.zeros((n_chains, n_draws))
    return Posterior(lik, draws, np.arange(n_draws), zeros, zeros, np.ones(lik.ndim), np.full(lik.ndim, 1e4),
                     n_draws, 0, 1, True, seed, "test draws", 0.3, 0.0)


def test_the_spread_is_zero_when_the_plateau_agrees_and_the_gap_when_it_does_not(driver):
    model, sim, fit, fs = driver
    r0 = float(fit.theta[model.names.index("R0")])
    thetas = fit.theta * (1 + 1e-3 * np.random.default_rng(1).standard_normal((200, fit.theta.size)))
    same = r0_spread(model, thetas, sim.free.with_meta(low_band=_low_band(model, fit.theta, fs, 1.0)))
    assert same is not None and same.tau_ohm == 0.0 and "not widened" in same.line()
    assert same.plateau_ohm == pytest.approx(r0, rel=2e-3)
    low = r0_spread(model, thetas, sim.free.with_meta(low_band=_low_band(model, fit.theta, fs, 0.92)))
    # tau^2 = (a-b)^2/2 - (u_a^2+u_b^2)/2: the 8 % gap over sqrt(2), less the two small sds
    assert low.tau_ohm == pytest.approx(0.08 * r0 / math.sqrt(2), rel=0.05)
    assert "widened" in low.line() and "-8.0 %" in low.line()
    assert r0_spread(model, thetas, sim.free) is None  # no low band: no second method
    g = DrawGroup(model, thetas)
    low_meas = sim.free.with_meta(low_band=_low_band(model, fit.theta, fs, 0.92))
    (wide,), (s,) = widen_r0([g], [low_meas], seed=0)
    i = model.params.index("R0")
    assert np.std(wide.thetas[:, i]) == pytest.approx(math.hypot(s.tau_ohm, s.r0_sd_ohm), rel=0.15)
    np.testing.assert_array_equal(np.delete(wide.thetas, i, axis=1), np.delete(thetas, i, axis=1))


def test_a_margin_inside_the_honest_r0_interval_is_flagged(driver):
    """The nominal shunt's margin is inside the 8 %-gap R0 interval: flagged with the total interval as
    the reason, and more of the held-back draws unstable; with r0="model" (the posterior alone, 0.1 %)
    the same design is not flagged."""
    model, sim, fit, fs = driver
    meas = sim.free.with_meta(low_band=_low_band(model, fit.theta, fs, 0.92))
    post = _posterior(model, meas, fit.theta)
    honest = robust_shunt(post, n_draws=60, seed=0)
    alone = robust_shunt(post, n_draws=60, seed=0, r0="model")
    unc = honest.nominal["r0_uncertainty"]
    assert "total_interval" in unc and "posterior_interval" not in unc
    margin = honest.nominal["stability_margin_ohm"]
    assert 0 < margin < unc["total_interval"]
    flagged = [w for w in honest.warnings if w.startswith(f"[{MARGIN_CODE}] nominal")]
    assert flagged and "low-frequency plateau" in flagged[0]
    assert any("widened by the spread to the low-frequency plateau" in w for w in honest.warnings)
    assert honest.report["r0_spread"][0]["tau_ohm"] > 0
    assert "posterior_interval" in alone.nominal["r0_uncertainty"] and alone.report["r0_spread"] == []
    assert margin > alone.nominal["r0_uncertainty_ohm"]
    assert not any(w.startswith(f"[{MARGIN_CODE}] nominal") for w in alone.warnings)
    assert honest.nominal["p_unstable"] > alone.nominal["p_unstable"]
    # the robust shunt is chosen against the widened R0: it keeps its margin beyond that interval
    assert honest.robust["stability_margin_ohm"] > unc["total_interval"]
