"""Ring count for NL by Hankel singular values (SPEC §3.3): the HSV routine against closed forms
and an independent method, the choice rule, and the paper's n = 7 → n = 5 on simulated data."""

import json
import warnings

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.cli import main
from bayes_emt.errors import IdentifiabilityWarning
from bayes_emt.estimation.hankel import (
    blocked_state_space,
    choose_rings,
    fold_out_of_band,
    foster_parts,
    gramian_hsv,
    hankel_singular_values,
    select_rings,
)
from bayes_emt.io import write_measurement
from bayes_emt.reference import PAPER_TABLES

TABLE5 = PAPER_TABLES["NL"]
# a two-ring coil with the Table 5 mechanics and gap (quick fits)
NL2 = {k: TABLE5[k] for k in ("zeta", "omega0", "phi", "R0", "Pg")} | {
    "P1": 8e-9, "P2": 8e-9, "R1": 1e-5, "R2": 2e-4}


def _nl(rings, values):
    m = build_model("NL", rings=rings)
    return m, m.vector(values)


def _spread_nl():
    """NL(6) with ring time constants spread over 1e-7..1e-2 s (R over five decades)."""
    n = 6
    vals = {"zeta": 0.01, "omega0": 50.0, "phi": 2.0, "R0": 2.5, "Pg": 3e-9}
    vals |= {f"P{j}": 4e-9 for j in range(1, n + 1)}
    vals |= {f"R{j}": r for j, r in enumerate(np.geomspace(1e-7, 3e-2, n), start=1)}
    return _nl(n, vals)


# ---- (b) closed forms ----------------------------------------------------------------------------

def test_first_order_coil_has_hsv_one_over_2r0():
    # 1/(R0 + L0 s) = (1/L0)/(s + R0/L0): one state, gramians b²/(2a) and c²/(2a), σ = |b c|/(2a)
    # = 1/(2 R0), whatever L0
    m = build_model("I")
    for L0 in (1e-6, 1.65e-3, 1.0):
        theta = m.vector({"zeta": 0.01, "omega0": 50, "phi": 1, "R0": 2.5, "L0": L0})
        np.testing.assert_allclose(hankel_singular_values(m, theta), [0.2], rtol=1e-13)


@pytest.mark.parametrize("case", ["table5", "spread", "UL7"])
def test_hsv_sum_is_half_the_dc_admittance(case):
    # state-space symmetric (RL circuit) ⇒ Wc = Wo = W, Σσ = trace W = ½ Bᵀ(−A)⁻¹B = Yb(0)/2 = 1/(2 R0):
    # an exact identity, tested to round-off
    if case == "table5":
        m, th = _nl(5, TABLE5)
    elif case == "spread":
        m, th = _spread_nl()
    else:
        m = build_model("UL", rings=7)
        th = m.vector({**{k: TABLE5[k] for k in ("zeta", "omega0", "phi", "R0")},
                       **{k: v for k, v in PAPER_TABLES["UD"].items() if k in ("Lg", "alpha", "beta")}})
    hsv = hankel_singular_values(m, th)
    assert hsv.size == m.rings + 1
    assert np.all(np.diff(hsv) <= 0) and hsv[-1] > 0
    np.testing.assert_allclose(hsv.sum(), 1 / (2 * m.as_dict(th)["R0"]), rtol=1e-10)


def test_realisation_reproduces_the_model_admittance():
    m, th = _spread_nl()
    A, B, C = blocked_state_space(m, th)
    np.testing.assert_allclose(A, A.T, rtol=0, atol=0)
    s = 1j * np.geomspace(1, 1e8, 50)
    Yss = np.array([(C @ np.linalg.solve(si * np.eye(A.shape[0]) - A, B))[0, 0] for si in s])
    Ym = 1 / m.electrical_impedance_s(s, th)
    np.testing.assert_allclose(Yss, Ym, rtol=1e-9)


# ---- (a) invariants: state scaling, independent method, spread time constants ------------------

