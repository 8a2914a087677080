"""File readers and writers: formats, units, the malformed-file corpus, real recordings."""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from bayes_emt import DataFormatError, build_model, simulate
from bayes_emt.cli import main
from bayes_emt.io import read_measurement, write_measurement
from bayes_emt.io.datasets import PAPER_BENCH_NOISE, PAPER_BENCH_SEED, load_paper_bench, paper_bench_path
from bayes_emt.reference import PAPER_TABLES

HERE = Path(__file__).parent
MALFORMED = HERE / "malformed"

# file -> a distinctive part of its one-line message (with the line number where one applies)
CORPUS = {
    "ambiguous_unit.csv": "ambiguous_unit.csv:1: unit 'MOHM' in column '|Z| (MOHM)' is ambiguous",
    "bad_option.s1p": "bad_option.s1p:1: unknown Touchstone option 'qq'",
    "binary.csv": "binary.csv:1: binary file (NUL bytes)",
    "comments_only.zma": "no data lines (only a header or comments)",
    "contradictory_freq_units.csv": "contradictory_freq_units.csv:1: column 'Freq (Hz) (rad/s)' states two "
                                    "frequency units (Hz and rad/s)",
    "contradictory_phase_units.csv": "contradictory_phase_units.csv:1: column 'Phase (deg/rad)' states both "
                                     "degrees and radians",
    "db_magnitude.csv": "db_magnitude.csv:1: column '|Z| (dB)' is in dB",
    "degrees_as_radians.csv": "degrees_as_radians.csv:3: phase 45 is beyond 2π, so it is not in radians",
    "duplicate_freq.zma": "duplicate_freq.zma:3: duplicate frequency 20 (also on line 2)",
    "empty.zma": "empty.zma: empty file",
    "extra_column.csv": "extra_column.csv:1: unexpected fourth column 'Extra'",
    "five_columns.csv": "five_columns.csv:1: header has 5 columns",
    "frequency_count.s1p": "frequency_count.s1p:4: [Number of Frequencies] says 5 but there are 3",
    "h_params.s1p": "h_params.s1p:1: H-parameters are two-port parameters",
    "header_only.csv": "no data lines (only a header)",
    "inf_value.zma": "inf_value.zma:2: non-finite value 'inf'",
    "mixed_quantities.csv": "mixed_quantities.csv:1: header mentions both impedance and admittance",
    "nan_value.zma": "nan_value.zma:2: non-finite value 'nan'",
    "negative_freq.zma": "negative_freq.zma:2: non-positive frequency -20",
    "negative_magnitude.s1p": "negative_magnitude.s1p:3: negative magnitude -0.5",
    "no_frequency_column.csv": "no_frequency_column.csv:1: first column 'Level' is not a frequency column",
    "no_header.csv": "no header line, so nothing says what the columns hold",
    "no_option_line.s1p": "no_option_line.s1p:1: data before the option line",
    "no_phase_unit.csv": "no_phase_unit.csv:1: header 'Frequency (Hz),|Z| (ohm),Phase' does not say whether "
                         "the phase is in degrees or radians; pass --phase-unit deg|rad",
    "no_units.csv": "no_units.csv:1: header 'f,mag,phase' does not say whether frequencies are in Hz or "
                    "rad/s; pass --freq-unit hz|rad/s",
    "one_column.zma": "one_column.zma:1: expected 3 columns, found 1",
    "ragged.zma": "ragged.zma:2: expected 3 columns, found 2",
    "s_equals_one.s1p": "s_equals_one.s1p:3: value maps to an infinite or zero impedance",
    "star_comments_no_suffix.txt": "if it is a .zma export, Hz/ohm/deg, name it .zma",
    "text_cell.zma": "text_cell.zma:2: not a number: 'abc'",
    "truncated_line.csv": "truncated_line.csv:3: expected 3 columns, found 2",
    "two_points.zma": "only 2 data points (need at least 3)",
    "two_port.s2p": "2-port Touchstone file",
    "two_ports_keyword.s1p": "two_ports_keyword.s1p:3: [Number of Ports] 2",
    "undecodable.zma": "undecodable.zma:1: binary file (undecodable bytes)",
    "unknown_columns.csv": "unknown_columns.csv:1: cannot tell what column 'Foo' holds",
    "unknown_format.s1p": "unknown_format.s1p:1: unknown Touchstone option 'mag'",
    "unknown_unit.csv": "unknown_unit.csv:1: unknown unit 'furlongs' in column 'Frequency (furlongs)'",
    "zero_complex.csv": "zero_complex.csv:2: zero impedance/admittance",
    "zero_freq.zma": "zero_freq.zma:1: non-positive frequency 0",
    "zero_magnitude.zma": "zero_magnitude.zma:2: non-positive magnitude 0",
    "zero_weight.csv": "zero_weight.csv:3: non-positive weight 0",
    # issue 9: silently wrong numbers
    "thousands_separator.csv": "thousands_separator.csv:3: '1.000' has a '.' although this file's decimal "
                               "mark is ','",
    "thousands_separator_dot.tsv": "thousands_separator_dot.tsv:4: frequency '1.000' reads as 1, below the "
                                   "500 of line 3: is '.' a thousands separator (1.000 = 1000)?",
    "negative_real_part_most.zma": "negative_real_part_most.zma:2: Re Z = -5.511 ohm < 0 (|Z| = 5.6 ohm, "
                                   "phase -169.8 deg) at 4 of 4 points; a passive transducer has Re Z >= 0",
}
# files that read, with a warning naming the file and line (issue 9: they passed without a word)
WARNING_CORPUS = {
    "negative_real_part.zma": "negative_real_part.zma:4: Re Z = -0.2958 ohm < 0 (|Z| = 11.3 ohm, phase 91.5 "
                              "deg) at 2 of 5 points",
    "radians_in_deg_column.csv": "radians_in_deg_column.csv:7: the phase is in degrees as the header says, "
                                 "but its largest magnitude, 0.74, does not exceed π/2",
}
# files that must read as text (issue 9: UTF-16 was called "binary"): name -> points
READS_CORPUS = {"utf16.csv": 4, "utf16_no_bom.zma": 3}


