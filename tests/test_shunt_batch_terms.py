"""The per-draw shunt design (``shunt/batch``) against the one-at-a-time design, for every catalogue
term, a second mechanical mode, and a loudspeaker (issue 32); the stability margin judged against a
posterior's R0 interval (issue 31).

The batched Newton (:func:`~bayes_emt.shunt.batch.design.design_draws`) must return each draw's
H∞-optimal ``(Rs, Cs)`` and attenuation equal to :func:`~bayes_emt.shunt.design_rc_shunt`. Tolerance:
1e-6 relative on Rs and the attenuation (where the optimum sits on the stability boundary, Rs is the
threshold, 0 with a winding capacitance: there 1e-6 of R0); on Cs 1e-6 for an interior optimum and
2e-5 where the optimum lies on the upper bound of Cs (a loudspeaker: Cs of farads), because the
one-at-a-time design's Nelder–Mead stops within its tolerance of the bound (measured 5e-6 in ln Cs on
LS10-44 draws) while the batched design lands on it.

The loudspeaker is the Dayton LS10-44 woofer's UD posterior median (../shared/realdata, free air,
fit by ``sample``): ζ 0.1034, ω0 213.76 rad/s (fs 34.0 Hz), φ 58.54 N/(A kg^0.5), R0 8.5616 Ω,
Lg 1.597 mH, α 5.093e-3, β 0.2901; the catalogue terms take their sizes from tests/test_catalogue.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from catalogue_cases import CASES  # the catalogue's terms on the paper's shaker, as test_catalogue uses them

from bayes_emt import build_model
from bayes_emt.reference import PAPER_TABLES
from bayes_emt.shunt import design_rc_shunt
from bayes_emt.shunt.batch.design import design_draws
from bayes_emt.shunt.batch.peaks import rc_peaks_batch
from bayes_emt.shunt.batch.plant import BatchPlant
from bayes_emt.shunt.draws import DrawGroup
from bayes_emt.shunt.robust import design_robust_shunt
from bayes_emt.shunt.safety import MARGIN_CODE

LS10_44 = {"zeta": 0.10341809777195743, "omega0": 213.7593843475715, "phi": 58.54399567993609,
           "R0": 8.561617766689015, "Lg": 0.0015970058167539365, "alpha": 0.005093133126425686,
           "beta": 0.2901108557472927}


def _draws(model, theta, n, rel=2e-3, seed=0):
    rng = np.random.default_rng(seed)
    return theta * (1 + rel * rng.standard_normal((n, theta.size)))


def _compare(model, thetas, *, max_fallback=0):
    nom = design_rc_shunt(model, np.median(thetas, axis=0))
    bp = BatchPlant(model, thetas)
    opt = design_draws(bp, (nom.Rs, nom.Cs), R0_start=nom.R0)
    assert int(opt.fallback.sum()) <= max_fallback
    assert np.isfinite(opt.Rs).all() and np.isfinite(opt.Cs).all() and np.isfinite(opt.attenuation_db).all()
    for i, th in enumerate(thetas):
        d = design_rc_shunt(model, th)
        on_bound = d.optimum.startswith("Cs at its upper bound")
        if d.optimum == "at the stability boundary":
            # Rs is the threshold (0 with a winding capacitance): relative to R0, its scale
            assert abs(opt.Rs[i] - d.Rs) <= 1e-6 * d.R0, i
        else:
            assert opt.Rs[i] == pytest.approx(d.Rs, rel=1e-6), i
        assert opt.attenuation_db[i] == pytest.approx(d.attenuation_db, rel=1e-6), i
        assert opt.Cs[i] == pytest.approx(d.Cs, rel=2e-5 if on_bound else 1e-6), i
    return opt


@pytest.mark.slow
def test_loudspeaker_draws_settle_in_the_batch():
    """Every LS10-44 draw used to fall back (its low equal peak lay outside the batch's window)."""
    model = build_model("UD")
    _compare(model, _draws(model, model.vector(LS10_44), 4))


def test_more_than_two_peaks_no_index_error():
    """UD+semi_inductance+suspension_creep+second_resonance on a loudspeaker: the model `diagnose`
    named for a real woofer; the peak search's exact path overflowed its two slots (IndexError)."""
    model = build_model("UD+semi_inductance+suspension_creep+second_resonance")
    theta = model.vector({**LS10_44, "K_semi": 0.02, "n_semi": 0.6, "lambda_creep": 0.1,
                          "zeta2": 0.02, "omega2": 2500.0, "phi2": 8.0})
    th = _draws(model, theta, 3)
    bp = BatchPlant(model, th)
    nom = design_rc_shunt(model, theta)
    # known centres for two slots while the exact search finds more peaks: no IndexError
    pb = rc_peaks_batch(bp, np.full(3, nom.Rs), np.full(3, nom.Cs), gradients=True,
                        centres=np.tile([bp.omega0[0] * 0.9, 2500.0], (3, 1)))
    assert pb.value.shape[0] == 3 and np.isfinite(pb.hinf).all()
    opt = design_draws(bp, (nom.Rs, nom.Cs), R0_start=nom.R0)
    assert np.isfinite(opt.Rs).all() and np.isfinite(opt.Cs).all() and np.isfinite(opt.attenuation_db).all()


#: terms where the batch does not yet equal the one-at-a-time design (measured, 20 draws each)
KNOWN: dict = {}
# parallel_driver was an expected failure (9 of 20 draws fell back; a second shaker in parallel across the
# terminals): six draws started where the two peaks' gradients pointed the same way and Newton on their
# cross product, which also vanishes where the peaks merge, stepped onto a single merged peak (the
# second equation is now the angle between g_lo and -g_hi, zero only where they are opposite); one
# walked off to a low-frequency peak; two converged but failed |g_lo x g_hi| < 1e-6 because the quartic
# placed the peaks 3e-8 off in log frequency, where the gradient turns by 4e-7 rad per 1e-8 (a sextic
# through seven points now: the cross product at the solution 1e-11 .. 2e-9)
# winding_capacitance was an expected failure (all 20 draws fell back): with a capacitance across the
# terminals the ideal loop is unstable for any negative Rs (threshold 0 at every Cs) and the optimum is
# a single peak held down by that boundary; the batch now solves it there (Rs on the boundary, ln Cs by
# secant steps on the peak's derivative along it): Cs within 1e-7, the attenuation within 1e-9 relative
# suspension_creep and enclosure_port were expected failures (the batch's attenuation -28.76 dB against
# -10.03 dB, and -24.12 against -11.82 dB): the batch divided by the closed-form open-terminal peak,
# which a stiffness modifier or a motional load changes; BatchPlant now takes it from the exact search


@pytest.mark.slow
@pytest.mark.parametrize("term", [pytest.param(t, marks=pytest.mark.xfail(reason=KNOWN[t], strict=True))
                                  if t in KNOWN else t for t in sorted(CASES)])
def test_every_catalogue_term_batched_equals_one_at_a_time(term):
    base, extra = CASES[term]
    model = build_model(f"{base}+{term}")
    theta = model.vector({**PAPER_TABLES[base], **extra})
    _compare(model, _draws(model, theta, 20), max_fallback=1)


@pytest.mark.slow
def test_two_mode_loudspeaker_batched_equals_one_at_a_time():
    model = build_model("UD+second_resonance")
    theta = model.vector({**LS10_44, "zeta2": 0.02, "omega2": 2500.0, "phi2": 8.0})
    _compare(model, _draws(model, theta, 20), max_fallback=1)


def test_margin_inside_the_posterior_r0_interval_is_flagged():
    """Issue 31: a posterior whose R0 interval is a few % wide (as a likelihood with model
    discrepancy gives) makes the nominal shunt's stability margin fall inside it: warning + field.
    The same shunt on a posterior with a 0.2 % R0 spread is not flagged."""
    model = build_model("NL")
    theta = model.vector(PAPER_TABLES["NL"])
    i = model.params.index("R0")
    flagged = {}
    for rel in (2e-3, 0.05):
        th = _draws(model, theta, 40, rel=1e-3, seed=3)
        th[:, i] = theta[i] * (1 + rel * np.random.default_rng(4).standard_normal(40))
        res = design_robust_shunt([DrawGroup(model, th)], nominal=(model, theta, "truth"), seed=0)
        nom = res.report["nominal"]
        half = float(np.diff(np.quantile(th[:, i], [0.05, 0.95]))[0]) / 2
        assert nom["r0_uncertainty"]["posterior_interval"] == pytest.approx(half, rel=1e-12)
        flagged[rel] = any(w.startswith(f"[{MARGIN_CODE}] nominal") for w in res.warnings)
        assert flagged[rel] == (nom["stability_margin_ohm"] <= half)
        codes = [w["code"] for w in res.report["safety"]["nominal"]["warnings"]]
        assert (MARGIN_CODE in codes) == flagged[rel]
    assert flagged == {2e-3: False, 0.05: True}
    assert math.isfinite(nom["stability_margin_ohm"])
    # the driver's terms: the resonance peak lowered (dB, 90 % interval) and where it went (Hz)
    red, hz = nom["resonance_peak_reduction_db"], nom["resonance_hz"]
    assert 0 < red["q05"] <= red["median"] <= red["q95"]
    f0 = theta[model.params.index("omega0")] / (2 * math.pi)
    assert f0 / 3 < hz["q05"] <= hz["q95"] < 4 * f0


def test_undefined_shunt_problem_is_refused_in_one_line(tmp_path, capsys):
    """An overdamped plant has no resonant peak: `shunt` refuses in one line naming why."""
    import json

    from bayes_emt.cli import main

    path = tmp_path / "over.json"
    path.write_text(json.dumps({"model": "I", "parameters": {**PAPER_TABLES["I"], "zeta": 0.9}}))
    assert main(["shunt", "--params", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "damping ratio 0.9 >= 1/sqrt(2)" in err[0] and "Traceback" not in err[0]
    model = build_model("I")
    over = np.tile(model.vector({**PAPER_TABLES["I"], "zeta": 0.9}), (4, 1))
    with pytest.raises(ValueError, match="nothing for a shunt to damp"):
        design_robust_shunt([DrawGroup(model, over)])


#: posterior median of NL(2)+second_resonance+suspension_creep, the model `diagnose` named for the
#: LS10-44 added-mass run (../shared/realdata, dayton_LS10-44_added100g_run2.txt, fit by `sample`)
LS10_44_MASS = {"zeta": 0.010203445840507249, "omega0": 197.66884479471202, "phi": 42.33039836676376,
                "R0": 7.613927544429413, "Pg": 1.3139268917662793e-08, "P1": 2.6043434901083913e-08,
                "P2": 2.9332021366685692e-08, "R1": 1.1809226356433666e-05, "R2": 6.317155681215467e-05,
                "zeta2": 0.06320049827004881, "omega2": 4924.324985035272, "phi2": 46.221985370783955,
                "lambda_creep": 0.06695593191269548}


@pytest.mark.slow
def test_three_equal_peaks_batched_equals_one_at_a_time():
    model = build_model("NL(2)+second_resonance+suspension_creep")
    theta = model.vector(LS10_44_MASS)
    _compare(model, _draws(model, theta, 20), max_fallback=1)


def test_hull_weights_are_the_three_peak_optimality_condition():
    """The weights with sum 1 that cancel three gradients: all >= 0 exactly when zero lies in the
    triangle of the gradients (the min-max optimality condition at three equal peaks)."""
    from bayes_emt.shunt.batch.design import _hull_weights

    g = np.array([[[1.0, 0.0], [-1.0, 1.0], [-1.0, -1.0]],     # origin inside the triangle
                  [[1.0, 0.2], [2.0, 1.0], [1.5, -1.0]],       # all to the right: outside
                  [[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]])       # collinear: no weights
    lam = _hull_weights(g)
    assert np.allclose(lam[:2].sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(np.einsum("mk,mkj->mj", lam[:2], g[:2]), 0.0, atol=1e-12)
    assert (lam[0] > 0).all() and (lam[1] < 0).any()
    assert np.isnan(lam[2]).all()


#: the Dayton LS10-44 free-air (run 2) NL(3)+second_resonance+winding_capacitance posterior median
#: (../shared/realdata, sampled by ``sample --seed 0``): the optimum lies at the corner of both bounds,
#: Cs at its upper bound and Rs on the stability boundary (threshold 0 with a winding capacitance)
LS10_44_FREE_CP = {"zeta": 0.06830608472, "omega0": 261.9292376, "phi": 56.21900663, "R0": 7.337779238,
                   "Pg": 9.015331293e-09, "P1": 7.010145467e-08, "P2": 3.263422934e-08,
                   "P3": 1.186095239e-08, "R1": 7.094040517e-06, "R2": 5.713872248e-05,
                   "R3": 0.000190755728, "zeta2": 0.02942126621, "omega2": 148.4920819,
                   "phi2": 5.211884427, "Cp": 2.313856534e-08}


def _corner_case(n):
    model = build_model("NL(3)+second_resonance+winding_capacitance")
    theta = model.vector(LS10_44_FREE_CP)
    return model, _draws(model, theta, n)


def test_corner_of_both_bounds_settles_in_the_batch():
    """Half the draws of that posterior fell back to the one-at-a-time design (its whole robust call
    took over 11 CPU minutes): the equal-peak Rs on the Cs bound is negative, so unstable."""
    model, th = _corner_case(20)
    nom = design_rc_shunt(model, np.median(th, axis=0))
    assert nom.optimum == "at the stability boundary"
    bp = BatchPlant(model, th)
    opt = design_draws(bp, (nom.Rs, nom.Cs), R0_start=nom.R0)
    assert not opt.fallback.any()
    corner = np.abs(opt.Rs) <= 1e-6 * bp.R0
    assert corner.any()  # the case exercises the corner
    assert (opt.margin > 0).all()


@pytest.mark.slow
def test_corner_of_both_bounds_batched_equals_one_at_a_time():
    model, th = _corner_case(12)
    _compare(model, th)


#: a draw of the LS10-44 added-mass NL(4)+second_resonance+suspension_creep posterior (../shared/realdata,
#: dayton_LS10-44_added100g_run2.txt, ``sample --seed 0``) that the batched Newton cannot settle: three
#: near-equal peaks, one of them the band's low edge; it falls back from its own optimum as the start
LS10_44_MASS_NL4_DRAW = {"zeta": 0.006281333612, "omega0": 198.0159487, "phi": 42.02202839,
                         "R0": 7.306467426, "Pg": 9.494690193e-13, "P1": 3.652487607e-08,
                         "P2": 2.816786695e-08, "P3": 8.625396416e-09, "P4": 9.484238309e-09,
                         "R1": 1.14168513e-05, "R2": 6.975759715e-05, "R3": 0.0002548467605,
                         "R4": 0.003201464887, "zeta2": 0.03221327389, "omega2": 80.8566383,
                         "phi2": 2.503059082, "lambda_creep": 0.0707095356}


def test_fallback_equals_the_one_at_a_time_design(monkeypatch):
    """A draw the batch hands to the one-at-a-time search (:func:`rc_optimum`, the design without its
    report) gets design_rc_shunt's Rs, Cs, attenuation and margin from the same start, within 1e-6
    relative; the fallback is counted."""
    import bayes_emt.shunt.batch.design as batch_design

    model = build_model("NL(4)+second_resonance+suspension_creep")
    theta = model.vector(LS10_44_MASS_NL4_DRAW)
    nom = design_rc_shunt(model, theta)
    starts = []
    real = batch_design.rc_optimum

    def spy(model_, theta_, *, start):
        starts.append(start)
        return real(model_, theta_, start=start)

    monkeypatch.setattr(batch_design, "rc_optimum", spy)
    th = np.stack([theta, theta])  # a repeated draw (an MCMC chain's rejected step) is solved once
    opt = design_draws(BatchPlant(model, th), (nom.Rs, nom.Cs), R0_start=nom.R0)
    assert opt.fallback.all() and len(starts) == 1  # the case exercises the fallback
    d = design_rc_shunt(model, theta, start=starts[0])
    for i in range(2):
        assert opt.Rs[i] == pytest.approx(d.Rs, rel=1e-6)
        assert opt.Cs[i] == pytest.approx(d.Cs, rel=1e-6)
        assert opt.attenuation_db[i] == pytest.approx(d.attenuation_db, rel=1e-6)
        assert opt.margin[i] == pytest.approx(d.stability_margin, rel=1e-6)
