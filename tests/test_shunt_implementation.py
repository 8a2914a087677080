"""Digital realisation of the shunt (SPEC.md §4, eqs. 55-56, Table 7) and the ``shunt`` command."""

import json
import math

import numpy as np
import pytest
from nl_circuit import nl_inductance_matrix
from scipy import optimize
from scipy.linalg import expm

from bayes_emt import build_model
from bayes_emt.cli import main
from bayes_emt.reference import PAPER_SHUNTS, PAPER_TABLES
from bayes_emt.shunt import evaluate_rc_shunt, instability_threshold
from bayes_emt.shunt.implementation import controller_tf, realise_rc_shunt

TABLE7 = {"R_in": 0.0996, "K_in": 99.23, "K_out": 0.9846}  # SPEC.md §4 Table 7


def paper(name):
    m = build_model(name)
    return m, m.vector(PAPER_TABLES[name])


def test_controller_equation_56():
    # SPEC.md §4 eq. 56: K(s) = (Rs − R_in + 1/(Cs s)) / (R_in K_in K_out)
    Rs, Cs = PAPER_SHUNTS["NL"]["Rs"], PAPER_SHUNTS["NL"]["Cs"]
    b, a = controller_tf(Rs, Cs, *TABLE7.values())
    s = 1j * 50.0
    g = TABLE7["R_in"] * TABLE7["K_in"] * TABLE7["K_out"]
    assert np.polyval(b, s) / np.polyval(a, s) == pytest.approx((Rs - TABLE7["R_in"] + 1 / (Cs * s)) / g)
    # and (55): R_in + g K(s) is the RC shunt again
    assert TABLE7["R_in"] + g * np.polyval(b, s) / np.polyval(a, s) == pytest.approx(Rs + 1 / (Cs * s))


def test_tustin_coefficients():
    # bilinear s = 2 fs (z − 1)/(z + 1) applied by hand to K(s) = (b0 s + b1)/s
    Rs, Cs, fs = -2.40, 0.0814, 5000.0
    r = realise_rc_shunt(*paper("NL"), Rs, Cs, fs=fs)
    (b0, b1), _ = r.K_s
    bz, az = r.K_z
    assert az == pytest.approx([1.0, -1.0])
    assert bz == pytest.approx([b0 + b1 / (2 * fs), -b0 + b1 / (2 * fs)], rel=1e-12)


def _independent_sampled_loop(Rs, Cs, fs, delay, p=PAPER_TABLES["NL"], n=5, N=480.0):
    """One-step matrix of the sampled-data loop built without the package: the NL plant from its
    inductance matrix with the sense resistor in the coil loop, zero-order hold by the augmented
    matrix exponential, the controller as a difference equation from its Tustin coefficients."""
    R_in, K_in, K_out = TABLE7.values()
    g = R_in * K_in * K_out
    L, Rv = nl_inductance_matrix(p, n, N)
    Li = np.linalg.inv(L)
    k = 2 + 1 + n
    A = np.zeros((k, k))
    A[0, 1], A[1, 0], A[1, 1], A[1, 2] = 1.0, -p["omega0"] ** 2, -2 * p["zeta"] * p["omega0"], p["phi"]
    A[2:, 2:] = -Li @ np.diag(np.r_[p["R0"] + R_in, Rv])
    A[2:, 1] -= Li[:, 0] * p["phi"]
    B = np.zeros(k)
    B[2:] = -Li[:, 0]  # the amplifier voltage opposes the current, as the shunt's
    T = 1 / fs
    M = expm(np.block([[A, B[:, None]], [np.zeros((1, k + 1))]]) * T)
    Ad, Bd = M[:k, :k], M[:k, k]
    # controller y_k = b0 e_k + b1 e_{k-1} + y_{k-1} (Tustin of an integrator + gain), e = sampled i
    b0 = ((Rs - R_in) * Cs * 2 * fs + 1) / (g * Cs * 2 * fs)
    b1 = (-(Rs - R_in) * Cs * 2 * fs + 1) / (g * Cs * 2 * fs)
    # loop state z = (x, e_{k-1}, y_{k-1}[, u queue]); u_k = g y_k (no delay) or g y_{k-1} (one sample)
    m = k + 2 + delay
    F = np.zeros((m, m))
    e_row = np.zeros(m)
    e_row[2] = 1.0  # e_k = i(kT)
    y_row = b0 * e_row
    y_row[k] += b1
    y_row[k + 1] += 1.0
    u_row = g * y_row if delay == 0 else np.eye(m)[k + 2] * g
    F[:k] = Ad @ np.eye(m)[:k] + np.outer(Bd, u_row)
    F[k] = e_row
    F[k + 1] = y_row
    if delay:
        F[k + 2] = y_row
    return F


