"""Initial estimate and two-step least squares against the paper's tables (SPEC.md §3, §5)."""

import json

import numpy as np
import pytest

from bayes_emt import IdentifiabilityWarning, build_model, simulate
from bayes_emt.cli import main
from bayes_emt.errors import DataFormatError
from bayes_emt.estimation.fitting import (
    central_jacobian,
    covariance_z,
    fit_admittance,
    forward_jacobian,
    relative_residuals,
)
from bayes_emt.io import write_measurement
from bayes_emt.reference import PAPER_TABLES

CASES = [("I", None, "I"), ("II", None, "II"), ("III", None, "III"), ("UD", None, "UD"),
         ("NL", 5, "NL"), ("UL", 5, "UD")]


def truth_of(name, rings, table):
    m = build_model(name, rings=rings)
    return m, m.vector(PAPER_TABLES[table])


@pytest.mark.parametrize("name, rings, table", CASES)
def test_noise_free_recovery_from_data_alone(name, rings, table):
    # acceptance 1: SPEC §5 Tables 1-5 (UL from Table 4's UD values), 2000 log points 1e1..1e5
    # rad/s, no noise: every parameter within 0.1 % (measured: 4e-15 for NL), the impedance too
    model, truth = truth_of(name, rings, table)
    meas = simulate(model, truth)
    fit = fit_admittance(meas, model)
    rel = np.abs(fit.theta / truth - 1)
    assert np.max(rel) < 1e-3, dict(zip(model.names, rel, strict=True))
    assert fit.warnings == ()  # the exact model: round-off residuals are no misfit (adequacy.NOISE_FLOOR)
    if name == "NL":
        z_fit = model.coil_impedance(meas.omega, fit.theta)
        z_true = model.coil_impedance(meas.omega, truth)
        assert np.max(np.abs(z_fit / z_true - 1)) < 1e-4
        z_term = model.impedance(meas.omega, fit.theta) / model.impedance(meas.omega, truth)
        assert np.max(np.abs(z_term - 1)) < 1e-4


def _coverage(name, rings, table, seeds):
    """Fractions of |fit − truth| within 1, 2 and 4 standard errors over seeds and parameters."""
    model, truth = truth_of(name, rings, table)
    t = []
    for seed in seeds:
        fit = fit_admittance(simulate(model, truth, noise=0.002, seed=seed), model)
        se = np.array([fit.stderr[n] for n in model.names])
        t.extend(np.abs(fit.theta - truth) / se)
    t = np.array(t)
    return {k: float(np.mean(t <= k)) for k in (1, 2, 4)}


@pytest.mark.parametrize("name, rings, table", [c for c in CASES if c[0] in ("I", "II", "UD")])
def test_standard_errors_are_honest_quick(name, rings, table):
    # a quick version of acceptance 2 (5 seeds); the full 20-seed run is marked slow. Two-sided:
    # errors too small leave truths beyond 4 se; errors too large put nearly all within 1 se, where a
    # Gaussian puts 68 % (measured with seeds 0-4: I 0.68, II 0.77, UD 0.71; 2x inflated errors would
    # give about 0.95, 2x too small about 0.38)
    cov = _coverage(name, rings, table, range(5))
    assert cov[4] >= 0.95 and 0.45 <= cov[1] <= 0.9, cov


@pytest.mark.slow
@pytest.mark.parametrize("name, rings, table", CASES)
def test_standard_errors_are_honest_20_seeds(name, rings, table):
    # acceptance 2: 0.2 % noise (the simulator's relative complex Gaussian), 20 seeds: >= 95 % of
    # parameters within 4 standard errors. Honest also means not inflated: a Gaussian puts 68 % within
    # 1 and 95 % within 2 (measured 0.69-0.74 and 0.94-0.98 over the six models)
    cov = _coverage(name, rings, table, range(20))
    assert cov[4] >= 0.95 and cov[2] >= 0.85 and cov[1] <= 0.85, cov


def test_fit_reports_and_serialises():
    model, truth = truth_of("UD", None, "UD")
    fit = fit_admittance(simulate(model, truth, noise=0.002, seed=2), model)
    rec = fit.to_json_dict()
    assert set(rec) >= {"model", "rings", "parameters", "stderr", "rms_rel_residual", "chi2", "n_points"}
    assert rec["n_points"] == 2000 and 0.002 < rec["rms_rel_residual"] < 0.004
    json.dumps(rec)
    labels = [s["step"][:2] for s in fit.info["steps"]]
    assert labels[-3:] == ["1:", "2:", "3:"] and set(labels[:-3]) == {"0:"} and len(labels) <= 6
    assert fit.info["initial"]["path"].startswith(("levy", "resonance peak"))
    assert fit.info["final_start"] in ("step 0", "step 2") and fit.info["seconds"] > 0
    assert fit.success and fit.initial.shape == (model.ndim,)


