"""Joint evidence (issue 23): the physics a diagnosis names must explain a second recording of the
same transducer; a term only one recording needs is flagged (bayes_emt.discovery.joint)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.cli.commands.diagnose import also_arg
from bayes_emt.discovery.diagnose import Diagnosis, Finding
from bayes_emt.discovery.joint import check_with, model_without, value_disagreements, with_second_recordings
from bayes_emt.discovery.locate import Band
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io import write_measurement
from bayes_emt.io.simulate import simulate
from bayes_emt.models import parse_model_spec

GRID = 2 * np.pi * np.geomspace(10.0, 2.0e4, 400)
M, DM = 0.02, 0.01  # moving mass and the mass added for the second recording [kg]
# a loudspeaker-like driver (scripts/discovery_benchmark.py): fs 45 Hz, Qms 5, Bl 7 N/A, Mms 20 g
SPEAKER = {"zeta": 0.1, "omega0": 2 * np.pi * 45.0, "phi": 7.0 / math.sqrt(M), "R0": 6.0, "L0": 1.5e-4}
SEMI = {"K_semi": 4e-3, "n_semi": 0.75}
STEP = {"omegas": 2 * np.pi * 2000.0, "delta_s": 0.02, "psi_s": 0.02}


def _loaded(vals):
    """The driver with ``DM`` added: ω0, ζ and φ̄ = Bl/√m scale by √(m/(m + Δm)) (SPEC §3.4)."""
    r = math.sqrt(M / (M + DM))
    return {**vals, "omega0": vals["omega0"] * r, "zeta": vals["zeta"] * r, "phi": vals["phi"] * r}


def _finding(physics, spec):
    band = Band(GRID[0], GRID[-1], 0, GRID.size - 1, ("real", "imag"), 0.0, 0.0, GRID[200])
    return Finding(physics, band, 100.0, 1.0, 1.0, True, "", True, {}, spec, physics + " explains ...")


@pytest.fixture(scope="module")
def pair():
    """A: the semi-inductance coil and a 2 % instrument step at 2 kHz (a session effect); B: the same
    driver with 10 g added, no step. A diagnosis of A that names both."""
    final_model = parse_model_spec("I+semi_inductance+measurement_artifact")
    a = simulate(final_model, {**SPEAKER, **SEMI, **STEP}, GRID, noise=0.003, seed=11, source="A")
    b = simulate(parse_model_spec("I+semi_inductance"), _loaded({**SPEAKER, **SEMI}), GRID, noise=0.003,
                 seed=12, source="B")
    base = fit_admittance(a, parse_model_spec("I"))
    final = fit_admittance(a, final_model, initial={**SPEAKER, **SEMI, **STEP})
    diag = Diagnosis("A", base, final, (_finding("semi_inductance", "I+semi_inductance"),
                                        _finding("measurement_artifact", final_model.label)), ())
    return a, b, diag


def test_a_term_both_recordings_need_passes_one_only_the_first_needs_is_flagged(pair):
    a, b, diag = pair
    rec = check_with(diag, b, DM, meas=a)
    by = {t["physics"]: t for t in rec["terms"]}
    assert rec["method"] == "laplace-joint"
    assert by["semi_inductance"]["needed_by_other"] is True
    assert by["semi_inductance"]["delta_log_z_joint"] >= 5.0
    assert by["semi_inductance"]["verdict"] == "shared, kept"
    # the step: A alone explains the pair better than one step shared by both
    assert by["measurement_artifact"]["needed_by_other"] is False
    assert by["measurement_artifact"]["delta_log_z_joint"] < 5.0
    assert by["measurement_artifact"]["best_alternative"] == "first_only"
    assert rec["flagged"] == ["measurement_artifact"]
    assert by["measurement_artifact"]["model_without"] == "I+semi_inductance"
    # the joint added-mass fit with the final model recovers the moving mass (20 g) within 10 %
    am = rec["added_mass"]
    assert set(am) == {"baseline", "final"}
    assert am["final"]["m_kg"] == pytest.approx(M, rel=0.10)
    # the step forced on B too: the pair does not share the final model (the F-test, a diagnostic
    # beside the verdicts, rejects it)
    assert am["final"]["consistency_p_value"] < 1e-3


MODE2 = {"zeta2": 0.03, "omega2": 2 * np.pi * 400.0, "phi2": 12.0}


@pytest.mark.parametrize("f2_other, agree", [(400.0, True), (1200.0, False)])
def test_a_term_the_other_recording_needs_for_another_feature_is_flagged(f2_other, agree):
    """A: a second mode at 400 Hz; B: the same driver with its second mode at 400 Hz (the same
    physics) or at 1200 Hz (another feature). B alone needs the term either way (Δ log Z_B ≥ 5);
    the joint evidence of both (one set of mode values) keeps it at 400 Hz and not at 1200 Hz,
    where the mode in A alone explains the pair better, and the separate fits' values name both
    frequencies: flagged, with the warning."""
    model = parse_model_spec("I+second_resonance")
    a = simulate(model, {**SPEAKER, **MODE2}, GRID, noise=0.003, seed=31, source="A")
    b = simulate(model, {**SPEAKER, **MODE2, "omega2": 2 * np.pi * f2_other}, GRID, noise=0.003, seed=32,
                 source="B")
    base = fit_admittance(a, parse_model_spec("I"))
    final = fit_admittance(a, model, initial={**SPEAKER, **MODE2})
    diag = Diagnosis("A", base, final, (_finding("second_resonance", model.label),), ())
    out = with_second_recordings(diag, a, [(b, None)])
    rec = out.joint[0]
    (t,) = rec["terms"]
    assert rec["method"] == t["method"] == "laplace-joint"
    assert t["delta_log_evidence_other"] >= 5.0  # B alone needs a second mode either way
    assert t["values_agree"] is agree
    assert (rec["flagged"] == ["second_resonance"]) is not agree
    warned = [w for w in out.warnings if w.startswith("second_resonance:") and "joint evidence" in w]
    table = next(x for x in out.tables() if "joint evidence" in x.title)
    if agree:
        assert t["needed_by_other"] is True and t["delta_log_z_joint"] >= 5.0
        assert t["verdict"] == "shared, kept"
        assert warned == [] and table.rows[0][4] == "yes"
    else:
        assert t["needed_by_other"] is False and t["delta_log_z_joint"] < 5.0
        assert t["best_alternative"] == "first_only" and t["verdict"] == "flagged: other values"
        apart = {x["name"]: x for x in t["values_apart"]}
        assert apart["omega2"]["first"] == pytest.approx(2 * np.pi * 400.0, rel=0.02)
        assert apart["omega2"]["other"] == pytest.approx(2 * np.pi * 1200.0, rel=0.02)
        assert len(warned) == 1 and "do not use it for the same thing" in warned[0]
        assert table.rows[0][4] == "no: flagged"
    assert table.rows[0][2] == t["delta_log_z_joint"]  # the verdict's number, beside B's own


def test_values_disagree_only_beyond_the_factor_and_the_standard_errors():
    """:func:`value_disagreements` on hand-made fits: a factor 3 apart with small errors disagrees; a
    factor 1.5 apart (within the factor 2) or a factor 3 apart with errors as large do not; without
    a covariance nothing is judged."""
    model = parse_model_spec("I+second_resonance")
    vals = {**SPEAKER, **MODE2}
    theta = np.array([vals.get(n, 1.0) for n in model.names])
    i = model.names.index("omega2")

    def fit(w2, sd):
        th = theta.copy()
        th[i] = w2
        cov = np.diag(np.full(model.ndim, 1e-6))
        cov[i, i] = sd**2
        return SimpleNamespace(model=model, z=model.params.to_z(th), cov_z=cov, parameters=model.as_dict(th))

    w = 2 * np.pi * 400.0
    assert [x["name"] for x in value_disagreements(fit(w, 0.01), fit(3 * w, 0.01), ["omega2"])] == ["omega2"]
    assert value_disagreements(fit(w, 0.01), fit(1.5 * w, 0.01), ["omega2"]) == []
    assert value_disagreements(fit(w, 0.5), fit(3 * w, 0.5), ["omega2"]) == []
    assert value_disagreements(fit(w, 0.01), SimpleNamespace(**{**vars(fit(3 * w, 0.01)), "cov_z": None}),
                               ["omega2"]) is None


def test_the_diagnosis_carries_the_joint_record_and_a_warning_per_flagged_term(pair):
    a, b, diag = pair
    out = with_second_recordings(diag, a, [(b, None)])  # the same driver: no added-mass fit
    assert len(out.joint) == 1 and "added_mass" not in out.joint[0]
    flagged = [w for w in out.warnings if "joint evidence" in w]
    assert len(flagged) == 1 and flagged[0].startswith("measurement_artifact:")
    assert "only one recording needs" in flagged[0]
    back = Diagnosis.from_json_dict(out.to_json_dict())
    assert back.joint == out.joint


def test_taking_a_finding_out_removes_its_term_or_restores_the_coil_it_replaced():
    final = parse_model_spec("NL(3)+suspension_creep")
    diag = SimpleNamespace(
        final_fit=SimpleNamespace(model=final), baseline_fit=SimpleNamespace(model=parse_model_spec("UD")),
        findings=(SimpleNamespace(physics="eddy_current", model_spec="NL(3)"),
                  SimpleNamespace(physics="suspension_creep", model_spec="NL(3)+suspension_creep")))
    assert model_without(diag, 0).label == "UD+suspension_creep"
    assert model_without(diag, 1).label == "NL(3)"


def test_also_option_reads_file_and_added_mass():
    assert also_arg("b.txt:0.1") == ("b.txt", 0.1)
    assert also_arg("b.txt") == ("b.txt", None)
    assert also_arg("C:/data/b.txt") == ("C:/data/b.txt", None)
    with pytest.raises(ValueError, match="--also b.txt:0"):
        also_arg("b.txt:0")


def test_diagnose_also_prints_the_joint_check_on_the_command_line(tmp_path, capsys):
    """Two recordings without a hidden effect: nothing to name, the joint added-mass fit of the
    start model is printed with its mass [kg], and the second recording's own diagnosis (not with
    ``--no-search-also``)."""
    a = simulate(parse_model_spec("I"), SPEAKER, GRID, noise=0.003, seed=1)
    b = simulate(parse_model_spec("I"), _loaded(SPEAKER), GRID, noise=0.003, seed=2)
    pa, pb = write_measurement(a, tmp_path / "a.csv"), write_measurement(b, tmp_path / "b.csv")
    main(["diagnose", str(pa), "--model", "I", "--also", f"{pb}:{DM}", "--quiet"])
    out = capsys.readouterr().out
    assert f"joint evidence with {pb}" in out or "joint evidence with b.csv" in out
    line = next(x for x in out.splitlines() if "joint added-mass fit, final" in x)
    m = float(line.split(" m ")[1].split(" kg")[0])
    assert m == pytest.approx(M, rel=0.05)
    # the second recording is diagnosed too, from the same start: nothing to name there either
    assert "its own diagnosis: I -> I (no finding" in out
    main(["diagnose", str(pa), "--model", "I", "--also", f"{pb}:{DM}", "--quiet", "--no-search-also"])
    out = capsys.readouterr().out
    assert "joint added-mass fit, final" in out and "its own diagnosis" not in out


def test_a_missing_second_recording_is_one_line_before_any_diagnosis(tmp_path, capsys):
    a = simulate(parse_model_spec("I"), SPEAKER, GRID, noise=0.003, seed=1)
    pa = write_measurement(a, tmp_path / "a.csv")
    assert main(["diagnose", str(pa), "--also", str(tmp_path / "none.csv") + ":0.1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none.csv" in err[0]


def test_searching_the_second_recording_flags_a_term_only_it_needs():
    """The other way round (:func:`search_other`): A is the semi-inductance driver, B the same driver
    with 10 g added and a 2 % instrument step at 2 kHz (a session effect of B). B's own diagnosis,
    from A's starting model I, names the semi-inductance and the step; the semi-inductance is A's too,
    so only the step is checked on A, where it gains less than 5 nats: flagged as a term only B
    needs, with a warning."""
    a = simulate(parse_model_spec("I+semi_inductance"), {**SPEAKER, **SEMI}, GRID, noise=0.003, seed=21,
                 source="A")
    b = simulate(parse_model_spec("I+semi_inductance+measurement_artifact"),
                 _loaded({**SPEAKER, **SEMI, **STEP}), GRID, noise=0.003, seed=22, source="B")
    base = fit_admittance(a, parse_model_spec("I"))
    final = fit_admittance(a, parse_model_spec("I+semi_inductance"), initial={**SPEAKER, **SEMI})
    diag = Diagnosis("A", base, final, (_finding("semi_inductance", "I+semi_inductance"),), ())
    out = with_second_recordings(diag, a, [(b, DM)], search={"seed": 0, "time_budget": None})
    sr = out.joint[0]["search"]
    assert sr["baseline_model"] == "I"
    assert "semi_inductance" in sr["findings"] and "measurement_artifact" in sr["findings"]
    only = {t["physics"]: t for t in sr["only_other"]}
    assert set(only) == {"measurement_artifact"}
    assert only["measurement_artifact"]["needed_by_first"] is False
    # A's points show no discontinuity where B's step is: refused on A without an evidence (the
    # refusal rank_candidates gives such a step whatever its evidence)
    assert only["measurement_artifact"]["delta_log_evidence_first"] is None
    assert "show no such step" in only["measurement_artifact"]["note"]
    assert any(w.startswith("measurement_artifact:") and "only one recording needs" in w
               for w in out.warnings)
    # A's own finding is needed by B, so nothing of A's is flagged
    assert out.joint[0]["flagged"] == []
    back = Diagnosis.from_json_dict(out.to_json_dict())
    assert back.joint == out.joint
    # the diagnosis's tables (report, text summary) carry the joint record both ways
    table = next(t for t in out.tables() if "joint evidence" in t.title)
    assert {(r[0], r[1], r[4]) for r in table.rows} == {
        ("semi_inductance", "this", "yes"), ("measurement_artifact", "the other only", "no: flagged")}
    assert "I -> " in table.notes[0]
