"""The batched machinery of the robust shunt: thresholds, peaks and per-draw optima for many draws
at once, checked against the single-draw reference implementations; risk measures, intervals and
the mixture of models."""

import math

import numpy as np
import pytest
from scipy import optimize

from bayes_emt import build_model
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.shunt import Plant, design_rc_shunt, instability_threshold, rc_impedance
from bayes_emt.shunt.batch.design import design_draws
from bayes_emt.shunt.batch.peaks import rc_peaks_batch
from bayes_emt.shunt.batch.plant import BatchPlant, SampledShunt, terminal_impedance
from bayes_emt.shunt.draws import mixture_weights, sample_mixture, split_halves
from bayes_emt.shunt.implementation import sampled_loop_max_pole
from bayes_emt.shunt.risk import clopper_pearson, cvar, quantiles, risk_value, spearman, summary


def scattered(name, n, rel, seed=0):
    """``n`` parameter vectors scattered around the paper's table (independent relative spread)."""
    m = build_model(name)
    th = m.vector(PAPER_TABLES[name])
    rng = np.random.default_rng(seed)
    return m, th * (1 + rel * rng.standard_normal((n, th.size)))


# ---- thresholds -------------------------------------------------------------------------------
@pytest.mark.parametrize("name,cs", [("NL", 0.0812), ("UD", 0.135), ("II", 0.281)])
def test_thresholds_match_instability_threshold(name, cs):
    # the batched threshold solves the same crossing condition as stability.instability_threshold
    # (exact, Brent-refined) by a local cubic on a cached grid: agreement within 1e-9 ohm
    m, th = scattered(name, 6, 3e-3)
    bp = BatchPlant(m, th)
    for c in (0.4 * cs, cs, 2.5 * cs):
        ref = np.array([instability_threshold(m, t, c) for t in th])
        np.testing.assert_allclose(bp.threshold(c), ref, rtol=0, atol=1e-9)
    # per-draw capacitances and a subset of draws
    cs_each = cs * np.linspace(0.8, 1.2, 3)
    ref = np.array([instability_threshold(m, th[i], c) for i, c in zip([1, 3, 5], cs_each, strict=True)])
    np.testing.assert_allclose(bp.threshold(cs_each, idx=[1, 3, 5]), ref, rtol=0, atol=1e-9)


def test_margin_is_how_far_r0_may_drop():
    # R0 enters the terminal impedance additively: lowering R0 by the margin puts the loop on its
    # threshold (SPEC §4; module docstring of batch_plant)
    m, th = scattered("NL", 3, 2e-3)
    bp = BatchPlant(m, th)
    Rs, Cs = -2.40, 0.0812
    margin = bp.margin(Rs, Cs)
    i0 = m.params.index("R0")
    for t, mg in zip(th, margin, strict=True):
        shifted = t.copy()
        shifted[i0] -= mg
        assert instability_threshold(m, shifted, Cs) == pytest.approx(Rs, abs=1e-9)


def test_terminal_impedance_is_the_models_series_impedance():
    m, th = scattered("UD", 2, 1e-3)
    s = 1j * np.array([10.0, 50.0, 300.0])
    np.testing.assert_array_equal(terminal_impedance(m, s, th), m.impedance_s(s, th))


@pytest.mark.parametrize("delay,fs", [(0, 5000.0), (1, 5000.0), (1, 1000.0)])
def test_sampled_threshold_against_the_exact_sampled_data_loop(delay, fs):
    # the frequency-domain threshold of a sampled-data shunt keeps the loop's fundamental only
    # (aliasing neglected): it must carry at least 90 % of the shift from the ideal threshold
    # that the exact sampled-data loop (ZOH plant, Tustin controller, delay) shows
    m = build_model("NL")
    th = m.vector(PAPER_TABLES["NL"])
    Cs = 0.0812
    ss = SampledShunt(fs=fs, delay_samples=delay)
    cr = BatchPlant(m, th[None], sampled=ss).crossings(Cs, Rs=-2.40)
    ideal = BatchPlant(m, th[None]).threshold(Cs)[0]

    def f(rs):
        return sampled_loop_max_pole(m, th, rs, Cs, fs=fs, delay_samples=delay) - 1.0

    exact = optimize.brentq(f, cr.threshold[0] - 0.01, cr.threshold[0] + 0.01, xtol=1e-12)
    assert exact > ideal  # sampling and delay cost stability margin
    assert abs(cr.threshold[0] - exact) < 0.1 * (exact - ideal)
    # with a delay the loop is unstable again at large positive Rs (an upper threshold)
    assert np.isfinite(cr.upper[0]) == (delay > 0)
    if delay:
        assert f(cr.upper[0] + 0.5) > 0 > f(-2.40)


