"""Closed-loop stability of the shunted transducer: the threshold in Rs against an independent
time-domain simulation, exact poles, the argument principle and the Bessel models' Foster form."""

import numpy as np
import pytest
from nl_circuit import nl_inductance_matrix
from scipy import special
from scipy.linalg import expm

from bayes_emt import build_model
from bayes_emt.reference import PAPER_SHUNTS, PAPER_TABLES
from bayes_emt.shunt import (
    assess_stability,
    closed_loop_poles,
    count_unstable_poles,
    foster_realisation,
    instability_threshold,
)

PAPER_MODELS = ("I", "II", "III", "UD", "NL")


def paper(name):
    m = build_model(name)
    return m, m.vector(PAPER_TABLES[name])


def nl_physical_state_matrix(Rs, Cs, p=PAPER_TABLES["NL"], n=5, N=480.0):
    """The RC-shunted NL system from its inductance matrix (SPEC.md §2, eq. 41's circuit), built
    independently of the package's modal/Foster pole code. States: x̄, v̄ (mass-normalised),
    capacitor voltage, coil current, ring currents."""
    L, Rv = nl_inductance_matrix(p, n, N)
    R = np.diag(np.r_[p["R0"] + Rs, Rv])
    z, w0, ph = p["zeta"], p["omega0"], p["phi"]
    k = 3 + n + 1
    A = np.zeros((k, k))
    A[0, 1], A[1, 0], A[1, 1], A[1, 3] = 1.0, -(w0**2), -2 * z * w0, ph
    A[2, 3] = 1.0 / Cs
    Li = np.linalg.inv(L)
    A[3:, 3:] = -Li @ R
    A[3:, 1] -= Li[:, 0] * ph  # back-EMF in the coil loop
    A[3:, 2] -= Li[:, 0]  # capacitor voltage in the coil loop
    return A


