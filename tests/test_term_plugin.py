"""A physics term defined only here, registered at run time, goes through the whole package
(issue 21, acceptance 3): parsed in a spec, fitted, sampled, saved and reloaded, and proposed and
named by discrepancy discovery on data simulated with it; nothing in ``params/`` or ``discovery/``
names it.

The term is a Zobel network, a series ``R_z``–``C_z`` across the terminals (an amplifier's
load-flattening snubber left on the fixture): ``Y ← Y + s C_z/(1 + s R_z C_z)``. It is not in the
catalogue (winding capacitance is a pure ``s Cp``), looks like a capacitor below ``1/(R_z C_z)`` and
like a resistor across the coil above it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pytest

import bayes_emt
from bayes_emt.discovery import candidate_physics, locate_mismatch, rank_candidates
from bayes_emt.discovery.locate import Band
from bayes_emt.discovery.name import log_evidence
from bayes_emt.models import (
    AUGMENTATIONS,
    TERMS,
    Term,
    catalogue_entries,
    param_spec,
    parse_model_spec,
    register_term,
    term_from_dict,
    unregister_term,
)
from bayes_emt.params import LogUniform, ParamSpec
from bayes_emt.reference import PAPER_TABLES


@dataclass(frozen=True)
class Zobel(Term):
    """``Y ← Y + s C_z/(1 + s R_z C_z)``: a series RC across the terminals."""

    id = "zobel_network"
    stage = "parallel"
    augmentation = True
    band = "coil"
    physics = "zobel_network"
    description = "a series RC (Zobel network) across the terminals"
    signature = "|Z| flattens to R_z in parallel with the coil above 1/(R_z C_z)"
    parameters = (
        ParamSpec("C_zob", "F", r"$C_z$", LogUniform(1e-10, 1e-2), "capacitance of a Zobel network"),
        ParamSpec("R_zob", "ohm", r"$R_z$", LogUniform(1e-2, 1e4), "resistance of a Zobel network"),
    )

    def evaluate(self, s, v, other):
        C, R = v[:, 0:1], v[:, 1:2]
        return s * C / (1.0 + s * R * C)

    def jw_rational(self, v):
        C, R = v[:, 0], v[:, 1]
        return np.stack([np.zeros_like(C), C], axis=-1), np.stack([np.ones_like(C), R * C], axis=-1)

    def start(self, ctx):
        """The admittance misfit in the band against ``s C/(1 + s τ)`` over a grid of ``τ = R C``,
        ``C`` by linear least squares; the three best."""
        m = ctx.in_band()
        s, dy = ctx.s[m], (ctx.Y - ctx.Y_base)[m]
        w = ctx.omega[m]
        fits = []
        for tau in np.geomspace(0.3 / w[-1], 3.0 / w[0], 9):
            e = s / (1.0 + tau * s)
            c = float(np.real(np.vdot(e, dy)) / np.real(np.vdot(e, e)))
            if c > 0:
                fits.append((float(np.sum(np.abs(dy - c * e) ** 2)), c, tau))
        fits.sort()
        sC, sR = self.params["C_zob"], self.params["R_zob"]
        return [{"C_zob": sC.clip_inside(c), "R_zob": sR.clip_inside(tau / c)} for _, c, tau in fits[:3]]


TRUTH = {"C_zob": 2e-6, "R_zob": 30.0}
NOISE = 0.002


@pytest.fixture(scope="module")
def zobel():
    register_term(Zobel)
    yield Zobel
    unregister_term(Zobel.id)


@pytest.fixture(scope="module")
def meas(zobel):
    return bayes_emt.simulate(parse_model_spec("II+zobel_network"), {**PAPER_TABLES["II"], **TRUTH},
                              noise=NOISE, seed=3)


@pytest.fixture(scope="module")
def fit(meas):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bayes_emt.fit(meas, "II+zobel_network")


def test_a_registered_term_is_known_everywhere(zobel):
    model = parse_model_spec("II+zobel_network")
    assert model.spec == "II+zobel_network" and model.names[-2:] == ("C_zob", "R_zob")
    assert "zobel_network" in AUGMENTATIONS and "zobel_network" in list(AUGMENTATIONS)
    assert param_spec("R_zob") == Zobel.parameters[1]
    assert term_from_dict(model.terms[-1].to_dict()) == model.terms[-1]
    entry = next(e for e in catalogue_entries() if e["id"] == "zobel_network")
    assert entry["band"] == "coil" and [p["name"] for p in entry["parameters"]] == ["C_zob", "R_zob"]
    # a coil-band term is a candidate where the coil dominates (above 3 omega_r), not below it
    high = Band(2e3, 1e5, 0, 10, ("real",), 50.0, 20.0, 1e4)
    low = Band(10.0, 60.0, 0, 10, ("real",), 50.0, 20.0, 30.0)
    base = parse_model_spec("II")
    assert "zobel_network" in candidate_physics(high, base, 50.8)
    assert "zobel_network" not in candidate_physics(low, base, 50.8)
    assert "zobel_network" not in candidate_physics(high, model, 50.8)  # already in the model


def test_registration_checks_the_term(zobel):
    # every problem named in one line: a term the package cannot use is refused before it is used
    @dataclass(frozen=True)
    class NoBand(Zobel):
        id = "zobel_without_band"
        band = ""

    @dataclass(frozen=True)
    class Clash(Zobel):
        id = "winding_capacitance"

    @dataclass(frozen=True)
    class OtherPrior(Zobel):
        id = "zobel_other_prior"
        parameters = (ParamSpec("Cp", "F", r"$C_p$", LogUniform(1e-12, 1e-6), "another prior for Cp"),
                      Zobel.parameters[1])

    @dataclass(frozen=True)
    class NoStart(Term):
        id = "zobel_without_start"
        stage = "parallel"
        augmentation = True
        band = "coil"
        physics = description = signature = "x"
        parameters = Zobel.parameters

        def evaluate(self, s, v, other):
            return s * v[:, 0:1]

    for cls, words in [(NoBand, "band class"), (Clash, "is taken"), (OtherPrior, "declared differently"),
                       (NoStart, "does not define start"), (object, "not a subclass")]:
        with pytest.raises(ValueError, match=words):
            register_term(cls)
        assert getattr(cls, "id", None) not in TERMS or TERMS[cls.id] is not cls
    with pytest.raises(ValueError, match="cannot be unregistered"):
        unregister_term("winding_capacitance")
    assert register_term(Zobel) is Zobel  # registering it again is a no-op


def test_a_registered_term_is_fitted_from_the_data(meas, fit):
    # 0.2 % noise on 2000 points: the least-squares estimates lie within 4 standard errors of the
    # truth (a Gaussian's 4-sigma; the fit's standard errors are checked in test_fitting.py) and
    # the residual is at the noise floor (rms relative residual sqrt(2) * 0.2 %, within 5 %)
    assert fit.model.spec == "II+zobel_network"
    for name, value in TRUTH.items():
        assert abs(fit.parameters[name] - value) < 4 * fit.stderr[name], name
    assert fit.rms_rel_residual / (NOISE * math.sqrt(2)) == pytest.approx(1.0, abs=0.05)


def test_a_registered_term_is_sampled_saved_and_reloaded(meas, fit, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a 300-step chain does not converge: not the point here
        post = bayes_emt.sample(meas, fit.model, fit=fit, seed=5, max_steps=300)
    draws = post.draws
    assert draws.shape[-1] == len(post.names) and np.all(np.isfinite(draws))
    path = post.save(tmp_path / "zobel.nc")
    back = bayes_emt.read_posterior(path)
    assert back.model == post.model and back.model.spec == "II+zobel_network"
    assert back.model.params == post.model.params  # priors included
    np.testing.assert_array_equal(back.draws, draws)
    # without the term registered the file cannot be read, and says why in one line
    unregister_term(Zobel.id)
    try:
        with pytest.raises(ValueError, match="unknown physics term 'zobel_network'.*register_term"):
            bayes_emt.read_posterior(path)
    finally:
        register_term(Zobel)
    # the walkers stay where the data put the Zobel network (its posterior is a few standard
    # errors wide; 300 steps from the fit's ball cannot wander off without a sampler bug)
    i = list(post.names).index("R_zob")
    assert abs(np.median(draws[..., i]) - fit.parameters["R_zob"]) < 5 * fit.stderr["R_zob"]


def test_discovery_proposes_and_accepts_a_registered_term(meas, zobel):
    # the base model II leaves the network out: the located band reaches into the coil's range,
    # the candidates include the registered term, and its fit is accepted by evidence
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = bayes_emt.fit(meas, "II")
        loc = locate_mismatch(meas, base.model, base.theta, seed=0)
        assert loc.bands, "the data simulated with the network must show a mismatch against II"
        band = loc.bands[0]
        assert "zobel_network" in candidate_physics(band, base.model, 50.8)
        ranked = rank_candidates(meas, base, log_evidence(meas, base), band, loc.sigma_rel, ["zobel_network"])
    assert ranked and ranked[0].physics == "zobel_network" and ranked[0].accepted


@pytest.mark.slow
def test_diagnose_names_a_registered_term(meas, zobel):
    # end to end, every candidate of the catalogue competing: the registered term is named
    from bayes_emt.discovery import diagnose

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = diagnose(meas, parse_model_spec("II"), seed=0)
    assert [f.physics for f in d.findings][:1] == ["zobel_network"], d.details()["tried"]
    assert d.final_model.startswith("II+zobel_network")