# ---- peaks ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["NL", "UD", "I"])
def test_batched_peaks_match_plant_peak(name):
    # heights within 1e-8 relative of Plant.peak (Brent-refined on the exact model), for designs
    # with two peaks, one merged peak, and one close to the stability boundary
    m, th = scattered(name, 5, 3e-3)
    d = design_rc_shunt(m, m.vector(PAPER_TABLES[name]))
    bp = BatchPlant(m, th)
    for rs, cs in ((d.Rs, d.Cs), (d.Rs + 0.2, d.Cs * 1.3), (d.Rs - 0.9 * d.stability_margin, d.Cs)):
        pb = rc_peaks_batch(bp, rs, cs)
        ref = [Plant(m, t).peak(lambda s, rs=rs, cs=cs: rc_impedance(s, rs, cs)).value for t in th]
        np.testing.assert_allclose(pb.hinf, ref, rtol=1e-8)
        assert not pb.exact.any()


LS10_44 = {"zeta": 0.10341809777195743, "omega0": 213.7593843475715, "phi": 58.54399567993609,
           "R0": 8.561617766689015, "Lg": 0.0015970058167539365, "alpha": 0.005093133126425686,
           "beta": 0.2901108557472927}  # the LS10-44 woofer's UD posterior median (test_shunt_batch_terms)


@pytest.mark.parametrize("rs,cs", [(6.417, 1.87), (-5.0, 1.87), (0.0, 0.5), (-8.41418, 1.86969)])
def test_batched_peaks_below_the_band_match_plant_peak(rs, cs):
    # a loudspeaker's shunts that flatten the resonance (the response falls from the band's low
    # edge ω0/40, or peaks below it): the batch searches below the band as Plant.local_peaks does,
    # for all draws at once (it was one scalar search per draw: 250 of 260 s of shunt --posterior
    # on the LS10-44 posterior). Heights within 1e-8 relative, no draw handed to Plant.
    m = build_model("UD")
    rng = np.random.default_rng(1)
    th = m.vector(LS10_44) * (1 + 3e-3 * rng.standard_normal((6, m.ndim)))
    bp = BatchPlant(m, th)
    pb = rc_peaks_batch(bp, rs, cs, gradients=True)
    ref = [Plant(m, t).peak(lambda s: rc_impedance(s, rs, cs)).value for t in th]
    np.testing.assert_allclose(pb.hinf, ref, rtol=1e-8)
    assert not pb.exact.any()
    # the gradient of the largest peak against a central difference of Plant's peak in Rs
    h = 1e-5
    for i in (0, 3):
        k = int(np.nanargmax(pb.value[i]))
        p = Plant(m, th[i])
        up, dn = (math.log(p.peak(lambda s, r=r: rc_impedance(s, r, cs)).value) for r in (rs + h, rs - h))
        assert pb.grad[i, k, 0] == pytest.approx((up - dn) / (2 * h), rel=1e-4, abs=1e-7)


def test_peak_gradients_match_finite_differences():
    # envelope-theorem gradients d ln h/d(Rs, ln Cs) against central differences of Plant's
    # refined peaks (step 1e-6): agreement 1e-5 relative
    m, th = scattered("NL", 2, 2e-3)
    bp = BatchPlant(m, th)
    rs, cs = -2.44, 0.075
    pb = rc_peaks_batch(bp, rs, cs, gradients=True)
    h = 1e-6
    for i, t in enumerate(th):
        p = Plant(m, t)
        for k in range(2):
            w = pb.omega[i, k]

            def lnh(r, c, w=w, p=p):
                return math.log(max(q.value for q in p.local_peaks(lambda s: rc_impedance(s, r, c))
                                    if abs(q.omega / w - 1) < 0.02))

            g_r = (lnh(rs + h, cs) - lnh(rs - h, cs)) / (2 * h)
            g_u = (lnh(rs, cs * math.exp(h)) - lnh(rs, cs * math.exp(-h))) / (2 * h)
            np.testing.assert_allclose(pb.grad[i, k], [g_r, g_u], rtol=1e-5, atol=1e-8)


