"""Invariants of the physics terms and models (SPEC.md §1-2): passivity, limits, convergence,
closed forms, vectorisation, numerical soundness far from the paper's values."""

import numpy as np
import pytest
from scipy import special

from bayes_emt import build_model
from bayes_emt.models import MODEL_NAMES
from bayes_emt.models import terms as T
from bayes_emt.reference import PAPER_TABLES

OMEGA_WIDE = np.geomspace(1e-1, 1e7, 801)  # rad/s: the range a sampler may ask for


def paper_theta(name, rings=None):
    model = build_model(name, rings=rings)
    src = "UD" if name == "UL" else name
    return model, model.vector(PAPER_TABLES[src])


def scattered_thetas(model, theta0, rng, n=200, decades=6):
    """Parameter sets log-uniformly within ±`decades` decades of the paper's (within prior support)."""
    out = theta0 * 10.0 ** rng.uniform(-decades, decades, size=(n, theta0.size))
    lo = np.array([s.prior.lower for s in model.params])
    hi = np.array([s.prior.upper for s in model.params])
    return np.clip(out, lo, hi)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_passive_and_finite_within_six_decades(name):
    model, theta0 = paper_theta(name)
    rng = np.random.default_rng(1)
    thetas = scattered_thetas(model, theta0, rng)
    Zc = model.coil_impedance(OMEGA_WIDE, thetas)
    Z = model.impedance(OMEGA_WIDE, thetas)
    assert np.all(np.isfinite(Zc)) and np.all(np.isfinite(Z))
    # passivity: Re Z >= 0 (tolerance: rounding relative to |Z|)
    assert np.all(Zc.real >= -1e-12 * np.abs(Zc))
    assert np.all(Z.real >= -1e-12 * np.abs(Z))


def test_bessel_ratio_matches_direct_formula_where_that_is_finite():
    # SPEC §2 model III written with J0, J1 of complex argument, valid for moderate |alpha s|
    s = 1j * np.geomspace(1e-1, 1e4, 200)
    alpha, beta = 3.74e-4, 0.287
    x = np.sqrt(-alpha * s)
    direct = -beta * np.sqrt(-s) * special.jv(1, x) / special.jv(0, x)
    np.testing.assert_allclose(T.bessel_eddy(s, alpha, beta), direct, rtol=1e-12)


def test_bessel_asymptotic_switch_is_continuous():
    w = np.array([999.999, 1000.001]) * np.exp(1j * np.pi / 4)
    direct = special.ive(1, w) / special.ive(0, w)
    np.testing.assert_allclose(T._i1_over_i0(w), direct, rtol=1e-14)


@pytest.mark.parametrize(
    "name, expected",
    [
        ("I", lambda p: p["L0"]),
        ("II", lambda p: p["L0"]),
        ("III", lambda p: p["beta"] * np.sqrt(p["alpha"]) / 2),  # SPEC §2 LF limit of III
        ("UD", lambda p: p["Lg"] + p["beta"] * np.sqrt(p["alpha"]) / 2),
        ("NL", lambda p: 480**2 * (p["Pg"] + sum(p[f"P{j}"] for j in range(1, 6)))),
    ],
)
def test_low_frequency_inductance(name, expected):
    model, theta = paper_theta(name)
    omega = np.array([1e-3])
    L = (model.coil_impedance(omega, theta) / (1j * omega)).real[0]
    assert L == pytest.approx(expected(PAPER_TABLES[name]), rel=1e-4)


def test_model_III_phase_tends_to_45_degrees():
    model, theta = paper_theta("III")
    # the approach is slow (I1/I0 ≈ 1 - 1/(2w), w = sqrt(alpha s)): phase decreases towards 45°
    phase = np.degrees(np.angle(model.coil_impedance(np.array([1e5, 1e7, 1e9, 1e13]), theta)))
    assert np.all(np.diff(phase) < 0) and np.all(phase > 45.0)
    assert phase[-1] == pytest.approx(45.0, abs=0.01)


def test_ul_converges_to_ud():
    # SPEC §2: max relative difference over 10..1e5 rad/s ≈ 16 % (n=5), 4 % (n=20), 1 % (n=80)
    omega = np.geomspace(10, 1e5, 2000)
    ud, theta = paper_theta("UD")
    z_ud = ud.coil_impedance(omega, theta)
    errs = []
    for n in (5, 20, 80):
        z_ul = build_model("UL", rings=n).coil_impedance(omega, theta)
        errs.append(np.max(np.abs(z_ul - z_ud) / np.abs(z_ud)))
    assert errs[0] == pytest.approx(0.16, abs=0.01)
    assert errs[1] == pytest.approx(0.04, abs=0.005)
    assert errs[2] == pytest.approx(0.01, abs=0.002)


