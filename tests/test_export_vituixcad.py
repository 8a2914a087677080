"""The VituixCAD driver-database line: written from a T/S record (and a semi-inductance fit), it
parses back to the same values under the database's header."""

from __future__ import annotations

import math

import pytest

from bayes_emt.cli import main
from bayes_emt.errors import DataFormatError
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.io.export import VITUIXCAD_HEADER, read_vituixcad, vituixcad_ke, write_vituixcad
from bayes_emt.io.paramfile import write_json
from bayes_emt.models import parse_model_spec
from bayes_emt.thiele_small import thiele_small
from bayes_emt.thiele_small.simulate import simulate_driver

# the header of VituixCAD_Drivers.txt, as luchp/audioshape src/audioshape/vituixcad.py writes it
HEADER = ("Manufacturer\tModel\tType\tStatus\tSize [in]\tRe [ohm]\tfs [Hz]\tQms\tQes\tQts\tRms [Ns/m]\t"
          "Mms [g]\tCms [mm/N]\tVas [l]\tSd [cm2]\tBL [Tm]\tPmax [W]\tXmax [mm]\tBeta\tZ1k [ohm]\t"
          "Z10k [ohm]\tLe [mH]\tLeb [mH]\tKe [sH]\tRss [ohm]\tUSPL [dB]\tBL\u00b2/Re\tRevision\tUpdated")


@pytest.fixture(scope="module")
def driver():
    sim = simulate_driver("I+semi_inductance", seed=8, n_points=400)
    ts = thiele_small(sim.free, "I+semi_inductance", loaded=list(sim.loaded), sd=sim.sd, fast=True,
                      models_for_spread=[])
    fit = fit_admittance(sim.free, parse_model_spec("I+semi_inductance"))
    return sim, ts, fit


def test_header_is_vituixcads():
    assert "\t".join(VITUIXCAD_HEADER) == HEADER


def test_line_parses_back_to_the_same_values(tmp_path, driver):
    sim, ts, fit = driver
    coil = {k: float(fit.theta[fit.model.names.index(k)]) for k in ("K_semi", "n_semi")}
    path = write_vituixcad(tmp_path / "VituixCAD_Drivers.txt", ts, manufacturer="Invented", model="W6",
                           coil=coil)
    assert path.read_text(encoding="utf-8").splitlines()[0] == HEADER
    (row,) = read_vituixcad(path)
    assert row["Manufacturer"] == "Invented" and row["Model"] == "W6"
    # every T/S value in the column's unit, to the 10 significant digits written
    expect = {"Re [ohm]": ts["Re"], "fs [Hz]": ts["fs"], "Qms": ts["Qms"], "Qes": ts["Qes"],
              "Qts": ts["Qts"], "Rms [Ns/m]": ts["Rms"], "Mms [g]": ts["Mms"] * 1e3,
              "Cms [mm/N]": ts["Cms"] * 1e3, "Vas [l]": ts["Vas"] * 1e3, "Sd [cm2]": sim.sd * 1e4,
              "BL [Tm]": ts["Bl"], "Le [mH]": ts["Le"] * 1e3,
              "BL\u00b2/Re": ts["Bl"] ** 2 / ts["Re"],
              "Ke [sH]": vituixcad_ke(coil["K_semi"], coil["n_semi"])}
    for col, value in expect.items():
        assert row[col] == pytest.approx(value, rel=1e-9), col
    for empty in ("Leb [mH]", "Rss [ohm]", "Pmax [W]", "Xmax [mm]"):
        assert empty not in row


def test_ke_mapping():
    # n = 1/2: Leach's K s^n is VituixCAD's semi-inductor exactly
    assert vituixcad_ke(0.02, 0.5) == pytest.approx(0.02, rel=1e-15)
    # otherwise equal magnitude at 1 kHz: |Ke sqrt(jw)| = |K (jw)^n| there
    w = 2 * math.pi * 1000.0
    assert vituixcad_ke(0.003, 0.7) * w**0.5 == pytest.approx(0.003 * w**0.7, rel=1e-12)


def test_cli_writes_the_line(tmp_path, driver, capsys):
    sim, ts, fit = driver
    ts.save(tmp_path / "ts.json")
    write_json(tmp_path / "fit.json", fit.to_json_dict())
    out = tmp_path / "vx.txt"
    assert main(["export", str(tmp_path / "ts.json"), "--vituixcad", str(out),
                 "--fit", str(tmp_path / "fit.json"), "--name", "W6"]) == 0
    (row,) = read_vituixcad(out)
    assert row["Model"] == "W6" and row["fs [Hz]"] == pytest.approx(ts["fs"], rel=1e-9) and "Ke [sH]" in row
    # a fit without a semi-inductance has no Ke to give
    ud = fit_admittance(sim.free, parse_model_spec("I"))
    write_json(tmp_path / "i.json", ud.to_json_dict())
    assert main(["export", str(tmp_path / "ts.json"), "--vituixcad", str(tmp_path / "v2.txt"),
                 "--fit", str(tmp_path / "i.json")]) == 2
    assert "has no semi_inductance term" in capsys.readouterr().err


def test_reader_names_the_bad_cell(tmp_path):
    p = tmp_path / "v.txt"
    p.write_text(HEADER + "\nX\tY\t\t\t\tfour\n", encoding="utf-8")
    with pytest.raises(DataFormatError, match=r"v\.txt:2: column 'Re \[ohm\]' is not a number: 'four'"):
        read_vituixcad(p)
    q = tmp_path / "w.txt"
    q.write_text("Brand=x\n")
    with pytest.raises(DataFormatError, match="not a VituixCAD driver database"):
        read_vituixcad(q)
