"""The ten bench mistakes a person makes with units and setups: each gives a one-line refusal
(exit 2) or a warning naming the option, and the unit that was meant is accepted when written.

The driver is :func:`~bayes_emt.thiele_small.simulate.simulate_driver`'s 6.5" woofer (Mms 14.9 g,
fs 42 Hz, Bl 7 T m, Sd 133 cm²); ``--fast`` intervals keep each case to about a second."""

from __future__ import annotations

import math

import pytest

from bayes_emt.cli import main
from bayes_emt.io import write_measurement
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.plausibility import ImplausibleInput
from bayes_emt.thiele_small.simulate import simulate_driver
from bayes_emt.units import UnitError, parse_quantity

FAST = ["--fast", "--spread-models", "none", "--quiet"]


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    d = tmp_path_factory.mktemp("driver")
    sim = simulate_driver("I+semi_inductance", deltas=(0.010,), box_volume=0.010, n_points=300, seed=4)
    free = write_measurement(sim.free, d / "free.zma")
    loaded = write_measurement(sim.loaded[0][0], d / "with10g.csv")
    box = write_measurement(sim.box[0], d / "box.csv")
    return sim, str(free), str(loaded), str(box)


def _run(argv, capsys):
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


def _refused(rc, err, *needles):
    assert rc == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, (n, err)


# ---- 1-4: a number meant in g, cm2 or L given bare (SI) ----------------------------------------
def test_1_added_mass_in_grams_given_as_kg_is_refused_naming_the_option(driver, capsys):
    sim, free, loaded, _ = driver
    rc, _, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10", *FAST], capsys)
    _refused(rc, err, "--delta-m", "10g")
    rc, out, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10g", *FAST], capsys)
    assert rc == 0, err
    mms = next(ln for ln in out.splitlines() if ln.startswith("Mms"))
    assert abs(float(mms.split()[1]) - 1e3 * sim.truth["Mms"]) < 0.05 * 1e3 * sim.truth["Mms"]


def test_2_known_mms_in_grams_given_as_kg_is_refused(driver, capsys):
    _, free, _, _ = driver
    rc, _, err = _run(["ts", free, "--mms", "14.9", *FAST], capsys)
    _refused(rc, err, "--mms", "14.9g")


def test_3_sd_in_cm2_given_as_m2_is_refused_naming_the_option(driver, capsys):
    _, free, loaded, _ = driver
    rc, _, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10g", "--sd", "133", *FAST], capsys)
    _refused(rc, err, "--sd", "133cm2")
    rc, out, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10g", "--sd", "133cm2", *FAST], capsys)
    assert rc == 0 and "implausible" not in out + err


def test_4_box_volume_in_litres_given_as_m3_is_refused(driver, capsys):
    _, free, _, box = driver
    rc, _, err = _run(["ts", free, "--box", box, "--box-volume", "10", "--sd", "133cm2", *FAST], capsys)
    _refused(rc, err, "--box-volume", "10L")
    rc, out, err = _run(["ts", free, "--box", box, "--box-volume", "10L", "--sd", "133cm2", *FAST], capsys)
    assert rc == 0, err


# ---- 5: an area off by a factor (mm2 read as cm2...) that passes the range check ----------------
def test_5_an_sd_too_large_for_the_cone_warns_or_refuses_by_efficiency(driver, capsys):
    """Sd 0.9 m² on a 15 g cone: Mms/Sd = 0.017 kg/m² and η0 far above 100 % (η0 ∝ Sd²): refused,
    naming --sd; Sd 0.1 m² (Mms/Sd = 0.15 kg/m², η0 ≈ 30 %) is delivered with warnings."""
    _, free, loaded, _ = driver
    rc, _, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10g", "--sd", "0.9", *FAST], capsys)
    _refused(rc, err, "eta0", "--sd")
    rc, out, err = _run(["ts", free, "--loaded", loaded, "--delta-m", "10g", "--sd", "0.1", *FAST], capsys)
    assert rc == 0 and "warning [implausible_eta0]" in out and "(--sd)" in out