def test_nl_with_one_ring_is_gap_plus_inductor_parallel_resistor():
    Pg, P, R, N = 3.4e-9, 4.1e-9, 2.9e-6, 480.0
    model = build_model("NL", rings=1, n_turns=N)
    omega = np.geomspace(1, 1e6, 300)
    s = 1j * omega
    theta = model.vector({"zeta": 0.01, "omega0": 50, "phi": 2, "R0": 2.5, "Pg": Pg, "P1": P, "R1": R})
    closed = N**2 * Pg * s + (N**2 * P * s) * (N**2 * R) / (N**2 * P * s + N**2 * R)
    np.testing.assert_allclose(model.coil_impedance(omega, theta), closed, rtol=1e-12)


def test_nl_modal_form_equals_equation_41():
    p = PAPER_TABLES["NL"]
    n, N = 5, 480.0
    Pv = np.array([p[f"P{j}"] for j in range(1, n + 1)])
    Rv = np.array([p[f"R{j}"] for j in range(1, n + 1)])
    D, U = np.tril(np.ones((n, n))), np.ones(n)
    Pm, Rm = np.diag(Pv), np.diag(Rv)
    s_all = 1j * np.geomspace(1, 1e6, 60)
    direct = np.array([
        N**2 * (p["Pg"] + U @ Pm @ U) * s
        - N**2 * (U @ Pm @ D.T @ np.linalg.solve(D @ Pm @ D.T * s + Rm, D @ Pm @ U)) * s**2
        for s in s_all])
    np.testing.assert_allclose(T.ring_ladder(s_all, np.array(p["Pg"]), Pv, Rv, N), direct, rtol=1e-10)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_vectorised_equals_loop(name):
    model, theta0 = paper_theta(name)
    rng = np.random.default_rng(2)
    thetas = theta0 * np.exp(0.3 * rng.standard_normal((7, theta0.size)))
    omega = np.geomspace(10, 1e5, 50)
    batch = model.admittance(omega, thetas)
    assert batch.shape == (7, 50)
    for i in range(7):
        np.testing.assert_allclose(batch[i], model.admittance(omega, thetas[i]), rtol=1e-13)
    assert model.admittance(omega, thetas.reshape(7, 1, -1)).shape == (7, 1, 50)


def test_admittance_is_equation_47_for_model_I():
    p = PAPER_TABLES["I"]
    model, theta = paper_theta("I")
    omega = np.geomspace(10, 1e5, 100)
    s = 1j * omega
    mech = s**2 + 2 * p["zeta"] * p["omega0"] * s + p["omega0"] ** 2
    Y = 1 / (p["L0"] * s + p["R0"] + p["phi"] ** 2 * s / mech)
    np.testing.assert_allclose(model.admittance(omega, theta), Y, rtol=1e-13)


def test_parameter_order_and_names_follow_spec():
    assert build_model("UD").names == ("zeta", "omega0", "phi", "R0", "Lg", "alpha", "beta")
    assert build_model("NL", rings=2).names == ("zeta", "omega0", "phi", "R0", "Pg", "P1", "P2", "R1", "R2")
    assert build_model("UL", rings=9).names[4:] == ("Lg", "alpha", "beta")


def test_bad_model_requests_raise_specific_errors():
    with pytest.raises(ValueError, match="unknown model"):
        build_model("XX")
    with pytest.raises(ValueError, match="rings"):
        build_model("NL", rings=0)
    with pytest.raises(ValueError, match="NL and UL only"):
        build_model("UD", rings=3)
    model = build_model("I")
    with pytest.raises(ValueError, match="takes 5 parameters"):
        model.admittance(np.array([1.0]), np.ones(4))
    with pytest.raises(KeyError, match="missing"):
        model.vector({"zeta": 0.1})


def test_with_term_and_priors_compose():
    model = build_model("I")
    from bayes_emt.models import make_term, model_from_dict

    aug = model.with_term(make_term("winding_capacitance"))
    assert aug.names[-1] == "Cp" and aug.spec == "I+winding_capacitance" and aug.base == "I"
    # a combination of base terms that is none of the paper's models keeps its terms as its name,
    # and rebuilds from its record all the same
    odd = model.with_term(make_term("bessel_eddy"))
    assert odd.names[-2:] == ("alpha", "beta") and odd.base is None and odd.spec == "inductance+bessel_eddy"
    assert model_from_dict(odd.to_dict()) == odd
    tight = model.with_priors({"R0": {"dist": "uniform", "lower": 2, "upper": 3}})
    assert tight.params["R0"].prior.upper == 3 and tight.names == model.names
    with pytest.raises(KeyError, match="unknown parameter"):
        model.with_priors({"nope": {"dist": "uniform", "lower": 0, "upper": 1}})
