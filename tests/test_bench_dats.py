"""DATS (Dayton Audio Test System) exports: both header styles, the bench's own fit, and the rows
below the analyser's resolution."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.errors import DataFormatError
from bayes_emt.io import read_measurement
from bayes_emt.io.dats import looks_like_dats
from bayes_emt.io.resolution import resolution_band
from bayes_emt.thiele_small.relations import UNITS

BENCH = Path(__file__).parent / "bench"

# the header lines of the three real DATS exports (../shared/realdata/README.md), in SI:
# fs [Hz], Re [ohm], Qms, Qes, Qts, Le [H]; 0 in the file ("not computed") is absent
REAL_DATS = {
    "grs_12SW-4HE_dats_0h.txt": {"fs": 25.07, "Re": 4.2, "Qms": 3.929, "Qes": 0.5885, "Qts": 0.5118,
                                 "Le": 2.855e-3},
    "scanspeak_18W-4424G00_dats_0h.txt": {"fs": 69.41, "Re": 3.117, "Qms": 5.518, "Qes": 0.6708,
                                          "Qts": 0.598, "Le": 0.2988e-3},
    "sb_SB26STAC-C000-4_dats_freeair.txt": {"fs": 658.1, "Re": 3.223, "Qms": 2.608, "Qes": 1.735,
                                            "Qts": 1.042},
}


def _read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_measurement(path)
    return m, [str(w.message) for w in caught]


@pytest.mark.parametrize("name", sorted(REAL_DATS))
def test_real_dats_reads_with_its_bench_fit(name, realdata):
    path = realdata / name
    m, warned = _read(path)
    assert m.meta["format"] == "dats" and m.meta["quantity"] == "Z" and m.meta["freq_unit"] == "hz"
    fit = m.meta["bench_fit"]
    assert fit["bench"] == "DATS" and fit["source"] == str(path)
    assert fit["values"] == pytest.approx(REAL_DATS[name], rel=1e-12)
    assert set(fit["values"]) <= set(UNITS)
    # K(r), X(r), K(i), X(i) and Z(max) are kept with their units; 0-valued fields are not
    assert {"K(r)", "X(r)", "K(i)", "X(i)", "Zmax"} <= set(fit["extra"])
    assert "Sd" not in fit["extra"] and "Vas" not in fit["values"] and "Bl" not in fit["values"]
    assert all("unit" in v for v in fit["extra"].values())
    # rows 24-100 (1.029-9.243 Hz) repeat in runs; the first row kept is line 101, 9.514 Hz
    assert m.n_points == 344 - 77
    assert m.meta["dropped_band_hz"] == [1.029, 9.243]
    assert m.f_hz[0] == pytest.approx(9.514, rel=1e-12)
    notes = [n for n in m.meta["notices"] if "dropped" in n]
    assert len(notes) == 1 and "1.029-9.243 Hz" in notes[0]
    assert sum("dropped" in w for w in warned) == 1
    assert m.f_hz[-1] == pytest.approx(20642.546, rel=1e-12)


@pytest.mark.parametrize("name, style", [("dats_percent.txt", "%"), ("dats_percent_star_crlf.txt", "%"),
                                         ("dats_star_crlf.txt", "*")])
def test_both_header_styles_and_line_ends(name, style):
    m, _ = _read(BENCH / name)
    assert m.meta["format"] == "dats" and m.meta["header_style"] == style
    v = m.meta["bench_fit"]["values"]
    assert v["fs"] == pytest.approx(43.33) and v["Re"] == 5.6 and v["Qms"] == 6.35
    assert v["Qes"] == 0.514 and v["Qts"] == 0.476
    if name == "dats_percent.txt":  # the older block, each field in SI
        assert v["Bl"] == 6.1 and v["Vas"] == pytest.approx(17.2e-3) and v["Mms"] == pytest.approx(14.2e-3)
        assert v["Cms"] == pytest.approx(0.95e-3) and v["eta0"] == pytest.approx(0.0041) and v["SPL"] == 88.1
        extra = m.meta["bench_fit"]["extra"]
        assert extra["piston_diameter"]["value"] == pytest.approx(0.130)
        assert extra["Sd"] == {"value": pytest.approx(math.pi * 0.065**2), "unit": "m^2",
                               "note": extra["Sd"]["note"]}
        assert extra["L10k"]["value"] == pytest.approx(0.31e-3) and extra["L10k"]["unit"] == "H"
        assert extra["Zmax"]["value"] == 37.2
    if name == "dats_percent_star_crlf.txt":  # 'L(e)= 0' and 'BL= 0': not computed
        assert "Le" not in v and "Bl" not in v
    # the fixture's 8.977 Hz and below repeat one 0.3 Hz FFT bin's value (make_corpus.dats_rows)
    assert m.meta["dropped_band_hz"][1] == pytest.approx(8.977)
    assert np.all(m.f_hz > 9.0)


def test_dats_header_spl_line_is_not_a_sound_pressure_export(realdata):
    # '* SPL= 0 1W/1m' is a field of DATS's fit block, not a column
    m, _ = _read(realdata / "grs_12SW-4HE_dats_0h.txt")
    assert "SPL" not in m.meta["bench_fit"]["values"]


def test_spl_parameter_line_in_a_plain_table_is_not_a_column(tmp_path):
    p = tmp_path / "t.zma"
    p.write_text("* SPL= 88 1W/1m\n* Freq(Hz) |Z|(ohm) Phase(deg)\n10 6 10\n20 8 20\n40 12 30\n")
    assert read_measurement(p).n_points == 3
    q = tmp_path / "s.zma"
    q.write_text("* Freq(Hz) SPL(dB) Phase(deg)\n10 80 10\n20 82 20\n40 85 30\n")
    with pytest.raises(DataFormatError, match="sound-pressure"):
        read_measurement(q)


def test_dats_refuses_options_and_bad_rows(tmp_path):
    with pytest.raises(DataFormatError, match="states its own units"):
        read_measurement(BENCH / "dats_percent.txt", freq_unit="hz")
    text = (BENCH / "dats_percent.txt").read_text().splitlines()
    text[40] = "12.5\t6.0"
    p = tmp_path / "short.txt"
    p.write_text("\n".join(text) + "\n")
    with pytest.raises(DataFormatError, match=r"short\.txt:41: expected 3 columns, found 2"):
        read_measurement(p)


def test_looks_like_dats_needs_the_block_and_the_column_line():
    assert looks_like_dats("* f(s)= 25 Hz\n* R(e)= 4 Ohms\nFreq Impedance Phase\n1 2 3\n")
    assert not looks_like_dats("* f(s)= 25 Hz\nFreq Impedance Phase\n1 2 3\n")  # one field only
    assert not looks_like_dats("Freq Impedance Phase\n1 2 3\n")
    assert not looks_like_dats("* Measurement data measured by REW\n* Freq(Hz) SPL(dB) Phase\n")


def test_resolution_band_rule():
    f = np.arange(1.0, 21.0)
    a = np.r_[[5, 5, 5, 6, 6, 7, 7], np.arange(8.0, 21.0)]
    b = a * 2.0
    assert resolution_band(f, a, b) == 7
    # one coincidence of two equal rows high up is not a band
    a2 = np.arange(1.0, 21.0)
    a2[15] = a2[14]
    assert resolution_band(f, a2, a2) == 0
    # a curve flat over most of its band is kept whole
    assert resolution_band(f, np.ones(20), np.ones(20)) == 0


def test_plain_table_with_repeated_low_rows_names_them_and_keeps_them(tmp_path):
    # a plain table does not say which analyser wrote it: the band is named, with the option to drop it
    rows = [(1.0, 5.0, 3.0), (1.1, 5.0, 3.0), (1.2, 5.0, 3.0), (1.3, 5.2, 4.0), (1.4, 5.2, 4.0)]
    rows += [(2.0 + i, 5.5 + i, 5.0 + i) for i in range(10)]
    p = tmp_path / "r.zma"
    p.write_text("".join(f"{f}\t{m}\t{ph}\n" for f, m, ph in rows))
    with pytest.warns(UserWarning, match=r"rows 1-1.4 Hz repeat .* pass --omega-min 12.57 \(rad/s, 2 Hz\)"):
        m = read_measurement(p)
    assert m.n_points == 15 and m.meta["repeated_band_hz"] == [1.0, 1.4]


def test_info_shows_the_dats_file(capsys):
    assert main(["info", str(BENCH / "dats_star_crlf.txt")]) == 0
    out = capsys.readouterr()
    assert "dats" in out.out and "dropped 76 of 344 rows" in out.out + out.err
