"""The likelihood's fast path (inference/fastpath.py, inference/noise.py) against the plain formula
evaluated through the model: every model, every noise regime, weights, augmented models (fast where
every term offers a kernel, general otherwise), pickling."""

import math
import pickle

import numpy as np
import pytest

from bayes_emt import build_model, simulate
from bayes_emt.inference.fastpath import JwPlan
from bayes_emt.inference.likelihood import Likelihood
from bayes_emt.inference.noise import SERIES_X
from bayes_emt.measurement import Measurement
from bayes_emt.models import MODEL_NAMES, Term, param_spec
from bayes_emt.params import ParamSet
from bayes_emt.reference import PAPER_TABLES

OMEGA = np.geomspace(10, 1e5, 300)


def _theta0(model):
    return model.vector(PAPER_TABLES["UD" if model.base == "UL" else model.base])


def _reference_total(model, meas, theta):
    """SPEC noise model summed point by point, the admittance from Model.admittance (complex)."""
    k = model.ndim
    w = np.ones(meas.n_points) if meas.weights is None else meas.weights
    out = []
    for row in np.atleast_2d(theta):
        r = model.admittance(meas.omega, row[:k]) - meas.Y
        sig2 = ((row[k] * np.abs(meas.Y)) ** 2 + row[k + 1] ** 2) / w**2
        out.append(np.sum(-np.log(2 * math.pi * sig2) - np.abs(r) ** 2 / (2 * sig2)))
    return np.array(out)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_fast_total_equals_the_formula_in_every_noise_regime(name):
    model = build_model(name)
    th = _theta0(model)
    meas = simulate(model, th, OMEGA, noise=0.002, seed=2)
    lik = Likelihood(model, meas)
    assert lik._plan is not None  # the six models all have the fast path
    rng = np.random.default_rng(0)
    amax = 1 / np.min(np.abs(meas.Y)) ** 2
    amin = 1 / np.max(np.abs(meas.Y)) ** 2
    # sigma_abs / sigma_rel chosen in the small-rho series, the large-rho series, between, and zero
    regimes = [1e-3 * math.sqrt(SERIES_X / amax), 30 * math.sqrt(1 / (SERIES_X * amin)),
               math.sqrt(1 / amin), 0.0]
    rows = []
    for ratio in regimes:
        srel = 0.002 * math.exp(0.3 * rng.standard_normal())
        rows.append(np.r_[th * np.exp(0.01 * rng.standard_normal(th.size)), srel, srel * ratio])
    theta = np.array(rows)
    np.testing.assert_allclose(lik(theta), _reference_total(model, meas, theta), rtol=1e-10)
    np.testing.assert_allclose(lik(theta), lik.pointwise(theta).sum(axis=-1), rtol=1e-10)
    # vectorised over leading axes, and one vector alone
    assert lik(theta.reshape(2, 2, -1)).shape == (2, 2)
    np.testing.assert_allclose(lik(theta[1]), lik(theta)[1], rtol=1e-13)


def test_weights_and_many_walkers_in_chunks():
    model = build_model("UD")
    th = _theta0(model)
    m0 = simulate(model, th, OMEGA, noise=0.002, seed=5)
    meas = Measurement(m0.omega, m0.Y, weights=np.linspace(0.5, 2.0, OMEGA.size))
    lik = Likelihood(model, meas)
    rng = np.random.default_rng(1)
    # 37 walkers: the last chunk of walkers is a ragged one
    theta = np.r_[th, 0.002, 1e-7] * np.exp(0.02 * rng.standard_normal((37, th.size + 2)))
    np.testing.assert_allclose(lik(theta), _reference_total(model, meas, theta), rtol=1e-10)
    e = lik.scaled_squared_residuals(theta[:, : model.ndim])
    r = model.admittance(meas.omega, theta[:, : model.ndim]) - meas.Y
    np.testing.assert_allclose(e, np.abs(r) ** 2 * meas.weights**2 / np.abs(meas.Y) ** 2, rtol=1e-9)


def test_non_finite_and_unphysical_sets_give_minus_inf():
    model = build_model("NL")
    meas = simulate(model, _theta0(model), OMEGA, noise=0.002, seed=1)
    lik = Likelihood(model, meas)
    good = np.r_[_theta0(model), 0.002, 1e-8]
    bad = np.array([good, good, good])
    bad[1, 6] = -1.0  # a negative permeance
    bad[2, -2] = np.nan
    ll = lik(bad)
    assert np.isfinite(ll[0]) and ll[1] == -np.inf and ll[2] == -np.inf