@pytest.mark.parametrize("make", [lambda: _nl(5, TABLE5), _spread_nl])
def test_hsv_invariant_to_state_scaling_and_agree_with_square_root_method(make):
    # HSV are similarity invariants. The square-root method (two Lyapunov solves, LAPACK balancing)
    # on realisations scaled over eight decades must give every value, down to the smallest, as the
    # closed-form symmetric route does. Time constants 1e-7..1e-2 s in the "spread" case.
    m, th = make()
    hsv = hankel_singular_values(m, th)
    A, B, C = blocked_state_space(m, th)
    rng = np.random.default_rng(0)
    n = A.shape[0]
    spread = np.geomspace(1e-4, 1e4, n)
    for T in (np.eye(n), np.diag(spread), np.diag(rng.permutation(spread))):
        Ti = np.diag(1 / np.diag(T))
        np.testing.assert_allclose(gramian_hsv(T @ A @ Ti, T @ B, C @ Ti), hsv, rtol=1e-8)
    # the physical (inductor current) coordinates: x = M^-½ ξ with M = diag(G, L_k)
    _, G, Lk, _ = foster_parts(m, th)
    Mh = np.sqrt(np.r_[G, Lk])
    np.testing.assert_allclose(gramian_hsv(A * Mh[None, :] / Mh[:, None], B / Mh[:, None], C * Mh[None, :]),
                               hsv, rtol=1e-8)


def test_out_of_band_modes_are_folded():
    # a ring with its corner at 0.01 rad/s acts in 10..1e5 rad/s as the resistor L/τ in series
    # with R0: folded, it gets HSV 0 and the sum identity holds with the augmented R0
    m, th = _nl(2, NL2 | {"R1": 1e-12})
    R0, G, Lk, tau = foster_parts(m, th)
    assert (1 / tau).min() < 1.0
    R0f, Gf, Lkf, _, nf = fold_out_of_band(R0, G, Lk, tau, (10.0, 1e5))
    assert nf == 1 and Lkf.size == 1 and Gf == G and R0f > R0
    hsv = hankel_singular_values(m, th, band=(10.0, 1e5))
    assert hsv.size == 3 and hsv[-1] == 0 and hsv[1] > 0
    np.testing.assert_allclose(hsv.sum(), 1 / (2 * R0f), rtol=1e-12)
    # in band, nothing is folded
    np.testing.assert_array_equal(hankel_singular_values(m, m.vector(NL2), band=(10.0, 1e5)),
                                  hankel_singular_values(m, m.vector(NL2)))


def test_models_without_series_inductance_are_refused():
    m = build_model("II")
    with pytest.raises(ValueError, match="series"):
        hankel_singular_values(m, m.vector(PAPER_TABLES["II"]))


# ---- the rule ---------------------------------------------------------------------------------

def test_choose_rings_rule():
    # the paper: n = 7 fit, 8 states, sharp drop between states 6 and 7 → n = 5
    assert choose_rings([1, 0.1, 0.03, 0.01, 0.003, 0.001, 1e-5, 3e-6]) == 5
    # folded states (exactly 0) count as a drop to the 1e-8 σ1 floor: still the sharpest
    assert choose_rings([0.17, 0.016, 0.0043, 0.0013, 3.9e-4, 9.3e-5, 0, 0]) == 5
    # the largest drop wins, not the first sharp one
    assert choose_rings([1, 0.1, 0.005, 0.002, 1e-6, 5e-7]) == 3
    # a drop between two immaterial states (below the floor) cannot outrank a real one
    assert choose_rings([1, 0.1, 0.03, 0.01, 0.003, 0.001, 1e-6, 0]) == 5
    # the coil current → first ring ratio is never a cut (n ≥ 1)
    assert choose_rings([1, 1e-3, 5e-4, 2e-4]) == 3
    # no drop ≥ sharp_drop: keep every state
    assert choose_rings([1, 0.3, 0.1, 0.03]) == 3
    assert choose_rings([1, 0.3, 0.1, 0.03], sharp_drop=2.5) == 2  # 0.1/0.03 = 3.3 is the largest
    assert choose_rings([1.0]) == 0 and choose_rings([1.0, 0.5]) == 1
    # states below the noise floor are unresolved: Table 5 data, seed 11, NL(7) fit (ε = 1.28e-5 S):
    # the spare in-band ring (1.66e-5) is no sharp drop by itself, but lies below 2.5 ε
    seed11 = [0.173, 0.0163, 0.00429, 0.00125, 3.89e-4, 9.30e-5, 1.66e-5, 0]
    assert choose_rings(seed11) == 6
    assert choose_rings(seed11, noise_floor=2.5 * 1.28e-5) == 5
    # seed 1: a spare ring at 1e-6 S made the drop *after* it the largest
    seed1 = [0.173, 0.0163, 0.00429, 0.00126, 3.89e-4, 9.05e-5, 1.04e-6, 0]
    assert choose_rings(seed1) == 6 and choose_rings(seed1, noise_floor=3.2e-5) == 5
    assert choose_rings([1, 1e-3, 5e-4, 2e-4], noise_floor=0.01) == 1  # no ring resolved
    for bad in ([0.1, 1.0, 0.01], [], [1, -1e-3], [1, np.nan]):
        with pytest.raises(ValueError):
            choose_rings(bad)