# ---- per-draw optima --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["NL", "UD"])
def test_batched_optima_match_design_rc_shunt(name):
    # the batched Newton on the equal-peak conditions against design_rc_shunt draw by draw:
    # Rs within 1e-6 ohm, Cs within 1e-6 relative, attenuation within 1e-6 dB
    m, th = scattered(name, 3, 5e-3, seed=2)
    nominal = m.vector(PAPER_TABLES[name])
    d0 = design_rc_shunt(m, nominal)
    opt = design_draws(BatchPlant(m, th), (d0.Rs, d0.Cs), R0_start=nominal[m.params.index("R0")])
    assert not opt.fallback.any()
    for i, t in enumerate(th):
        ref = design_rc_shunt(m, t)
        assert opt.Rs[i] == pytest.approx(ref.Rs, abs=1e-6)
        assert opt.Cs[i] == pytest.approx(ref.Cs, rel=1e-6)
        assert opt.attenuation_db[i] == pytest.approx(ref.attenuation_db, abs=1e-6)
        assert opt.margin[i] == pytest.approx(ref.stability_margin, abs=1e-8)


# ---- risk, intervals, correlations ------------------------------------------------------------
def test_cvar_and_risk_measures():
    a = np.arange(1.0, 11.0)  # 1..10
    assert cvar(a, 0.9) == pytest.approx(10.0)
    assert cvar(a, 0.8) == pytest.approx(9.5)
    assert cvar(a, 0.75) == pytest.approx((10 + 9 + 0.5 * 8) / 2.5)  # a fractional last atom
    assert cvar(a, 0.0) == pytest.approx(a.mean())
    assert risk_value(a, "mean") == pytest.approx(5.5)
    assert risk_value(a, "worst") == 10.0
    with pytest.raises(ValueError, match="unknown risk"):
        risk_value(a, "median")


def test_quantiles_keep_infinity():
    a = np.r_[np.arange(99.0), np.inf]
    q = quantiles(a, [0.5, 0.999])
    assert q[0] == pytest.approx(49.5) and q[1] == np.inf
    assert summary(np.r_[1.0, 2.0, np.inf])["q95"] == np.inf


def test_clopper_pearson_reference_values():
    # closed forms: k = 0 -> upper = 1 − (α/2)^(1/n); k = n -> lower = (α/2)^(1/n)
    lo, hi = clopper_pearson(0, 500, 0.95)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 500), rel=1e-10)
    lo, hi = clopper_pearson(20, 20, 0.95)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 20), rel=1e-10)
    # Clopper & Pearson (1934)-type textbook value: 5 of 50, 95 %: 0.0333 .. 0.2181
    lo, hi = clopper_pearson(5, 50)
    assert (lo, hi) == (pytest.approx(0.0333, abs=5e-5), pytest.approx(0.2181, abs=5e-5))


def test_spearman_is_rank_based():
    rng = np.random.default_rng(0)
    x = rng.normal(size=200)
    X = np.column_stack([x, -np.exp(x), np.ones(200), rng.normal(size=200)])
    rho = spearman(X, x**3)
    assert rho[0] == pytest.approx(1.0) and rho[1] == pytest.approx(-1.0)
    assert np.isnan(rho[2]) and abs(rho[3]) < 0.2


# ---- mixture of models ------------------------------------------------------------------------
def test_mixture_weights_from_log_evidences():
    w, note = mixture_weights([0.0, -math.log(3.0)])
    np.testing.assert_allclose(w, [0.75, 0.25])
    assert "log evidence" in note
    w, note = mixture_weights([None, None])
    np.testing.assert_allclose(w, [0.5, 0.5])
    assert "equally" in note
    with pytest.raises(ValueError, match="every posterior"):
        mixture_weights([1.0, None])
    w, _ = mixture_weights([1000.0, 0.0])  # no overflow
    assert w[1] == 0.0