class _NoKernel(Term):
    """A parallel capacitance written as a plain term: no fast kernel (Term's defaults)."""

    id = "test_capacitance_without_kernel"
    stage = "parallel"
    augmentation = True

    @classmethod
    def default_params(cls):
        return ParamSet([param_spec("Cp")])

    def evaluate(self, s, v, other):
        return s * v[:, 0:1]


# the augmentation's values: small enough to keep the base model's character, large enough to matter
_AUG_VALUES = {"winding_capacitance": [2e-9], "lead_impedance": [0.3, 2e-6], "lr2": [2e-3, 40.0],
               "second_resonance": [0.05, 2 * math.pi * 800.0, 3.0], "suspension_creep": [0.05],
               "semi_inductance": [0.01, 0.6]}


def _augmented(spec):
    model = build_model(spec)
    base, *augs = spec.split("+")
    return model, np.r_[_theta0(build_model(base)), *[_AUG_VALUES[a] for a in augs]]


def test_plan_reproduces_the_model_for_every_model():
    rng = np.random.default_rng(4)
    for name in MODEL_NAMES:
        model = build_model(name)
        plan = JwPlan.build(model, OMEGA)
        theta = _theta0(model) * np.exp(0.5 * rng.standard_normal((5, model.ndim)))
        np.testing.assert_allclose(plan.admittance(theta), model.admittance(OMEGA, theta), rtol=1e-10)


@pytest.mark.parametrize("spec, fast", [
    ("NL+winding_capacitance", True), ("I+winding_capacitance+lead_impedance", True),
    ("UD+lr2+second_resonance", True), ("II+second_resonance", True),
    ("UD+winding_capacitance", False),  # a parallel term beside the Bessel kernel
    ("NL+suspension_creep", False), ("III+semi_inductance", False)])
def test_augmented_models_take_the_fast_path_when_every_term_offers_a_kernel(spec, fast):
    model, th = _augmented(spec)
    assert (JwPlan.build(model, OMEGA) is not None) is fast
    meas = simulate(model, th, OMEGA, noise=0.002, seed=3)
    lik = Likelihood(model, meas)
    assert (lik._plan is not None) is fast
    rng = np.random.default_rng(6)
    theta = np.r_[th, 0.002, 1e-8] * np.exp(0.05 * rng.standard_normal((7, th.size + 2)))
    np.testing.assert_allclose(lik(theta), _reference_total(model, meas, theta), rtol=1e-10)
    np.testing.assert_allclose(lik.model_admittance(theta[:, : model.ndim]),
                               model.admittance(OMEGA, theta[:, : model.ndim]), rtol=1e-10)


def test_a_term_without_a_kernel_leaves_the_model_on_its_own_path():
    # a term written with nothing but evaluate (Term's jw_rational/jw_bessel give None): no plan,
    # the same likelihood through Model.admittance
    base = build_model("I")
    aug = base.with_term(_NoKernel.make())
    assert aug.jw_form(np.ones((1, aug.ndim))) is None and JwPlan.build(aug, OMEGA) is None
    meas = simulate(base, _theta0(base), OMEGA, noise=0.002, seed=3)
    lik = Likelihood(aug, meas)
    assert lik._plan is None
    theta = np.r_[_theta0(base), 1e-9, 0.002, 1e-8]
    np.testing.assert_allclose(lik(theta), _reference_total(aug, meas, theta), rtol=1e-12)


def test_plan_pickles_without_its_scratch_buffers():
    plan = JwPlan.build(build_model("UD"), OMEGA)
    th = np.tile(_theta0(build_model("UD")), (3, 1))
    y = plan.admittance(th)
    back = pickle.loads(pickle.dumps(plan))
    np.testing.assert_array_equal(back.admittance(th), y)


def test_box_prior_equals_the_param_set_density():
    model = build_model("NL").with_priors({"R0": {"dist": "lognormal", "median": 2.5, "sigma_log": 0.1},
                                            "omega0": {"dist": "uniform", "lower": 40, "upper": 60}})
    meas = simulate(build_model("NL"), _theta0(build_model("NL")), OMEGA[:50], noise=0.002, seed=1)
    lik = Likelihood(model, meas)
    rng = np.random.default_rng(0)
    z = lik.params.to_z(np.r_[_theta0(model), 0.002, 1e-8]) + 2.0 * rng.standard_normal((200, lik.ndim))
    z[:, 1] = rng.uniform(35, 65, 200)  # omega0 (identity transform) around its uniform support
    x, lp = lik._box_prior(z)
    ref = lik.params.log_prior_z(z)
    assert np.array_equal(np.isfinite(lp), np.isfinite(ref)) and 0 < np.isfinite(ref).sum() < 200
    np.testing.assert_allclose(lp[np.isfinite(ref)], ref[np.isfinite(ref)], rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(x, lik.params.from_z(z))
