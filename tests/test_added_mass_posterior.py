"""Joint posterior of an added-mass pair (issue 4: "m, c, k, φ when an added-mass pair is given —
sample both recordings jointly"): likelihood identity, recovery of a known truth, the saved
DataTree, resume, the command line."""

import json
import warnings

import arviz as az
import h5py
import numpy as np
import pytest
from test_added_mass import TRUE, _pair

from bayes_emt import ConvergenceWarning, build_model, read_posterior
from bayes_emt.added_mass.fit import JointModel, fit_added_mass
from bayes_emt.added_mass.posterior import AddedMassLikelihood, AddedMassPosterior, sample_added_mass
from bayes_emt.cli import main
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.inference.sampling import SamplerSettings
from bayes_emt.io import write_measurement
from bayes_emt.reference import PAPER_TABLES

MODEL = build_model("UD")
SHARED = {k: v for k, v in PAPER_TABLES["UD"].items() if k not in ("zeta", "omega0", "phi")}
DM = -0.645


@pytest.fixture(scope="module")
def pair():
    (base, _), (loaded, _) = _pair(MODEL, SHARED, TRUE, DM, np.geomspace(10, 1e5, 200), 0.002, (1, 2))
    return base, loaded


@pytest.fixture(scope="module")
def joint_fit(pair):
    return fit_added_mass(*pair, DM, MODEL)