# ---- 6: a unit contradicting the file format -----------------------------------------------------
def test_6_freq_unit_rad_s_on_a_zma_is_refused(driver, tmp_path, capsys):
    """A headerless .zma (frequency, |Z|, phase: Hz by the format's definition, as LspCAD and REW
    write it) read with --freq-unit rad/s would put fs at 42/2pi = 6.7 Hz; it is refused."""
    import numpy as np

    sim = driver[0]
    z = sim.free.Z
    rows = np.column_stack([sim.free.f_hz, np.abs(z), np.degrees(np.angle(z))])
    free = tmp_path / "plain.zma"
    free.write_text("".join(f"{a:.8g} {b:.8g} {c:.8g}\n" for a, b, c in rows))
    free = str(free)
    for cmd in (["ts", free, *FAST], ["fit", free, "--model", "I"]):
        rc, _, err = _run([*cmd, "--freq-unit", "rad/s"], capsys)
        _refused(rc, err, "--freq-unit rad/s", "Hz by definition")


# ---- 7: a vented box given as free air ------------------------------------------------------------
def test_7_a_vented_box_curve_given_as_free_air_warns(tmp_path, capsys):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from vented_box import simulate_vented_box

    path = write_measurement(simulate_vented_box(0, noise=0.003, seed=2), tmp_path / "vented.zma")
    rc, out, err = _run(["ts", str(path), *FAST], capsys)
    assert rc == 0 and "warning [vented_curve]" in out, out + err
    free = write_measurement(simulate_vented_box(0, noise=0.003, seed=2, port=False), tmp_path / "free.zma")
    rc, out, err = _run(["ts", str(free), *FAST], capsys)
    assert rc == 0 and "vented_curve" not in out


# ---- 8: a force factor beyond any motor ------------------------------------------------------------
def test_8_a_force_factor_beyond_any_motor_is_refused(driver, capsys):
    _, free, _, _ = driver
    rc, _, err = _run(["ts", free, "--bl", "216", *FAST], capsys)
    _refused(rc, err, "= 216 T m is beyond any motor", "--bl")


# ---- 9-10: a unit of the wrong dimension, an unknown unit --------------------------------------
@pytest.mark.parametrize("argv, needle", [
    (["--delta-m", "8cm2"], "argument --delta-m: '8cm2': cm2 is an area, not a mass"),
    (["--sd", "85in"], "argument --sd: '85in': unknown unit 'in' for an area"),
    (["--box-volume", "20kg"], "argument --box-volume: '20kg': kg is a mass, not a volume"),
    (["--omega-min", "10g"], "argument --omega-min: '10g': g is a mass, not a frequency"),
    (["--exclude-band", "20Hz:1kg"], "--exclude-band '20Hz:1kg': '1kg': kg is a mass"),
    (["--re", "6.1g"], "argument --re: '6.1g': g is a mass, not a resistance"),
])
def test_9_10_a_wrong_or_unknown_unit_is_refused_naming_the_option(driver, capsys, argv, needle):
    _, free, loaded, _ = driver
    extra = ["--loaded", loaded] if argv[0] == "--delta-m" else []
    rc, _, err = _run(["ts", free, *extra, *argv, *FAST], capsys)
    _refused(rc, err, needle)


# ---- and the rest of the table ---------------------------------------------------------------
def test_a_small_added_mass_warns():
    """1 g on a 14.9 g cone moves fs by 3 %: warned, naming --delta-m; 10 g (67 %) is not."""
    sim = simulate_driver("I+semi_inductance", deltas=(0.001,), n_points=300, seed=4)
    r = thiele_small(sim.free, "I+semi_inductance", loaded=list(sim.loaded), fast=True, models_for_spread=[])
    w = next(w for w in r.warnings if w["code"] == "small_added_mass")
    assert "(--delta-m)" in w["message"]


