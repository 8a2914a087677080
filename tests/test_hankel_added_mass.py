"""Ring count by Hankel singular values (SPEC §3.3) and added mass (SPEC §3.4, Appendix B)."""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

from bayes_emt import build_model, simulate
from bayes_emt.added_mass import fit_added_mass, physical_from_two_fits
from bayes_emt.datasets import load_paper_bench
from bayes_emt.hankel import blocked_state_space, choose_rings, hankel_singular_values, select_rings
from bayes_emt.io import read_measurement
from bayes_emt.reference import PAPER_ADDED_MASS, PAPER_PHYSICAL, PAPER_TABLES

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"


def test_hsv_of_first_order_system_closed_form():
    # 1/(R + L s) = (1/L)/(s + R/L): one state, HSV = b c / (2 a) = 1/(2 R)
    m = build_model("I")
    theta = m.vector({"zeta": 0.01, "omega0": 50, "phi": 1, "R0": 2.5, "L0": 1e-3})
    np.testing.assert_allclose(hankel_singular_values(m, theta), [1 / (2 * 2.5)], rtol=1e-10)


def test_hsv_invariant_to_state_scaling_and_direct_gramians():
    m = build_model("NL")
    th = m.vector(PAPER_TABLES["NL"])
    A, B, C = blocked_state_space(m, th)
    T = np.diag(np.geomspace(1, 1e3, A.shape[0]))
    Ti = np.linalg.inv(T)
    for AA, BB, CC in ((A, B, C), (T @ A @ Ti, T @ B, C @ Ti)):
        Wc = linalg.solve_continuous_lyapunov(AA, -BB @ BB.T)
        Wo = linalg.solve_continuous_lyapunov(AA.T, -CC.T @ CC)
        direct = np.sqrt(np.sort(np.abs(np.linalg.eigvals(Wc @ Wo)))[::-1])
        np.testing.assert_allclose(hankel_singular_values(m, th)[:3], direct[:3], rtol=1e-6)


def test_choose_rings_rule():
    assert choose_rings([1, 0.1, 0.03, 0.01, 0.003, 0.001, 1e-6, 0]) == 5
    assert choose_rings([1, 0.3, 0.1, 0.03, 0]) == 3
    assert choose_rings([1, 0.3, 0.1, 0.03]) == 3  # no sharp drop: keep all states


def test_nl5_data_choose_five_rings_from_a_seven_ring_fit():
    # acceptance 3 (SPEC §3.3: the paper fitted n = 7 and found the drop after state 6, n = 5)
    rc = select_rings(load_paper_bench(), 7)
    assert rc.rings == 5
    assert rc.hsv.size == 8


def test_table_b9_from_tables_5_and_b8_within_rounding():
    # acceptance 4: SPEC §5 Table B.9 (m 1.73 kg, c 1.92 N s/m, k 4.47e3 N/m, phi 2.51 N/A)
    # from Table 5 and Table B.8 (delta m = -0.645 kg). Tolerance: the range the formulas give
    # when every input moves by up to half a unit of its last printed digit, widened by half a
    # unit of the output's last printed digit.
    base, loaded = PAPER_TABLES["NL"], PAPER_ADDED_MASS["parameters"]
    half = {"zeta": (5e-6, 5e-6), "omega0": (0.05, 0.05), "phi": (0.005, 0.005)}
    got = physical_from_two_fits(base, loaded, PAPER_ADDED_MASS["delta_m"])
    corners = []
    for signs in itertools.product((-1, 1), repeat=6):
        b = dict(base)
        ld = dict(loaded)
        for s, (key, rec) in zip(signs, [(k, b) for k in half] + [(k, ld) for k in half], strict=True):
            rec[key] = rec[key] + s * half[key][0]
        corners.append(physical_from_two_fits(b, ld, PAPER_ADDED_MASS["delta_m"]))
    out_half = {"m": 0.005, "c": 0.005, "k": 5.0, "phi_raw": 0.005}
    for key, ref in PAPER_PHYSICAL.items():
        lo = min(c[key] for c in corners) - out_half[key]
        hi = max(c[key] for c in corners) + out_half[key]
        assert lo <= ref <= hi, (key, got[key], lo, hi)
        assert lo <= got[key] <= hi


def test_joint_fit_recovers_physical_parameters():
    model = build_model("UD")
    p = dict(PAPER_TABLES["UD"])
    m, c, k, phi = 1.73, 1.92, 4470.0, 2.51

    def mech(M):
        return {"zeta": c / (2 * math.sqrt(M * k)), "omega0": math.sqrt(k / M), "phi": phi / math.sqrt(M)}

    omega = np.geomspace(10, 1e5, 600)
    base = simulate(model, {**p, **mech(m)}, omega, noise=0.002, seed=1)
    loaded = simulate(model, {**p, **mech(m - 0.645)}, omega, noise=0.002, seed=2)
    r = fit_added_mass(base, loaded, -0.645, model)
    for key, truth in {"m": m, "c": c, "k": k, "phi_raw": phi}.items():
        assert abs(r.values[key] - truth) < 4 * r.stderr[key], key
    rec = r.to_json_dict()
    assert rec["method"] == "joint" and set(rec["two_fit"]) >= {"m", "c", "k", "phi_raw"}


def test_inconsistent_pair_is_refused():
    # the resonance must fall when mass is added
    with pytest.raises(Exception, match="non-positive mass"):
        physical_from_two_fits({"zeta": 0.01, "omega0": 50, "phi": 2}, {"zeta": 0.01, "omega0": 60, "phi": 2},
                               0.1)


@pytest.mark.skipif(not REAL.exists(), reason="../shared/realdata not present")
def test_real_added_mass_pair_is_plausible():
    # Dayton LS10-44 with +0.100 kg (../shared/realdata/README.md), fitted up to 1 kHz
    band = (2 * math.pi * 10, 2 * math.pi * 1e3)
    b = read_measurement(REAL / "dayton_LS10-44_freeair_run2.txt", freq_unit="hz").select(*band)
    ld = read_measurement(REAL / "dayton_LS10-44_added100g_run2.txt", freq_unit="hz").select(*band)
    r = fit_added_mass(b, ld, 0.1, build_model("UD"))
    # a 10" subwoofer: moving mass of order 0.1 kg, Bl of order 10-30 T m (sanity, not a datasheet)
    assert 0.05 < r.values["m"] < 0.3 and 5 < r.values["phi_raw"] < 40
    assert abs(r.values["m"] - r.two_fit["m"]) < 5 * r.stderr["m"]