@pytest.fixture(scope="module")
def short(pair, joint_fit):
    """A budget of 1000 steps (the sampler converges within it here: τ of a few steps). White noise:
    these tests are about the pair's joint posterior, not the noise model (the correlated one adds
    two parameters per run and needs a longer budget)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)  # a miss would fail the fixture, loudly
        return sample_added_mass(*pair, DM, MODEL, fit=joint_fit, seed=4, max_steps=1000, progress=False,
                                 noise="white")


def test_correlated_pair_gives_each_run_its_discrepancy(pair):
    base, loaded = pair
    lik = AddedMassLikelihood(JointModel(MODEL, DM), base, loaded, noise="correlated")
    assert lik.params.names[-8:] == (
        "sigma_rel_base", "sigma_abs_base", "sigma_disc_base", "ell_base",
        "sigma_rel_loaded", "sigma_abs_loaded", "sigma_disc_loaded", "ell_loaded")
    white = AddedMassLikelihood(JointModel(MODEL, DM), base, loaded)
    x = np.array([*TRUE.values(), *SHARED.values()])
    xw = np.r_[x, 0.002, 1e-9, 0.002, 1e-9]
    xc = np.r_[x, 0.002, 1e-9, 0.0, 0.1, 0.002, 1e-9, 0.0, 0.1]
    assert lik(xc[None])[0] == pytest.approx(white(xw[None])[0], rel=1e-12)  # no discrepancy: white


def test_joint_likelihood_is_the_sum_of_the_two_runs(pair):
    base, loaded = pair
    lik = AddedMassLikelihood(JointModel(MODEL, DM), base, loaded)
    assert lik.params.names == ("m", "c", "k", "phi_raw", "R0", "Lg", "alpha", "beta", "sigma_rel_base",
                                "sigma_abs_base", "sigma_rel_loaded", "sigma_abs_loaded")
    x = np.array([[*TRUE.values(), *SHARED.values(), 2e-3, 1e-9, 3e-3, 1e-8],
                  [1.6, 2.0, 4400.0, 2.4, *SHARED.values(), 1e-3, 1e-7, 2e-3, 1e-9]])
    single = Likelihood(MODEL, base), Likelihood(MODEL, loaded)
    expect = np.zeros(2)
    for i, lk in enumerate(single):
        mass = np.array([x[0, 0], x[1, 0]]) + (DM if i else 0.0)
        zeta = x[:, 1] / (2 * np.sqrt(mass * x[:, 2]))
        theta = np.column_stack([zeta, np.sqrt(x[:, 2] / mass), x[:, 3] / np.sqrt(mass), x[:, 4:8],
                                 x[:, 8 + 2 * i : 10 + 2 * i]])
        expect += lk(theta)
    np.testing.assert_allclose(lik(x), expect, rtol=1e-13)
    pb, pl = lik.pointwise(x)
    assert pb.shape == (2, base.n_points) and pl.shape == (2, loaded.n_points)
    post, ll = lik.log_prob_z(lik.params.to_z(x))
    np.testing.assert_allclose(ll, expect, rtol=1e-13)
    np.testing.assert_allclose(post - ll, lik.params.log_prior_z(lik.params.to_z(x)), rtol=1e-12)
    with pytest.raises(ValueError, match="sampled Student-t nu"):
        AddedMassLikelihood(JointModel(MODEL, DM), base, loaded, "student", None)


def test_joint_posterior_recovers_the_physical_truth(short, joint_fit):
    # known truth (Table B.9 physics on the Table 4 coil, 0.2 % noise): each physical parameter
    # inside its central 99 % interval; and sharing both runs' zeta and phi-bar makes c and phi
    # tighter than the paper's two-fit formulas (base run only; their delta-method standard error)
    flat = short.flat()
    for i, (name, truth) in enumerate(TRUE.items()):
        lo, hi = np.quantile(flat[:, i], [0.005, 0.995])
        print(f"{name}: 99 % [{lo:.5g}, {hi:.5g}], truth {truth}")
        assert lo < truth < hi, name
    sd = dict(zip(short.names, flat.std(axis=0), strict=False))
    two = joint_fit.two_fit["stderr"]
    assert sd["c"] < two["c"] and sd["phi_raw"] < two["phi_raw"]
    # posterior sd and the joint fit's standard errors agree (near-Gaussian posterior), within 30 %
    for name in TRUE:
        assert 0.7 < sd[name] / joint_fit.stderr[name] < 1.3, (name, sd[name], joint_fit.stderr[name])
    np.testing.assert_allclose(np.median(flat[:, 8]), 0.002, rtol=0.15)  # sigma_rel_base
    d = short.derived()
    w_loaded = np.sqrt(TRUE["k"] / (TRUE["m"] + DM))
    np.testing.assert_allclose(np.median(d["omega0_loaded"]), w_loaded, rtol=1e-3)
    assert short.converged and "converged at step" in short.to_json_dict()["message"]


def test_joint_posterior_datatree_roundtrip(short, tmp_path):
    path = short.save(tmp_path / "pair.nc")
    dt = az.from_netcdf(path)
    assert dt.attrs["kind"] == "added_mass" and dt.attrs["delta_m_kg"] == DM
    assert dt["posterior"]["m"].attrs["units"] == "kg"
    assert dt["posterior"]["omega0_loaded"].attrs["units"] == "rad/s"
    assert dt["log_likelihood"]["Y_base"].dims[-1] == "omega_base"
    assert dt["log_likelihood"]["Y_loaded"].shape[-1] == short.likelihood.loaded.n_points
    summ = az.summary(dt, var_names=["m", "c", "k", "phi_raw"])
    assert len(summ) == 4
    back = read_posterior(path)
    assert isinstance(back, AddedMassPosterior)
    np.testing.assert_array_equal(back.draws, short.draws)
    assert back.likelihood.params.to_dict() == short.likelihood.params.to_dict()
    np.testing.assert_allclose(back.likelihood(back.flat()[:5]), short.log_lik.reshape(-1)[:5], rtol=1e-12)
    rec = json.loads(json.dumps(short.to_json_dict(), allow_nan=False))
    assert set(rec["physical"]) == {"m", "c", "k", "phi_raw"} and rec["physical"]["k"]["unit"] == "N/m"
    assert rec["derived"]["zeta_loaded"]["unit"] == "1" and rec["delta_m"] == DM


def test_joint_resume_continues_the_same_chain(pair, joint_fit, tmp_path):
    st = SamplerSettings(check_every=100, reseed_every=50)
    kw = {"fit": joint_fit, "seed": 2, "progress": False, "settings": st}
    with pytest.warns(ConvergenceWarning):
        ref = sample_added_mass(*pair, DM, MODEL, max_steps=300, checkpoint=tmp_path / "a.h5", **kw)
    with pytest.warns(ConvergenceWarning):
        sample_added_mass(*pair, DM, MODEL, max_steps=150, checkpoint=tmp_path / "b.h5", **kw)
    with pytest.warns(ConvergenceWarning):
        res = sample_added_mass(*pair, DM, MODEL, max_steps=300, checkpoint=tmp_path / "b.h5", resume=True,
                                **kw)
    np.testing.assert_array_equal(ref.draws, res.draws)
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "b.h5") as b:
        np.testing.assert_array_equal(a["mcmc"]["chain"][:], b["mcmc"]["chain"][:])
    other = (pair[1], pair[0])
    with pytest.raises(ValueError, match="cannot resume: different data"):
        sample_added_mass(*other, DM, MODEL, max_steps=300, checkpoint=tmp_path / "b.h5", resume=True, **kw)


def test_sample_command_with_a_pair(pair, tmp_path, capsys):
    files = []
    for name, meas in zip(("base.csv", "loaded.csv"), pair, strict=True):
        write_measurement(meas, tmp_path / name)
        files.append(str(tmp_path / name))
    assert main(["sample", files[0], "--model", "UD", "--loaded", files[1]]) == 2
    assert "--loaded and --delta-m go together" in capsys.readouterr().err
    pri = tmp_path / "p.toml"
    pri.write_text('[m]\ndist = "lognormal"\nmedian = 1.7\nsigma_log = 0.5\n')
    out = tmp_path / "o.json"
    code = main(["sample", files[0], "--model", "UD", "--loaded", files[1], "--delta-m", str(DM),
                 "--max-steps", "200", "--quiet", "--priors", str(pri), "--json", str(out),
                 "--out", str(tmp_path / "pair.nc")])
    assert code == 1  # 200 steps cannot converge: flagged, exit 1
    text = capsys.readouterr().out
    assert "NOT CONVERGED" in text and "omega0_loaded (derived)" in text
    rec = json.loads(out.read_text())
    assert rec["converged"] is False and rec["physical"]["m"]["unit"] == "kg"
    priors = {d["name"]: d["prior"] for d in json.loads(az.from_netcdf(tmp_path / "pair.nc").attrs["priors"])}
    assert priors["m"]["dist"] == "lognormal"
    pri.write_text('[m]\ndist = "lognormal"\nmedian = -1\nsigma_log = 0.5\n')
    assert main(["sample", files[0], "--model", "UD", "--loaded", files[1], "--delta-m", str(DM),
                 "--priors", str(pri), "--out", str(tmp_path / "x.nc")]) == 2
    assert "p.toml: m:" in capsys.readouterr().err


@pytest.mark.slow
def test_joint_posterior_converges_on_a_simulated_pair(pair, joint_fit):
    # the default stopping rule (50 tau, tau stable to 5 %, ESS >= 1000) within the default budget,
    # and each physical parameter inside its 90 % interval or within 1 sd of it
    post = sample_added_mass(*pair, DM, MODEL, fit=joint_fit, seed=0, progress=False)
    print(post.message, post.n_steps, float(np.max(post.tau)), post.wall_time)
    assert post.converged and np.min(post.ess) >= 1000
    flat = post.flat()
    for i, (name, truth) in enumerate(TRUE.items()):
        q05, q95 = np.quantile(flat[:, i], [0.05, 0.95])
        assert q05 - flat[:, i].std() < truth < q95 + flat[:, i].std(), name