def test_units_in_the_api_and_their_si_values():
    """Reference conversions (exact by definition: 1 ft = 0.3048 m, 1 in = 0.0254 m), rel 1e-12."""
    cases = [("8.017g", "mass", 8.017e-3), ("85cm2", "area", 85e-4), ("85 cm²", "area", 85e-4),
             ("20L", "volume", 0.020), ("1ft3", "volume", 0.3048**3), ("2kHz", "frequency", 2000.0),
             ("6.1ohm", "resistance", 6.1), ("20mohm", "resistance", 0.020), ("0.0330", "area", 0.0330)]
    for text, dim, si in cases:
        assert parse_quantity(text, dim) == pytest.approx(si, rel=1e-12), text
    assert parse_quantity("10Hz", "frequency", bare="rad/s") == pytest.approx(20 * math.pi, rel=1e-12)
    assert parse_quantity("62.83", "frequency", bare="rad/s") == 62.83  # bare: today's rad/s
    with pytest.raises(UnitError, match="not a mass"):
        parse_quantity("3L", "mass")
    for mega, dim in (("1MOhm", "resistance"), ("2Mg", "mass")):  # never read as milli
        with pytest.raises(UnitError, match="reads as mega"):
            parse_quantity(mega, dim)
    assert parse_quantity("20mOhm", "resistance") == pytest.approx(0.020, rel=1e-12)


def test_api_takes_units_and_refuses_the_same_mistakes(driver):
    sim, _, _, _ = driver
    r = thiele_small(sim.free, "I+semi_inductance", loaded=[(sim.loaded[0][0], "10g")], sd="133cm2",
                     fast=True, models_for_spread=[], exclude_band=[("5kHz", "5.2kHz")])
    assert r.inputs["exclude_band_hz"] == [[5000.0, 5200.0]]
    assert r["Mms"] == pytest.approx(sim.truth["Mms"], rel=0.05)
    assert r.inputs["sd_m2"] == pytest.approx(0.0133)
    assert not [w for w in r.warnings if w["code"] == "small_added_mass"]
    with pytest.raises(ImplausibleInput, match=r"sd \(--sd\) = 133 m\^2.*133cm2"):
        thiele_small(sim.free, "I+semi_inductance", loaded=[(sim.loaded[0][0], 0.010)], sd=133, fast=True,
                     models_for_spread=[])


def test_omega_min_with_a_unit_selects_the_same_points(driver, tmp_path, capsys):
    import json

    _, free, _, _ = driver
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["fit", free, "--model", "I", "--omega-min", "20Hz", "--json", str(a), "--quiet"]) == 0
    assert main(["fit", free, "--model", "I", "--omega-min", str(40 * math.pi), "--json", str(b),
                 "--quiet"]) == 0
    ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
    assert ra["n_points"] == rb["n_points"] and ra["parameters"] == rb["parameters"]


def test_the_gram_mistake_is_refused_by_every_command_that_takes_a_mass(driver, capsys):
    _, free, loaded, _ = driver
    for argv in (["added-mass", free, loaded, "--delta-m", "8.017", "--model", "I"],
                 ["sample", free, "--loaded", loaded, "--delta-m", "8.017", "--model", "I"],
                 ["diagnose", free, "--also", f"{loaded}:8.017"]):
        rc, _, err = _run(argv, capsys)
        _refused(rc, err, "8.017g")


def test_a_vented_box_given_as_the_sealed_test_box_warns(driver, tmp_path):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from vented_box import simulate_vented_box

    sim = driver[0]
    ported = simulate_vented_box(0, noise=0.003, seed=2)
    r = thiele_small(sim.free, "I+semi_inductance", box=(ported, "20L"), sd="133cm2", fast=True,
                     models_for_spread=[])
    assert any(w["code"] == "vented_curve" and "sealed box" in w["message"] for w in r.warnings)
    r = thiele_small(sim.free, "I+semi_inductance", box=(sim.box[0], "10L"), sd="133cm2", fast=True,
                     models_for_spread=[])
    assert not any(w["code"] == "vented_curve" for w in r.warnings)
