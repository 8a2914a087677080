"""File readers and writers: formats, units, the malformed-file corpus, real recordings."""

import math
from pathlib import Path

import numpy as np
import pytest

from bayes_emt import DataFormatError, build_model, simulate
from bayes_emt.cli import main
from bayes_emt.datasets import PAPER_BENCH_NOISE, PAPER_BENCH_SEED, load_paper_bench
from bayes_emt.io import read_measurement, write_measurement
from bayes_emt.reference import PAPER_TABLES

HERE = Path(__file__).parent
MALFORMED = HERE / "malformed"
REAL = HERE.parent.parent / "shared" / "realdata"

# file -> a distinctive part of its one-line message (with the line number where one applies)
CORPUS = {
    "empty.zma": "empty file",
    "binary.csv": "binary file",
    "header_only.csv": "no data lines",
    "one_column.zma": "one_column.zma:1: expected 3 columns, found 1",
    "ragged.zma": "ragged.zma:2: expected 3 columns, found 2",
    "text_cell.zma": "text_cell.zma:2: not a number: 'abc'",
    "nan_value.zma": "nan_value.zma:2: non-finite value 'nan'",
    "inf_value.zma": "inf_value.zma:2: non-finite value 'inf'",
    "negative_freq.zma": "negative_freq.zma:2: non-positive frequency -20",
    "zero_freq.zma": "zero_freq.zma:1: non-positive frequency 0",
    "duplicate_freq.zma": "duplicate_freq.zma:3: duplicate frequency 20 (also on line 2)",
    "zero_magnitude.zma": "zero_magnitude.zma:2: non-positive magnitude 0",
    "two_points.zma": "only 2 data points (need at least 3)",
    "unknown_columns.csv": "cannot tell what column 'foo' holds",
    "mixed_quantities.csv": "mentions both impedance and admittance",
    "no_units.csv": "pass --freq-unit hz|rad/s",
    "no_header.csv": "no header line",
    "extra_column.csv": "unexpected fourth column 'Extra'",
    "truncated_line.csv": "truncated_line.csv:3: expected 3 columns, found 2",
    "no_frequency_column.csv": "first column 'Level' is not a frequency column",
    "bad_option.s1p": "bad_option.s1p:1: unknown Touchstone option 'qq'",
    "h_params.s1p": "H-parameters are not supported",
    "two_port.s2p": "2-port Touchstone file",
    "s_equals_one.s1p": "s_equals_one.s1p:3: value maps to an infinite or zero impedance",
    "zero_complex.csv": "zero_complex.csv:2: zero impedance/admittance",
}