def growth(A, seconds=60.0, dt=1e-3):
    """Envelope ratio (last 2 s window / middle 2 s window) of the free response from x̄ = 1,
    stepped exactly with expm(A dt)."""
    E = expm(A * dt)
    x = np.zeros(A.shape[0])
    x[0] = 1.0
    per = int(round(2.0 / dt))
    env = np.zeros(int(seconds / 2))
    for k in range(int(round(seconds / dt))):
        x = E @ x
        env[k // per] = max(env[k // per], np.linalg.norm(x))
    return env[-1] / env[len(env) // 2]


@pytest.mark.parametrize("Cs", [PAPER_SHUNTS["NL"]["Cs"], 0.2])
def test_instability_threshold_agrees_with_time_domain_simulation(Cs):
    # acceptance: the Rs at which stability is lost agrees with an independent time-domain
    # simulation of the rational NL system to 1e-3 ohm: 1e-3 ohm above the computed threshold the
    # free response decays, 1e-3 ohm below it grows (so the simulated threshold lies within ±1e-3)
    nl, th = paper("NL")
    rc = instability_threshold(nl, th, Cs)
    assert growth(nl_physical_state_matrix(rc + 1e-3, Cs)) < 0.9
    assert growth(nl_physical_state_matrix(rc - 1e-3, Cs)) > 1.1


def test_independent_realisation_has_the_same_poles():
    nl, th = paper("NL")
    Rs, Cs = PAPER_SHUNTS["NL"]["Rs"], PAPER_SHUNTS["NL"]["Cs"]
    a = np.sort_complex(np.linalg.eigvals(nl_physical_state_matrix(Rs, Cs)))
    b = np.sort_complex(closed_loop_poles(nl, th, Rs, Cs))
    assert b == pytest.approx(a, rel=1e-8)


@pytest.mark.parametrize("name", PAPER_MODELS)
def test_threshold_poles_and_argument_principle_agree(name):
    # three independent routes: the crossing condition (exact model), the eigenvalues of the Foster
    # realisation (III/UD: 40 eddy modes) and the argument principle on the exact model
    m, th = paper(name)
    Cs = PAPER_SHUNTS[name]["Cs"]
    rc = instability_threshold(m, th, Cs)
    above, below = rc + 1e-6, rc - 1e-6
    assert np.max(closed_loop_poles(m, th, above, Cs).real) < 0
    assert np.max(closed_loop_poles(m, th, below, Cs).real) > 0
    assert count_unstable_poles(m, th, above, Cs) == 0
    assert count_unstable_poles(m, th, below, Cs) == 2  # a complex pair crosses
    for rs in (rc - 0.5, rc + 0.2, 3.0):
        p = closed_loop_poles(m, th, rs, Cs)
        assert count_unstable_poles(m, th, rs, Cs) == np.count_nonzero(p.real > 0)


def test_model_II_pole_through_infinity():
    # model II has no series inductance: at Rs = −(R0 + Rμ) a pole leaves through infinity
    m, th = paper("II")
    p = PAPER_TABLES["II"]
    edge = -(p["R0"] + p["Rmu"])
    Cs = 1e-4  # a small Cs: no crossing on the axis above that edge
    rc = instability_threshold(m, th, Cs)
    assert rc == pytest.approx(edge, abs=1e-12)
    assert np.max(closed_loop_poles(m, th, rc - 1e-3, Cs).real) > 1e6  # the pole came from infinity
    assert assess_stability(m, th, rc + 1e-3, Cs).stable
    assert not assess_stability(m, th, rc - 1e-3, Cs).stable


def test_threshold_vectorised_over_parameter_sets():
    nl, th = paper("NL")
    rng = np.random.default_rng(2)
    thetas = th * (1 + 0.01 * rng.standard_normal((2, 3, th.size)))
    out = instability_threshold(nl, thetas, 0.08)
    assert out.shape == (2, 3)
    assert out[1, 2] == instability_threshold(nl, thetas[1, 2], 0.08)


# ---- Foster form of the Bessel models -----------------------------------------------------------
def test_bessel_mittag_leffler_sections():
    # L_k = 2β√α/j_k², τ_k = α/j_k²; their sum is the low-frequency inductance β√α/2 (SPEC.md §2)
    m, th = paper("III")
    f = foster_realisation(m, th)
    p = PAPER_TABLES["III"]
    j = special.jn_zeros(0, f.L.size)
    assert f.L == pytest.approx(2 * p["beta"] * np.sqrt(p["alpha"]) / j**2, rel=1e-13)
    assert f.tau == pytest.approx(p["alpha"] / j**2, rel=1e-13)
    assert f.G + f.L.sum() == pytest.approx(p["beta"] * np.sqrt(p["alpha"]) / 2, rel=1e-13)


@pytest.mark.parametrize("name", ["III", "UD"])
def test_bessel_foster_error_within_stated_bound(name):
    m, th = paper(name)
    f = foster_realisation(m, th)
    assert not f.exact and 0 < f.error_coeff < 1e-12
    # on the imaginary axis and inside the right half-plane
    s = np.r_[1j * np.geomspace(1, 1e5, 60), np.geomspace(1, 1e5, 20), 300 * np.exp(0.7j)]
    exact = m.electrical_impedance_s(s, th)
    err = np.abs(exact - f.impedance(s))
    assert np.all(err <= f.error_bound(s) * (1 + 1e-6) + 1e-13 * np.abs(exact))


def test_bessel_threshold_matches_many_ring_rational_model():
    # UL converges to UD as n grows (SPEC.md §2): the exact UD threshold vs UL(80)'s
    ud, th = paper("UD")
    ul = build_model("UL", rings=80)
    Cs = PAPER_SHUNTS["UD"]["Cs"]
    assert instability_threshold(ud, th, Cs) == pytest.approx(instability_threshold(ul, th, Cs), abs=5e-3)


def test_stability_report_margins():
    nl, th = paper("NL")
    r = assess_stability(nl, th, PAPER_SHUNTS["NL"]["Rs"], PAPER_SHUNTS["NL"]["Cs"])
    assert r.stable and r.n_unstable == 0 and r.max_pole_real < 0 and 0 < r.min_damping_ratio < 1
    assert "exact" in r.method