# ---- ring count from data ----------------------------------------------------------------------

def test_two_ring_data_choose_two_rings_quickly():
    meas = simulate(build_model("NL", rings=2), NL2, np.geomspace(10, 1e5, 400), noise=0.002, seed=5)
    rc = select_rings(meas, 4)
    assert rc.rings == 2 and rc.hsv.size == 5 and rc.fit.model.rings == 4
    rec = json.loads(json.dumps(rc.to_json_dict(), allow_nan=False))
    assert rec["rings"] == 2 and len(rec["hankel_singular_values"]) == 5


def test_noise_level_is_relative_noise_times_smallest_admittance():
    from bayes_emt.estimation.hankel import noise_level
    from bayes_emt.estimation.results import FitResult

    m = build_model("NL")
    meas = simulate(m, TABLE5, np.geomspace(1e1, 1e5, 2000), noise=0.002, seed=3)
    fit = FitResult(m, m.vector(TABLE5), None, 0.0, 0.0, meas.n_points)
    eps = noise_level(meas, fit)
    np.testing.assert_allclose(eps, 0.002 * np.abs(m.admittance(meas.omega, fit.theta)).min(), rtol=0.05)


def _table5_data(seed):
    # SPEC §5 measurement: NL(5) with Table 5 values, 2000 log-spaced points over 1e1..1e5 rad/s,
    # 0.2 % relative complex noise
    return simulate(build_model("NL"), TABLE5, np.geomspace(1e1, 1e5, 2000), noise=0.002, seed=seed)


def test_table5_data_choose_five_rings_from_a_seven_ring_fit():
    # acceptance: SPEC §3.3 (the paper fitted n = 7 and found the drop between states 6 and 7 → n = 5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        rc = select_rings(_table5_data(11), 7)
    print("HSV [S]:", rc.hsv, "ratios:", rc.ratios, "folded:", rc.n_folded, "floor:", rc.noise_floor)
    assert rc.hsv.size == 8
    assert rc.rings == 5
    # six states resolved, with a margin of two on the noise floor both ways
    assert rc.resolved[:6].all() and not rc.resolved[6:].any()
    assert rc.hsv[5] > 2 * rc.noise_floor and rc.hsv[6] < rc.noise_floor / 1.5


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_table5_data_choose_five_rings_other_seeds(seed):
    assert select_rings(_table5_data(seed), 7).rings == 5


def test_hankel_command(tmp_path, capsys):
    meas = simulate(build_model("NL", rings=2), NL2, np.geomspace(10, 1e5, 400), noise=0.002, seed=5)
    data = write_measurement(meas, tmp_path / "nl2.csv")
    out = tmp_path / "hsv.json"
    assert main(["hankel", str(data), "--max-rings", "4", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "chosen: n = 2 rings" in text and "HSV [S]" in text
    assert json.loads(out.read_text())["rings"] == 2
    assert main(["hankel", str(data), "--max-rings", "1"]) == 2
    assert "max-rings" in capsys.readouterr().err
