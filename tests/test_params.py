"""The parameter-spec mechanism: transforms, log-Jacobians, prior densities, unit-cube maps."""

import numpy as np
import pytest
from scipy import integrate

from bayes_emt import build_model
from bayes_emt.params import LogNormal, LogUniform, Normal, ParamSet, ParamSpec, Uniform, prior_from_dict

PRIORS = [LogUniform(1e-3, 1e2), Uniform(-2.0, 5.0), Normal(1.0, 0.5), LogNormal(2.0, 0.7)]


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: type(p).__name__)
def test_sampling_space_density_integrates_to_one(prior):
    spec = ParamSpec("x", "1", "x", prior)
    lo, hi = spec.bounds_z()
    lo = max(lo, -40.0)
    hi = min(hi, 40.0)
    total, _ = integrate.quad(lambda z: np.exp(spec.log_prior_z(z)), lo, hi, limit=400)
    assert total == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: type(p).__name__)
def test_prior_transform_is_the_inverse_cdf(prior):
    # the unit-cube map pushes U(0,1) onto the prior: check the median and quartiles numerically
    spec = ParamSpec("x", "1", "x", prior)
    for q in (0.25, 0.5, 0.75):
        xq = float(prior.ppf(q))
        zq = spec.to_z(xq)
        lo = max(spec.bounds_z()[0], -40.0)
        mass, _ = integrate.quad(lambda z: np.exp(spec.log_prior_z(z)), lo, zq, limit=400)
        assert mass == pytest.approx(q, abs=1e-6)


def test_paramset_vectorised_round_trips_and_support():
    ps = build_model("UD").params
    rng = np.random.default_rng(0)
    x = ps.sample_prior(rng, 100)
    assert x.shape == (100, 7)
    np.testing.assert_allclose(ps.from_z(ps.to_z(x)), x, rtol=1e-12)
    assert np.all(np.isfinite(ps.log_prior_z(ps.to_z(x))))
    assert ps.log_prior_z(np.full(7, 1e3)) == -np.inf
    lo, hi = ps.bounds_z()
    assert np.all(lo < hi)
    # log-uniform in x is uniform in z = log x: the z-density is constant inside the support
    z = ps.to_z(x)
    assert np.ptp(ps.log_prior_z(z)) < 1e-12


def test_log_jacobian_matches_change_of_variables():
    ps = ParamSet([ParamSpec("a", "1", "a", LogNormal(3.0, 1.0)), ParamSpec("b", "1", "b", Uniform(0, 1))])
    z = np.array([0.4, 0.3])
    expected = ps.log_prior(ps.from_z(z)) + z[0]  # dx/dz = x for the log transform
    assert ps.log_prior_z(z) == pytest.approx(expected)


def test_prior_from_dict_errors_name_the_place():
    with pytest.raises(ValueError, match="priors.toml: R0: unknown prior dist"):
        prior_from_dict({"dist": "cauchy"}, where="priors.toml: R0")
    with pytest.raises(ValueError, match="bad fields"):
        prior_from_dict({"dist": "uniform", "low": 1}, where="x")
    with pytest.raises(ValueError, match="0 < lower"):
        LogUniform(0.0, 1.0)


def test_same_name_same_prior_across_models():
    # shared parameters must carry identical priors in every model (evidences stay comparable)
    shared = ("zeta", "omega0", "phi", "R0")
    specs = {n: build_model(m).params[n] for m in ("I", "NL") for n in shared}
    for m in ("II", "III", "UD", "UL"):
        for n in shared:
            assert build_model(m).params[n] == specs[n]