def test_band_without_resonance_warns_and_too_few_points_raise():
    model, truth = truth_of("I", None, "I")
    with pytest.warns(IdentifiabilityWarning, match="no mechanical resonance"):
        fit_admittance(simulate(model, truth, np.geomspace(1e3, 1e5, 200), noise=0.002, seed=1), model,
                       initial=truth)
    with pytest.raises(DataFormatError, match="cannot determine the 15 parameters"):
        fit_admittance(simulate(model, truth, np.geomspace(40, 60, 7)), build_model("NL"))


def test_cli_fit_json(tmp_path, capsys):
    model, truth = truth_of("II", None, "II")
    data = tmp_path / "d.csv"
    write_measurement(simulate(model, truth, noise=0.002, seed=5), data)
    out = tmp_path / "fit.json"
    assert main(["fit", str(data), "--model", "II", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Rmu" in text and "ohm" in text and "std error" in text
    rec = json.loads(out.read_text())
    assert rec["model"] == "II" and rec["parameters"]["Rmu"] == pytest.approx(2.95, rel=0.02)
    # the fit's JSON feeds simulate and shunt
    assert main(["simulate", "--params", str(out), "--out", str(tmp_path / "s.zma"), "--points", "300"]) == 0
    assert main(["shunt", "--params", str(out)]) == 0


@pytest.mark.parametrize("seed", [0, 4])
def test_noisy_nl_fit_reaches_the_least_squares_minimum(seed):
    # with 0.2 % noise the paper's W = 1/s step can drag weakly identified ring parameters into a
    # worse valley (these seeds did); a least-squares estimate must fit at least as well as the
    # truth, and its errors must be of the size its standard errors say
    model, truth = truth_of("NL", 5, "NL")
    meas = simulate(model, truth, noise=0.002, seed=seed)
    fit = fit_admittance(meas, model)
    cost_truth = np.sum(np.abs(relative_residuals(model, meas, truth)) ** 2)
    assert fit.chi2 <= cost_truth
    se = np.array([fit.stderr[n] for n in model.names])
    assert np.all(np.abs(fit.theta - truth) < 5 * se)


def test_user_start_and_paper_only_estimate():
    model, truth = truth_of("II", None, "II")
    meas = simulate(model, truth, noise=0.002, seed=3)
    start = {k: v * 1.1 for k, v in PAPER_TABLES["II"].items()}
    fit = fit_admittance(meas, model, initial=start, polish=False)
    assert fit.info["initial"] == {"path": "user"} and fit.info["final_start"] == "step 2"
    assert not any(s["step"].startswith("3:") for s in fit.info["steps"])
    np.testing.assert_allclose(fit.initial, model.vector(start))
    np.testing.assert_allclose(fit.theta, truth, rtol=0.05)
    with pytest.raises(ValueError, match="6 values"):
        fit_admittance(meas, model, initial=truth[:4])
    with pytest.raises(ValueError, match="finite and positive"):
        fit_admittance(meas, model, initial=-truth)


def test_omega_range_restricts_the_data():
    model, truth = truth_of("I", None, "I")
    fit = fit_admittance(simulate(model, truth), model, omega_range=(10, 1e3))
    assert fit.n_points == np.count_nonzero(np.geomspace(10, 1e5, 2000) <= 1e3)
    np.testing.assert_allclose(fit.theta, truth, rtol=1e-6)


def test_jacobians_and_covariance():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((50, 3))

    def batch(z):  # a smooth batched residual with a known Jacobian
        return np.sin(z @ A.T)

    z = np.array([0.1, -0.2, 0.3])
    J = np.cos(A @ z)[:, None] * A
    np.testing.assert_allclose(central_jacobian(batch, z), J, atol=1e-8)
    np.testing.assert_allclose(forward_jacobian(batch, z), J, atol=1e-6)
    # s² (JᵀJ)⁻¹ for a linear model with unit noise; a rank-deficient Jacobian gives None
    r = rng.standard_normal(50)
    cov = covariance_z(A, r, 3)
    np.testing.assert_allclose(cov, np.linalg.inv(A.T @ A) * (r @ r) / 47)
    assert covariance_z(np.column_stack([A[:, :2], A[:, 0]]), r, 3) is None


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert main(["fit", str(tmp_path / "missing.zma"), "--model", "I"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bayes-emt: error:")


def test_a_too_simple_model_keeps_the_resonance_where_the_data_has_it():
    # model I on the bundled NL(5) data (Table 5 truth, omega0 = 50.8 rad/s): the relative-residual
    # objective has a degenerate optimum (zeta at its bound 2, omega0 ~ 4.6e4 rad/s, the mechanical
    # branch mimicking the eddy-current resistance rise) cheaper than any fit that keeps the
    # resonance. The fit must keep the transducer's resonance. Which start-ups end in the degenerate
    # valley depends on rounding (another processor sent a different one to omega0 = 11.4 rad/s), so
    # the rejected candidates are checked against the rule's definition, not pinned
    from bayes_emt.estimation.checks import locate_resonance
    from bayes_emt.estimation.fitting import batched_least_squares
    from bayes_emt.io.datasets import load_paper_bench

    meas = load_paper_bench()
    model = build_model("I")
    fit = fit_admittance(meas, model)
    p = fit.parameters
    assert abs(p["omega0"] / 50.8 - 1) < 0.01 and p["zeta"] < 0.05, p
    assert "resonance_mismatch" not in fit.info
    res = locate_resonance(meas)
    lo_w, hi_w = 0.5 * min(res.omega_lo, res.omega), 2 * max(res.omega_hi, res.omega)
    for r in fit.info.get("rejected", []):  # the rule: omega0 outside a factor 2 of the peak's band
        assert not lo_w <= r["omega0"] <= hi_w, r
    # the degenerate optimum exists and is cheaper: a local least-squares descent of the same
    # objective from a start in its valley stays there, below the fit's cost
    w = 1 / np.abs(meas.Y)

    def batch(z):
        d = (model.admittance(meas.omega, model.params.from_z(z)) - meas.Y) * w
        return np.concatenate([d.real, d.imag], axis=-1)

    lo, hi = model.params.bounds_z()
    start = model.params.to_z(model.vector({"zeta": 1.9, "omega0": 4.6e4, "phi": 100.0, "R0": 2.57,
                                            "L0": 1.65e-3}))
    sol = batched_least_squares(batch, start, lo, hi, max_nfev=500)
    degenerate = model.params.from_z(sol.x)
    assert degenerate[1] > 1e4 and 2 * sol.cost < fit.chi2, (degenerate, 2 * sol.cost, fit.chi2)
    # and a model this poor says so
    assert "model_inadequate" in fit.warning_codes


def test_high_resistance_coil_of_a_geophone_fits():
    # a geophone is the same physics with a fine-wire coil: an SM-24-like element has R0 ~ 375 ohm,
    # f0 ~ 10 Hz, open-circuit damping ~ 0.25, Bl ~ 28.8 N/A on an ~ 11 g mass (datasheet orders of
    # magnitude). R0 above 100 ohm was outside the (wrong, ring-resistance) prior support before;
    # 0.2 % noise, 400 points: every parameter within 4 standard errors
    model = build_model("I")
    truth = {"zeta": 0.25, "omega0": 2 * np.pi * 10, "phi": 28.8 / np.sqrt(0.011), "R0": 375.0, "L0": 0.02}
    meas = simulate(model, model.vector(truth), np.geomspace(10, 1e5, 400), noise=0.002, seed=1)
    fit = fit_admittance(meas, model)
    for name, value in truth.items():
        assert abs(fit.parameters[name] - value) < 4 * fit.stderr[name], name


def test_a_polish_that_runs_out_of_evaluations_is_continued_and_never_worse():
    """``_Problem.polish``: a solve that ends at its budget (scipy status 0) is continued with unit
    scaling for another budget; the result's cost is at most the first solve's, and ``nfev`` counts
    both. A solve that converges is returned as it is."""
    from bayes_emt.estimation.fitting import _Problem

    model, truth = truth_of("UD", None, "UD")
    meas = simulate(model, truth, noise=0.002, seed=3)
    model = model.bind(meas.omega)
    k = model.ndim
    prob = _Problem(model, meas, 1.0 / np.abs(meas.Y), np.arange(k), np.zeros(k))
    lo, hi = model.params.bounds_z()
    z0 = model.params.to_z(truth * np.r_[1.3, 0.9, 1.1, 1.05, np.ones(k - 4) * 1.2])
    short = prob.solve(z0, lo, hi, max_nfev=4)
    assert short.status == 0
    pol = prob.polish(z0, lo, hi, max_nfev=4)
    assert pol.cost <= short.cost and pol.nfev > short.nfev
    full = prob.solve(z0, lo, hi, max_nfev=25 * k)
    assert full.status != 0
    again = prob.polish(z0, lo, hi, max_nfev=25 * k)
    assert again.cost == pytest.approx(full.cost, rel=1e-12) and again.nfev == full.nfev


def test_a_model_with_a_term_fits_warm_from_its_automatic_starts_to_the_same_optimum():
    """``warm=True`` without ``initial`` on a model with an augmentation: the automatic starts (the
    base model's fit and the term's starts) go straight to the polish and reach the full fit's cost;
    ``fit_reusing`` keeps the warm and the full fit apart."""
    from bayes_emt.estimation.fitting import fit_reusing
    from bayes_emt.models import parse_model_spec
    from bayes_emt.thiele_small.simulate import simulate_driver

    meas = simulate_driver("UD+suspension_creep", deltas=(), seed=3, n_points=250).free
    model = parse_model_spec("UD+suspension_creep")
    reuse: dict = {}
    full = fit_reusing(meas, model, reuse)
    warm = fit_admittance(meas, model, warm=True, reuse=reuse)
    assert warm.info["warm"] and not full.info["warm"] and "warm start" in warm.info["path"]
    assert [s["step"][0] for s in warm.info["steps"]] == ["0"] * (len(warm.info["steps"]) - 1) + ["3"]
    assert warm.chi2 == pytest.approx(full.chi2, rel=1e-6)
    np.testing.assert_allclose(np.log(warm.theta), np.log(full.theta), atol=1e-4)
    assert fit_reusing(meas, model, reuse) is full  # the cached full fit, not the warm one
    assert fit_reusing(meas, model, reuse, warm=True) is not full