def test_sample_mixture_counts_and_halves():
    m1, t1 = scattered("NL", 80, 1e-3)
    m2, t2 = scattered("UD", 30, 1e-3)
    groups, warns = sample_mixture([(m1, t1, "a"), (m2, t2, "b")], np.array([0.7, 0.3]), 101, seed=4)
    assert [g.n for g in groups] == [71, 30] and not warns  # largest remainder: 70.7 -> 71, 30.3 -> 30
    assert len({tuple(r) for r in groups[0].thetas}) == 71  # without replacement
    groups, warns = sample_mixture([(m1, t1, "a"), (m2, t2, "b")], np.array([0.5, 0.5]), 100, seed=4)
    assert len(warns) == 1 and warns[0].startswith("b: 50 draws asked of 30")
    halves = split_halves(groups, seed=1)
    for g, (d, h) in zip(groups, halves, strict=True):
        assert np.intersect1d(d, h).size == 0 and d.size + h.size == g.n and abs(d.size - h.size) <= 1
    again = split_halves(groups, seed=1)
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(halves, again, strict=True))


# ---- the Q of the shunted resonance -------------------------------------------------------------
def test_resonance_q_is_smalls_qts_and_the_series_resistor_rule():
    # a resistive coil (model I with L0 = 1e-12 H): with a zero-impedance source Q is Small's (1972)
    # Qts = 1/(1/Qms + 1/Qes), Qes = w0 R0/phi^2 (mass-normalised: phi^2 = (Bl)^2/m); a series
    # resistor Rs gives Qes' = Qes (R0 + Rs)/R0; open terminals give Qms = 1/(2 zeta). Tolerance 1e-9
    # relative (the resonance refined by Newton steps on Re D; measured 7e-12, on any grid size).
    from bayes_emt.shunt.qfactor import resonance_q

    m = build_model("I")
    t = dict(PAPER_TABLES["I"], L0=1e-12)
    th = m.vector(t)[None]
    qms, qes = 1 / (2 * t["zeta"]), t["omega0"] * t["R0"] / t["phi"] ** 2
    q, fr = resonance_q(m, th)
    assert q[0] == pytest.approx(1 / (1 / qms + 1 / qes), rel=1e-9)
    assert fr[0] == pytest.approx(t["omega0"] / (2 * math.pi), rel=1e-9)
    for rs in (1.0, -0.5 * t["R0"]):
        q, _ = resonance_q(m, th, (rs, 1e9))
        assert q[0] == pytest.approx(1 / (1 / qms + 1 / (qes * (t["R0"] + rs) / t["R0"])), rel=1e-9)
    assert resonance_q(m, th, open_terminals=True)[0][0] == pytest.approx(qms, rel=1e-9)



def test_threshold_with_a_capacitance_across_the_terminals_is_zero():
    # with a winding capacitance the terminal impedance decays like 1/s: in the ideal loop any
    # negative Rs is unstable (a pole from infinity), so the threshold is Rs = 0 as in
    # instability_threshold; the batch said a negative threshold and called such shunts stable
    from catalogue_cases import CASES

    base, extra = CASES["winding_capacitance"]
    m = build_model(f"{base}+winding_capacitance")
    th = m.vector({**PAPER_TABLES[base], **extra})
    th = th * (1 + 1e-3 * np.random.default_rng(2).standard_normal((3, th.size)))
    bp = BatchPlant(m, th)
    for c in (0.05, 0.0812):
        ref = np.array([instability_threshold(m, t, c) for t in th])
        np.testing.assert_allclose(bp.threshold(c), ref, rtol=0, atol=1e-9)
        assert np.all(ref >= 0.0)
    # a sampled-data shunt has no gain at infinity: no pole from there
    assert np.all(BatchPlant(m, th, sampled=SampledShunt()).threshold(0.0812, Rs=-1.0) < 0)