def test_corpus_is_complete():
    files = {p.name for p in MALFORMED.iterdir()}
    assert files == set(CORPUS) and len(files) >= 20


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_malformed_file_gives_its_specific_message(name):
    with pytest.raises(DataFormatError) as exc:
        read_measurement(MALFORMED / name)
    msg = str(exc.value)
    assert CORPUS[name] in msg and "\n" not in msg


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_malformed_file_cli_exit_2_one_line(name, capsys):
    assert main(["info", str(MALFORMED / name)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bayes-emt: error:") and "Traceback" not in err[0]
    assert CORPUS[name] in err[0]


def test_missing_file(capsys):
    assert main(["info", "no/such/file.zma"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_option_contradicting_header(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("Frequency (Hz),|Z| (ohm),Phase (deg)\n10,5,3\n20,5,3\n30,5,3\n")
    with pytest.raises(DataFormatError, match="header says the frequency unit is 'hz'"):
        read_measurement(p, freq_unit="rad/s")


def test_unsorted_is_sorted_with_a_notice(tmp_path):
    p = tmp_path / "u.zma"
    p.write_text("30 5 3\n10 5 3\n20 5 3\n")
    with pytest.warns(UserWarning, match="sorted"):
        m = read_measurement(p)
    assert np.all(np.diff(m.omega) > 0)


@pytest.mark.parametrize("header, row, kw, expect", [
    ("Frequency (Hz),|Z| (ohm),Phase (deg)", "{f},8,45", {}, 8 * np.exp(1j * np.pi / 4)),
    ("Freq\tZ_abs\tZ_rad", f"{{f}}\t8\t{math.pi / 4}", {"freq_unit": "hz"}, 8 * np.exp(1j * np.pi / 4)),
    ("f_Hz,Re(Z),Im(Z)", "{f},3,4", {}, 3 + 4j),
    ("omega_rad_s,Y_real_S,Y_imag_S", "{w},0.12,-0.16", {}, 1 / (0.12 - 0.16j)),
    ("Frequency [Hz];|Y| [S];Phase [deg]", "{f};0.2;-90", {}, 1 / (0.2 * np.exp(-1j * np.pi / 2))),
])
def test_header_variants(tmp_path, header, row, kw, expect):
    p = tmp_path / "x.csv"
    rows = [row.format(f=f, w=2 * math.pi * f) for f in (100, 200, 300)]
    p.write_text("\n".join([header, *rows]) + "\n")
    m = read_measurement(p, **kw)
    assert m.omega[0] == pytest.approx(2 * math.pi * 100)
    assert m.Z[0] == pytest.approx(expect, rel=1e-12)


def test_touchstone_s_z_y(tmp_path):
    z = 6 + 8j
    s = (z - 50) / (z + 50)
    rest = "2000 0.2 53.13\n3000 0.2 53.13\n"
    cases = {
        "s.s1p": f"! comment\n# kHz S RI R 50\n1 {s.real} {s.imag}\n2 0.1 0.1\n3 0.1 0.1\n",
        "z.s1p": f"# Hz Z MA R 50\n1000 {abs(z) / 50} {math.degrees(np.angle(z))}\n" + rest,
        "y.s1p": f"# Hz Y RI R 50\n1000 {(50 / z).real} {(50 / z).imag}\n" + rest,
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        m = read_measurement(tmp_path / name)
        assert m.Z[0] == pytest.approx(z, rel=1e-9), name
        assert m.f_hz[0] == pytest.approx(1000.0)


def test_write_read_round_trip(tmp_path):
    meas = simulate(build_model("UD"), PAPER_TABLES["UD"], np.geomspace(10, 1e5, 50), noise=0.01, seed=4)
    write_measurement(meas, tmp_path / "m.csv")
    back = read_measurement(tmp_path / "m.csv")
    np.testing.assert_array_equal(back.omega, meas.omega)
    np.testing.assert_array_equal(back.Y, meas.Y)  # repr floats: exact
    write_measurement(meas, tmp_path / "m.zma")
    back = read_measurement(tmp_path / "m.zma")
    np.testing.assert_allclose(back.Y, meas.Y, rtol=1e-8)  # 10 significant digits
    with pytest.raises(DataFormatError, match="cannot write"):
        write_measurement(meas, tmp_path / "m.xlsx")


def test_bundled_dataset_is_what_its_readme_says():
    # data/README.md: Table 5, NL n=5, 2000 points over 1e1..1e5 rad/s, 0.2 % noise, seed 20261122
    meas = load_paper_bench()
    assert meas.n_points == 2000
    assert meas.omega[0] == pytest.approx(10.0) and meas.omega[-1] == pytest.approx(1e5)
    again = simulate(build_model("NL"), PAPER_TABLES["NL"], meas.omega, noise=PAPER_BENCH_NOISE,
                     seed=PAPER_BENCH_SEED)
    np.testing.assert_array_equal(again.Y, meas.Y)


REAL_FILES = {
    # file: (options, points, first frequency [Hz])  -- ../shared/realdata/README.md
    "dayton_LS10-44.zma": ({}, 344, 1.029),
    "dayton_LS10-44_freeair_run2.txt": ({"freq_unit": "hz"}, 9999, 1.0),
    "dayton_LS10-44_added100g_run2.txt": ({"freq_unit": "hz"}, 9999, 1.0),
    "seas_E0018_freeair.zma": ({}, 386, 10.0),
    "koan_mid_sealed.zma": ({}, 241, 19.958),
    "koan_tweeter.zma": ({}, 161, 199.95),
}


@pytest.mark.skipif(not REAL.exists(), reason="../shared/realdata not present")
@pytest.mark.parametrize("name", sorted(REAL_FILES))
def test_real_recordings_read(name):
    kw, n, f0 = REAL_FILES[name]
    m = read_measurement(REAL / name, **kw)
    assert m.n_points == n
    assert m.f_hz[0] == pytest.approx(f0, rel=1e-3)
    assert np.all(np.abs(m.Z) > 1.0) and np.all(np.abs(m.Z) < 400.0)  # loudspeaker impedances, ohm


@pytest.mark.skipif(not REAL.exists(), reason="../shared/realdata not present")
def test_radian_phase_file_needs_frequency_unit():
    with pytest.raises(DataFormatError, match="pass --freq-unit"):
        read_measurement(REAL / "dayton_LS10-44_freeair_run2.txt")
