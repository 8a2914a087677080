"""The public verbs take what a user holds and refuse what does not fit together (issue 21)."""

import json

import numpy as np
import pytest

import bayes_emt as be


@pytest.fixture(scope="module")
def ud_fit(paper_bench):
    return be.fit(paper_bench, "UD")


def test_a_fit_saved_and_loaded_is_the_same_fit(ud_fit, tmp_path):
    path = ud_fit.save(tmp_path / "fit.json")
    assert json.loads(path.read_text())["kind"] == "fit"
    back = be.load(path)
    assert back.model.label == "UD" and back.n_points == ud_fit.n_points
    np.testing.assert_allclose(back.theta, ud_fit.theta, rtol=1e-12)
    np.testing.assert_allclose(back.cov_z, ud_fit.cov_z, rtol=1e-12)
    assert back.warning_codes == ud_fit.warning_codes
    # what a person reads: a one-line repr, a table with units, the same table as HTML
    assert "\n" not in repr(back) and "UD fit of 2000 points" in repr(back)
    text = back.summary()
    assert "R0" in text and "ohm" in text and "rad/s" in text and "fs" in text and "Hz" in text
    assert "<table>" in back._repr_html_()


def test_verbs_refuse_a_fit_of_another_model(paper_bench, ud_fit):
    with pytest.raises(ValueError, match="the fit is of UD, the model asked for is NL"):
        be.sample(paper_bench, "NL(5)", fit=ud_fit, max_steps=10)
    with pytest.raises(ValueError, match="the fit is of UD, the model given is NL"):
        be.diagnose(paper_bench, "NL(5)", fit=ud_fit)
    with pytest.raises(TypeError, match="give a model spec"):
        be.sample(paper_bench)


def test_compare_and_robust_shunt_refuse_what_cannot_be_weighed(paper_bench):
    with pytest.raises(ValueError, match="each model once"):
        be.compare(paper_bench, ["UD", "UD"])
    with pytest.raises(ValueError, match='weights="evidence" over several posteriors needs their log Z'):
        be.robust_shunt([object(), object()])


def test_load_names_a_file_that_is_no_result(tmp_path):
    p = tmp_path / "x.json"
    p.write_text('{"hello": 1}')
    with pytest.raises(be.DataFormatError, match="x.json: not a saved bayes_emt result"):
        be.load(p)
    p.write_text("{not json")
    with pytest.raises(be.DataFormatError, match=r"x.json:1: not JSON"):
        be.load(p)


def test_a_shunt_design_saved_and_loaded_by_its_kind(ud_fit, tmp_path):
    """A shunt design's file says its kind; ``be.load`` reads it by that kind, and a file without
    one (written before) still by its fields."""
    d = be.design_shunt(ud_fit)
    path = tmp_path / "shunt.json"
    d.save(path)
    rec = json.loads(path.read_text())
    assert rec["kind"] == "shunt_design"
    back = be.load(path)
    assert type(back) is type(d)
    assert back.Rs == pytest.approx(d.Rs, rel=1e-12) and back.Cs == pytest.approx(d.Cs, rel=1e-12)
    assert back.stability_margin_ohm == pytest.approx(d.stability_margin_ohm, rel=1e-12)
    del rec["kind"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(rec))
    assert be.load(old).Rs == pytest.approx(d.Rs, rel=1e-12)