def test_corpus_is_complete():
    files = {p.name for p in MALFORMED.iterdir() if p.is_file()}
    assert files == set(CORPUS) | set(WARNING_CORPUS) | set(READS_CORPUS) and len(files) >= 20


@pytest.mark.parametrize("name", sorted(WARNING_CORPUS))
def test_suspect_file_reads_with_a_warning_naming_file_and_line(name, capsys):
    with pytest.warns(UserWarning) as rec:
        m = read_measurement(MALFORMED / name)
    msgs = [str(w.message) for w in rec]
    assert any(WARNING_CORPUS[name] in t and t.startswith(str(MALFORMED / name)) for t in msgs), msgs
    assert any(WARNING_CORPUS[name] in n for n in m.meta["notices"])
    assert main(["info", str(MALFORMED / name)]) == 0
    err = capsys.readouterr().err
    assert "bayes-emt: warning: " in err and WARNING_CORPUS[name] in err and "Traceback" not in err


@pytest.mark.parametrize("name", sorted(READS_CORPUS))
def test_utf16_text_reads(name):
    m = read_measurement(MALFORMED / name)
    assert m.n_points == READS_CORPUS[name]
    assert m.f_hz[0] == pytest.approx(20) and abs(m.Z[0]) == pytest.approx(5.6)
    assert np.degrees(np.angle(m.Z[0])) == pytest.approx(12.5)


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_malformed_file_gives_its_specific_message(name):
    with pytest.raises(DataFormatError) as exc:
        read_measurement(MALFORMED / name)
    msg = str(exc.value)
    assert CORPUS[name] in msg and "\n" not in msg
    assert msg.startswith(str(MALFORMED / name))


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_malformed_file_cli_exit_2_one_line(name, capsys):
    assert main(["info", str(MALFORMED / name)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bayes-emt: error:") and "Traceback" not in captured.err
    assert CORPUS[name] in err[0]


def test_missing_file_and_folder(capsys, tmp_path):
    assert main(["info", "no/such/file.zma"]) == 2
    assert "no/such/file.zma: no such file" in capsys.readouterr().err
    with pytest.raises(DataFormatError, match="is a folder"):
        read_measurement(tmp_path)


def _table(tmp_path, text, name="x.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_option_contradicting_header_raises(tmp_path):
    p = _table(tmp_path, "Frequency (Hz),|Z| (ohm),Phase (deg)\n10,5,3\n20,5,3\n30,5,3\n")
    with pytest.raises(DataFormatError, match=r"x.csv:1: header .* says the frequency unit is Hz, "
                                              r"but --freq-unit rad/s was given"):
        read_measurement(p, freq_unit="rad/s")
    with pytest.raises(DataFormatError, match="says the phase unit is degrees, but --phase-unit rad"):
        read_measurement(p, phase_unit="rad")
    with pytest.raises(DataFormatError, match="says the quantity is impedance Z, but --quantity Y"):
        read_measurement(p, quantity="Y")
    # an option that agrees with the header is fine; a bad option value is a plain error
    assert read_measurement(p, freq_unit="Hz", quantity="z").n_points == 3
    with pytest.raises(ValueError, match="freq_unit must be one of"):
        read_measurement(p, freq_unit="furlong")


def test_options_fill_what_the_header_does_not_say(tmp_path):
    p = _table(tmp_path, "f,mag,phase\n10,5,30\n20,5,30\n30,5,30\n")
    with pytest.raises(DataFormatError, match="pass --quantity Z|Y; nor whether the phase"):
        read_measurement(p, freq_unit="hz")
    m = read_measurement(p, freq_unit="hz", phase_unit="deg", quantity="Z")
    assert m.Z[0] == pytest.approx(5 * np.exp(1j * np.pi / 6))
    assert m.meta["units_from"] == {"freq_unit": "option", "phase_unit": "option", "quantity": "option"}
    # a headerless table reads as frequency, magnitude, phase once all three are given
    q = _table(tmp_path, "10\t5\t30\n20\t5\t30\n30\t5\t30\n", "h.txt")
    with pytest.raises(DataFormatError, match="pass --phase-unit deg|rad, --quantity Z|Y"):
        read_measurement(q, freq_unit="hz")
    m = read_measurement(q, freq_unit="rad/s", phase_unit="deg", quantity="Y")
    assert m.omega[0] == 10 and m.Y[0] == pytest.approx(5 * np.exp(1j * np.pi / 6))


def test_unsorted_is_sorted_with_a_warning_and_a_notice(tmp_path):
    p = _table(tmp_path, "30 5 3\n10 5 3\n20 5 3\n", "u.zma")
    with pytest.warns(UserWarning, match=r"u.zma:2: frequencies are not in increasing order; sorted"):
        m = read_measurement(p)
    assert np.all(np.diff(m.omega) > 0)
    assert any("sorted" in n for n in m.meta["notices"])


W = 2 * math.pi


@pytest.mark.parametrize("header, row, kw, expect", [
    ("Frequency (Hz),|Z| (ohm),Phase (deg)", "{f},8,45", {}, 8 * np.exp(1j * np.pi / 4)),
    ("Freq\tZ_abs\tZ_rad", f"{{f}}\t8\t{math.pi / 4}", {"freq_unit": "hz"}, 8 * np.exp(1j * np.pi / 4)),
    ("f_Hz,Re(Z),Im(Z)", "{f},3,4", {}, 3 + 4j),
    ("omega_rad_s,Y_real_S,Y_imag_S", "{w},0.12,-0.16", {}, 1 / (0.12 - 0.16j)),
    ("Frequency [Hz];|Y| [S];Phase [deg]", "{f};0.2;-90", {}, 1 / (0.2 * np.exp(-1j * np.pi / 2))),
    ("Frequency (Hz),Phase (°),|Z| (Ω)", "{f},45,8", {}, 8 * np.exp(1j * np.pi / 4)),  # reversed
    ("Freq(Hz) Ohm Deg", "{f} 8 45", {}, 8 * np.exp(1j * np.pi / 4)),
    ("Frequency (kHz),|Z| (kΩ),Phase (deg)", "{k},0.008,45", {}, 8 * np.exp(1j * np.pi / 4)),
    ("ω (rad/s),G (mS),B (mS)", "{w},120,-160", {}, 1 / (0.12 - 0.16j)),
    ("Frequency (Hz),R (ohm),X (ohm)", "{f},3,4", {}, 3 + 4j),
    ("Frequency (Hz);|Z| (ohm);Phase (deg)", "{fc};8,0;45,0", {}, 8 * np.exp(1j * np.pi / 4)),
    ("Freq,Impedance Magnitude,Phase angle", "{f},8,45", {"freq_unit": "hz", "phase_unit": "deg"},
     8 * np.exp(1j * np.pi / 4)),
    ("omega (rad s^-1),Re(Y) (S),Im(Y) (S)", "{w},0.12,-0.16", {}, 1 / (0.12 - 0.16j)),
    ("Frequency/Hz,Re(Z)/Ohm,-Im(Z)/Ohm", "{f},3,-4", {}, 3 + 4j),  # impedance-spectroscopy sign
    ("Freq (Hz)\tZ' (Ω)\t-Z'' (Ω)", "{f}\t3\t-4", {}, 3 + 4j),
])
def test_header_variants(tmp_path, header, row, kw, expect):
    rows = [row.format(f=f, w=W * f, k=f / 1e3, fc=str(f).replace(".", ",")) for f in (100, 200, 300)]
    p = _table(tmp_path, "\n".join([header, *rows]) + "\n")
    m = read_measurement(p, **kw)
    assert m.omega[0] == pytest.approx(W * 100)
    assert m.Z[0] == pytest.approx(expect, rel=1e-12)
    assert m.meta["n_header_lines"] == 1 and m.meta["header"] == header
    assert ("decimal commas read as decimal points" in m.meta["notices"]) == ("{fc}" in row)
    assert ("negated" in " ".join(m.meta["notices"])) == ("-Im" in header or "-Z" in header)


def test_latin1_export_with_degree_sign(tmp_path):
    p = tmp_path / "l.csv"
    p.write_bytes("Frequency (Hz),|Z| (ohm),Phase (°)\n10,5,30\n20,5,30\n30,5,30\n".encode("latin-1"))
    assert read_measurement(p).meta["phase_unit"] == "deg"


def test_zma_convention_is_stated_in_meta(tmp_path):
    p = _table(tmp_path, "* some header\r\n* another\r\n\r\n10\t5\t30\r\n20\t5\t30\r\n30\t5\t30", "c.zma")
    m = read_measurement(p)
    assert m.meta["format"] == "zma" and m.meta["n_header_lines"] == 3
    assert m.meta["units_from"] == dict.fromkeys(("freq_unit", "quantity", "phase_unit"), "zma convention")
    assert any(".zma convention" in n for n in m.meta["notices"])
    assert m.f_hz[0] == pytest.approx(10) and m.Z[0] == pytest.approx(5 * np.exp(1j * np.pi / 6))
    # a caller may override the convention (never silently), but not with impossible values
    with pytest.raises(DataFormatError, match=r"c.zma:4: phase 30 is beyond 2π, so it is not in radians"):
        read_measurement(p, phase_unit="rad")
    q = _table(tmp_path, "10 5 0.5\n20 5 0.5\n30 5 0.5\n", "r.zma")
    m = read_measurement(q, phase_unit="rad")
    assert m.Z[0] == pytest.approx(5 * np.exp(0.5j)) and any("overrides" in n for n in m.meta["notices"])


def test_comment_line_just_before_the_data_can_name_the_columns(tmp_path):
    p = _table(tmp_path, "* REW impedance export\n* Freq(Hz)  Ohm  Deg\n10 5 30\n20 5 30\n30 5 30\n", "r.txt")
    m = read_measurement(p)
    assert m.meta["units_from"] == dict.fromkeys(("freq_unit", "quantity", "phase_unit"), "header")
    assert m.meta["notices"] == ("column names taken from comment line 2",)
    assert m.Z[0] == pytest.approx(5 * np.exp(1j * np.pi / 6))
    # an ordinary comment does not count, nor a header-like comment away from the data
    q = _table(tmp_path, "* Freq(Hz)  Ohm  Deg\n* measured 2024\n10 5 30\n20 5 30\n30 5 30\n", "q.txt")
    with pytest.raises(DataFormatError, match="no header line"):
        read_measurement(q)


def test_degree_phase_that_never_exceeds_pi_warns(tmp_path):
    rows = "".join(f"{f} 5 {0.1 + f / 1e4:.4f}\n" for f in range(10, 40))
    with pytest.warns(UserWarning, match=r"small.zma:30: .* does not exceed π over 30 points"):
        read_measurement(_table(tmp_path, rows, "small.zma"))
    # a short file is judged against a passive device's range in radians, +-pi/2: a real degree
    # column of a few points (45 deg) passes quietly, radians do not
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_measurement(_table(tmp_path, "10 5 45\n20 5 30\n30 5 3\n", "deg.zma"))
    with pytest.warns(UserWarning, match=r"rad.zma:2: .* does not exceed π/2"):
        read_measurement(_table(tmp_path, "10 5 0.3\n20 5 1.2\n30 5 0.9\n", "rad.zma"))


def test_thousands_separator_is_refused_not_read_as_a_decimal_point(tmp_path):
    # '.' is a decimal point unless the file uses decimal commas: then it can only be a thousands mark
    ok = _table(tmp_path, "Frequency (Hz);|Z| (ohm);Phase (deg)\n500;6,1;10\n1000;7,2;20\n2000;8;30\n",
                "ok.csv")
    assert read_measurement(ok).f_hz[1] == pytest.approx(1000)
    with pytest.raises(DataFormatError, match=r"bad.csv:3: '1.000,5' has a '.'"):
        read_measurement(_table(tmp_path, "Frequency (Hz);|Z| (ohm);Phase (deg)\n500;6,1;10\n"
                                          "1.000,5;7,2;20\n2000;8;30\n", "bad.csv"))
    # dot-decimal files with a falling frequency written like 1.000: refused, not sorted
    with pytest.raises(DataFormatError, match=r"t.zma:3: frequency '2.500' reads as 2.5, below the 900"):
        read_measurement(_table(tmp_path, "800 6 10\n900 6 12\n2.500 7 20\n", "t.zma"))
    # a falling frequency that is no thousands pattern keeps the old behaviour: sorted, with a notice
    with pytest.warns(UserWarning, match="sorted"):
        read_measurement(_table(tmp_path, "800 6 10\n900 6 12\n25.5 7 20\n", "s.zma"))


def test_passivity_check_covers_real_imaginary_and_admittance_files(tmp_path):
    # Re Z < 0 is Re Y < 0: a conductance column with a negative value is the same defect
    p = _table(tmp_path, "Frequency (Hz),G (S),B (S)\n10,0.1,-0.05\n20,-0.02,-0.1\n30,0.1,-0.02\n"
                         "40,0.12,-0.01\n")
    with pytest.warns(UserWarning, match=r"x.csv:3: Re Z = .* < 0 .* at 1 of 4 points"):
        read_measurement(p)
    # rounding at +-90 deg is not flagged (tolerance 0.1 % of |Z|)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_measurement(_table(tmp_path, "10 5 30\n20 5 90.02\n30 5 -90.03\n40 5 45\n", "r.zma"))


def _s1p(tmp_path, name, text):
    return _table(tmp_path, text, name)


def test_touchstone_s_z_y_ma_db_ri(tmp_path):
    z = 6 + 8j
    s = (z - 50) / (z + 50)
    rest = "2000 0.2 53.13\n3000 0.2 53.13\n"  # values at other frequencies: any passive ones
    db = 20 * math.log10(abs(s))
    cases = {
        "s.s1p": f"! comment\n# kHz S RI R 50\n1 {s.real} {s.imag}\n2 0.1 0.1\n3 0.1 0.1\n",
        "sdb.s1p": f"# Hz S DB R 50\n1000 {db} {math.degrees(np.angle(s))}\n2000 -3 5\n3000 -3 5\n",
        "s75.s1p": f"# MHz R 75 RI S\n0.001 {((z - 75) / (z + 75)).real} {((z - 75) / (z + 75)).imag}\n"
                   "0.002 0.1 0.1\n0.003 0.1 0.1\n",
        "z.s1p": f"# Hz Z MA R 50\n1000 {abs(z) / 50} {math.degrees(np.angle(z))}\n" + rest,
        "y.s1p": f"# Hz Y RI R 50\n1000 {(50 / z).real} {(50 / z).imag}\n" + rest,
        # version 2.0: Z and Y are not normalised; [Reference] replaces R for S
        "z2.ts": f"[Version] 2.0\n# Hz Z RI R 50\n[Number of Ports] 1\n[Number of Frequencies] 3\n"
                 f"[Network Data]\n1000 {z.real} {z.imag}\n{rest}[End]\n",
        "s2.s1p": f"[Version] 2.0\n# Hz S RI\n[Number of Ports] 1\n[Reference] 10\n[Network Data]\n"
                  f"1000 {((z - 10) / (z + 10)).real} {((z - 10) / (z + 10)).imag}\n"
                  "2000 0.1 0\n3000 0.1 0\n[End]\n",
    }
    for name, text in cases.items():
        m = read_measurement(_s1p(tmp_path, name, text))
        assert m.Z[0] == pytest.approx(z, rel=1e-9), name
        assert m.f_hz[0] == pytest.approx(1000.0), name
        assert m.meta["format"] == "touchstone"


def test_touchstone_content_under_another_suffix_and_options(tmp_path):
    p = _s1p(tmp_path, "vna.txt", "! exported\n# Hz S RI R 50\n10 0.1 0.1\n20 0.1 0.1\n30 0.1 0.1\n")
    m = read_measurement(p)
    assert m.meta["format"] == "touchstone" and "read as Touchstone" in m.meta["notices"][-1]
    with pytest.raises(DataFormatError, match="states its own units; drop --freq-unit"):
        read_measurement(p, freq_unit="hz")


def test_touchstone_active_reflection_warns(tmp_path):
    p = _s1p(tmp_path, "a.s1p", "# Hz S MA R 50\n10 0.5 3\n20 1.2 3\n30 0.5 3\n")
    with pytest.warns(UserWarning, match=r"a.s1p:3: \|S11\| = 1.2 > 1"):
        read_measurement(p)


@pytest.mark.parametrize("weights", [False, True])
def test_write_read_round_trip(tmp_path, weights):
    meas = simulate(build_model("UD"), PAPER_TABLES["UD"], np.geomspace(10, 1e5, 50), noise=0.01, seed=4)
    if weights:
        meas = type(meas)(meas.omega, meas.Y, weights=np.linspace(0.5, 2, 50), meta=dict(meas.meta))
    write_measurement(meas, tmp_path / "m.csv")
    back = read_measurement(tmp_path / "m.csv")
    np.testing.assert_array_equal(back.omega, meas.omega)
    np.testing.assert_array_equal(back.Y, meas.Y)  # repr floats: exact
    if weights:
        np.testing.assert_array_equal(back.weights, meas.weights)
    assert back.meta["format"] == "native" and back.meta["units_from"]["freq_unit"] == "header"
    assert back.meta["written_meta"]["truth"] == pytest.approx(meas.meta["truth"])
    with warnings.catch_warnings():
        warnings.simplefilter("error" if not weights else "ignore")
        write_measurement(meas, tmp_path / "m.zma")
    back = read_measurement(tmp_path / "m.zma")
    np.testing.assert_allclose(back.omega, meas.omega, rtol=1e-9)
    np.testing.assert_allclose(back.Y, meas.Y, rtol=1e-8)  # 10 significant digits
    assert back.meta["written_meta"]["seed"] == 4


def test_writer_refuses_unknown_suffix_and_is_atomic(tmp_path):
    meas = simulate(build_model("I"), PAPER_TABLES["I"], np.geomspace(10, 1e5, 20))
    with pytest.raises(DataFormatError, match="cannot write '.xlsx'"):
        write_measurement(meas, tmp_path / "m.xlsx")
    target = tmp_path / "keep.csv"
    target.write_text("old")
    with pytest.raises(FileNotFoundError):
        write_measurement(meas, tmp_path / "missing_dir" / "m.csv")
    write_measurement(meas, target)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.csv"]  # no temporary file left behind


def test_bundled_dataset_is_what_its_readme_says():
    # data/README.md: Table 5, NL n=5, 2000 points over 1e1..1e5 rad/s, 0.2 % noise, seed 20261122
    meas = load_paper_bench()
    assert paper_bench_path().name == "paper_bench.csv" and paper_bench_path().exists()
    assert meas.n_points == 2000
    assert meas.omega[0] == pytest.approx(10.0) and meas.omega[-1] == pytest.approx(1e5)
    assert meas.meta["written_meta"]["seed"] == PAPER_BENCH_SEED
    model = build_model("NL", rings=5)
    again = simulate(model, PAPER_TABLES["NL"], meas.omega, noise=PAPER_BENCH_NOISE, seed=PAPER_BENCH_SEED)
    # regenerated, not bit for bit: numpy's SIMD kernels and the BLAS differ between processors in
    # the last bits (measured here 7.5e-16 relative at most; NPY_DISABLE_CPU_FEATURES=X86_V3 with
    # OPENBLAS_CORETYPE=Sandybridge gives other bits, 6.7e-16). 1e-12 is far above that and far
    # below what another seed, noise level or parameter set changes (the noise alone is 2e-3)
    np.testing.assert_allclose(again.Y, meas.Y, rtol=1e-12, atol=0)
    # and the noise is what the README says: 0.2 % per real and imaginary part of the relative error
    rel = meas.Y / model.admittance(meas.omega, model.vector(PAPER_TABLES["NL"])) - 1
    for part in (rel.real, rel.imag):
        assert abs(np.std(part) / PAPER_BENCH_NOISE - 1) < 0.1  # sd of a 2000-point sd estimate: 1.6 %


def test_info_command_prints_ranges_and_resonance(capsys):
    assert main(["info", str(paper_bench_path())]) == 0
    out = capsys.readouterr().out
    assert "points      2000" in out and "10 .. 1e+05 rad/s" in out and "ohm" in out
    assert "resonance   8.09" in out  # omega0 = 50.8 rad/s = 8.09 Hz (SPEC Table 5)


# file: (options, points, (first f [Hz], |Z| [ohm], phase [deg]), (last ...)) -- ../shared/realdata/README.md
REAL_FILES = {
    "dayton_LS10-44.zma": ({}, 344, (1.029, 7.262, 3.835), (20642.546, 298.433, 58.613)),
    "dayton_LS10-44_freeair_run2.txt": ({"freq_unit": "hz"}, 9999, (1.000000011117664, 7.409203109322563,
                                        math.degrees(55.245872448682336e-3)),
                                        (5000.000055588317, 84.76024635633641,
                                         math.degrees(0.94032019867045802))),
    "dayton_LS10-44_added100g_run2.txt": ({"freq_unit": "hz"}, 9999, (1.000000011117664, 7.314084415867047,
                                          math.degrees(59.474598501025697e-3)),
                                          (5000.000055588317, 92.39305994090992,
                                           math.degrees(1.091318842160377))),
    "seas_E0018_freeair.zma": ({}, 386, (10.0, 7.4867, 30.2638), (20000.0, 23.9102, 45.2846)),
    "koan_mid_sealed.zma": ({}, 241, (19.95849609375, 3.633732318878174, 22.158863067626953),
                            (20281.310546875, 7.263079643249512, 39.491397857666016)),
    "koan_tweeter.zma": ({}, 161, (199.951171875, 5.808544635772705, 16.42679214477539),
                         (20317.19921875, 5.9525651931762695, 8.825249671936035)),
}


@pytest.mark.parametrize("name", sorted(REAL_FILES))
def test_real_recordings_read(name, realdata):
    kw, n, first, last = REAL_FILES[name]
    m = read_measurement(realdata / name, **kw)
    assert m.n_points == n
    for i, (f, absz, deg) in ((0, first), (-1, last)):
        assert m.f_hz[i] == pytest.approx(f, rel=1e-12)
        assert abs(m.Z[i]) == pytest.approx(absz, rel=1e-12)
        assert math.degrees(np.angle(m.Z[i])) == pytest.approx(deg, rel=1e-10)
    assert m.meta["quantity"] == "Z" and m.meta["freq_unit"] == "hz"


def test_radian_phase_file_needs_frequency_unit(capsys, realdata):
    path = realdata / "dayton_LS10-44_freeair_run2.txt"
    with pytest.raises(DataFormatError, match=r"run2.txt:1: header .* does not say whether frequencies are "
                                              r"in Hz or rad/s; pass --freq-unit hz\|rad/s"):
        read_measurement(path)
    assert main(["info", str(path), "--freq-unit", "hz"]) == 0
    assert "phase unit rad (from header)" in capsys.readouterr().out