def test_documented_prior_table_is_the_catalogue():
    # the "Default priors" table of docs/physics.md is documentation users rely on: it must state the priors
    # the code uses (every "name(s) | unit | log-uniform LO .. HI" cell triple of the table)
    import re
    from pathlib import Path

    from bayes_emt.added_mass.fit import PHYSICAL_PARAMS
    from bayes_emt.inference.likelihood import NOISE_PARAMS, NU_SPEC
    from bayes_emt.models import param_spec

    text = (Path(__file__).resolve().parents[1] / "docs" / "physics.md").read_text(encoding="utf-8")
    table = text.split("## Default priors", 1)[1].split("\n## ", 1)[0]
    noise = {s.name: s for s in (*NOISE_PARAMS, *PHYSICAL_PARAMS)} | {"nu": NU_SPEC}
    seen = set()
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        for names, _unit, prior in zip(cells[0::3], cells[1::3], cells[2::3], strict=False):
            m = re.match(r"log-uniform ([0-9.e+-]+) \.\. ([0-9.e+-]+)", prior)
            if not m or "/" in names:
                continue
            for name in (n.strip() for n in names.split(",")):
                spec = noise[name] if name in noise else param_spec(name.replace("j", "1"))
                d = spec.prior.to_dict()
                assert d["dist"] == "loguniform", name
                assert (d["lower"], d["upper"]) == (float(m.group(1)), float(m.group(2))), name
                seen.add(name)
    assert seen == {"zeta", "omega0", "phi", "R0", "L0", "Rmu", "alpha", "beta", "Lg", "Pg", "Pj", "Rj",
                    "phi_raw", "sigma_rel", "sigma_abs", "nu"}


def test_coil_resistance_is_not_a_ring():
    # regression: "R0" matched the ring pattern R<j> and got ring 0's prior (1e-12..100 ohm,
    # "eddy-current resistance of core ring 0"), capping the coil's DC resistance at 100 ohm
    from bayes_emt import build_model
    from bayes_emt.models import param_spec

    for name in ("I", "II", "III", "UD", "NL", "UL"):
        spec = build_model(name).params["R0"]
        assert spec.description == "coil DC resistance" and spec.unit == "ohm"
        assert spec.prior.to_dict() == {"dist": "loguniform", "lower": 1e-3, "upper": 1e4}
    assert param_spec("R1").description == "eddy-current resistance of core ring 1"
    assert param_spec("P10").description == "permeance of core ring 10"
    with pytest.raises(KeyError):
        param_spec("P0")


def test_clip_inside_is_one_rule_in_both_spaces():
    # one margin (CLIP_MARGIN of the sampling-space width) for every "move a start inside the prior"
    from bayes_emt.params import CLIP_MARGIN, clip_inside

    ps = ParamSet([ParamSpec("a", "1", "a", LogUniform(1e-3, 1e3)),
                   ParamSpec("b", "1", "b", Uniform(-1.0, 1.0)), ParamSpec("c", "1", "c", Normal(0.0, 1.0))])
    lo, hi = ps.bounds_z()
    z = np.array([[-100.0, -5.0, -1e9], [100.0, 5.0, 1e9], [0.1, 0.2, 0.3]])
    out = ps.clip_inside(z)
    np.testing.assert_array_equal(out[2], z[2])  # inside: unchanged
    np.testing.assert_array_equal(out[:2, 2], z[:2, 2])  # an unbounded prior: nothing to clip
    width = hi[:2] - lo[:2]
    np.testing.assert_allclose(out[0, :2], lo[:2] + CLIP_MARGIN * width, rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[1, :2], hi[:2] - CLIP_MARGIN * width, rtol=0, atol=1e-15)
    assert np.all(np.isfinite(ps.log_prior_z(out)))
    np.testing.assert_array_equal(clip_inside(z, lo, hi), out)
    # value space: the same rule through the transform, a float for a scalar
    a = ps["a"].clip_inside(1e9)
    assert isinstance(a, float) and a < 1e3
    assert np.log(a) == pytest.approx(hi[0] - CLIP_MARGIN * width[0], abs=1e-12)
    assert ps["b"].clip_inside(-3.0) == pytest.approx(-1.0 + 2.0 * CLIP_MARGIN, abs=1e-15)
    assert ps["a"].clip_inside(2.0) == 2.0