@pytest.mark.parametrize("delay", [0, 1])
def test_sampled_data_stability_matches_independent_loop(delay):
    nl, th = paper("NL")
    Cs, fs = PAPER_SHUNTS["NL"]["Cs"], 5000.0
    for Rs in (PAPER_SHUNTS["NL"]["Rs"], -2.5, -2.6):
        r = realise_rc_shunt(nl, th, Rs, Cs, fs=fs, delay_samples=delay)
        F = _independent_sampled_loop(Rs, Cs, fs, delay)
        assert r.max_pole_abs == pytest.approx(np.max(np.abs(np.linalg.eigvals(F))), abs=1e-9)
    # the digital loop's threshold in Rs, then the free response of the independent loop either side
    rho = lambda rs: realise_rc_shunt(nl, th, rs, Cs, fs=fs, delay_samples=delay).max_pole_abs - 1  # noqa: E731
    rd = optimize.brentq(rho, -2.65, -2.45, xtol=1e-9)
    for d, grows in ((2e-3, False), (-2e-3, True)):
        F = _independent_sampled_loop(rd + d, Cs, fs, delay)
        x = np.zeros(F.shape[0])
        x[0] = 1.0
        P = np.linalg.matrix_power(F, 100)  # 20 ms per step
        norms = []
        for _ in range(3000):  # 60 s
            x = P @ x
            norms.append(np.linalg.norm(x))
        env = np.maximum.reduceat(np.array(norms), np.arange(0, 3000, 100))  # 2 s windows
        assert (env[-1] / env[len(env) // 2] > 1.1) == grows


def test_realisation_attenuation_and_delay():
    nl, th = paper("NL")
    Rs, Cs = PAPER_SHUNTS["NL"]["Rs"], PAPER_SHUNTS["NL"]["Cs"]
    r0 = realise_rc_shunt(nl, th, Rs, Cs)
    r1 = realise_rc_shunt(nl, th, Rs, Cs, delay_samples=1)
    assert r0.stable and r1.stable
    ideal = evaluate_rc_shunt(nl, th, Rs, Cs).attenuation_db
    assert r0.attenuation_ideal_db == pytest.approx(ideal, abs=1e-9)
    # the hold's half-sample lag already detunes the (large) negative resistance; a delay costs more
    assert r0.attenuation_ideal_db < r0.attenuation_db < r0.attenuation_ideal_db + 1.5
    assert r1.attenuation_db > r0.attenuation_db
    # at a very high rate the digital shunt becomes the ideal one
    fast = realise_rc_shunt(nl, th, Rs, Cs, fs=5e6)
    assert fast.attenuation_db == pytest.approx(r0.attenuation_ideal_db, abs=2e-3)
    # below the continuous threshold the sampled-data loop is unstable too
    rc = instability_threshold(nl, th, Cs)
    bad = realise_rc_shunt(nl, th, rc - 0.01, Cs)
    assert not bad.stable and bad.attenuation_db == math.inf and bad.to_json_dict()["attenuation_db"] is None


def test_realisation_of_a_bessel_model_names_its_plant():
    ud, th = paper("UD")
    r = realise_rc_shunt(ud, th, PAPER_SHUNTS["UD"]["Rs"], PAPER_SHUNTS["UD"]["Cs"])
    assert r.stable and "eddy-current modes" in r.plant_used
    with pytest.raises(ValueError, match="fs must be positive"):
        realise_rc_shunt(ud, th, -2.4, 0.1, fs=0.0)


# ---- the command --------------------------------------------------------------------------------
@pytest.fixture()
def param_files(tmp_path):
    out = {}
    for name in ("NL", "UD"):
        out[name] = tmp_path / f"{name}.json"
        out[name].write_text(json.dumps({"model": name, "parameters": PAPER_TABLES[name]}))
    return out


def test_cli_shunt_json(tmp_path, param_files, capsys):
    import matplotlib

    matplotlib.use("Agg")
    out = tmp_path / "shunt.json"
    rc = main(["shunt", "--model", "UD", "--params", str(param_files["UD"]), "--evaluate-on",
               str(param_files["NL"]), "--implement", "--r-in", "0.0996", "--k-in", "99.23", "--k-out",
               "0.9846", "--fs", "5000", "--delay", "--json", str(out), "--plot", str(tmp_path)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "Rs = -2.43811 ohm" in text and "K(z) = z^-1" in text and "dB" in text
    rec = json.loads(out.read_text())
    for key in ("Rs", "Cs", "attenuation_db", "stable", "stability_margin", "Rs_instability",
                "evaluated_on", "implementation"):
        assert key in rec
    assert rec["Rs"] == pytest.approx(-2.438, abs=5e-4) and rec["stable"] is True
    assert rec["evaluated_on"]["model"] == "NL(5)" and rec["implementation"]["delay_samples"] == 1
    assert rec["implementation"]["K_z"]["a"] == pytest.approx([1.0, -1.0])
    assert (tmp_path / "shunt_UD_attenuation_map.png").stat().st_size > 10_000
    assert (tmp_path / "shunt_UD_receptance.png").stat().st_size > 10_000


def test_cli_shunt_errors(param_files, capsys):
    assert main(["shunt", "--model", "I", "--params", str(param_files["UD"])]) == 2
    assert "holds model UD, but --model I" in capsys.readouterr().err
    assert main(["shunt", "--params", str(param_files["UD"]), "--fs", "4000"]) == 2
    assert "--implement only" in capsys.readouterr().err
    assert main(["shunt", "--params", str(param_files["UD"]) + ".missing"]) == 2
