"""The bench-export corpus (tests/bench, written by tests/bench/make_corpus.py from the documented
formats): every file is read to the values it was written from, or refused with its specific
one-line message naming the file (and line) and what to do; the expected outcome of each file is
in tests/bench/manifest.json."""

from __future__ import annotations

import importlib.util
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.errors import DataFormatError
from bayes_emt.io import read_measurement

BENCH = Path(__file__).parent / "bench"
MANIFEST = json.loads((BENCH / "manifest.json").read_text())
_spec = importlib.util.spec_from_file_location("make_corpus", BENCH / "make_corpus.py")
corpus = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(corpus)

READS = sorted(k for k, v in MANIFEST.items() if "reads" in v)
REFUSED = sorted(k for k, v in MANIFEST.items() if "refused" in v)


def test_corpus_is_complete_and_large_enough():
    files = {p.name for p in BENCH.iterdir() if p.is_file()} - {"make_corpus.py", "manifest.json"}
    assert files == set(MANIFEST)
    assert len(MANIFEST) >= 30 and len(READS) >= 15 and len(REFUSED) >= 10


@pytest.mark.parametrize("name", READS)
def test_corpus_file_reads_to_its_values(name):
    exp = MANIFEST[name]["reads"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_measurement(BENCH / name, **exp["options"])
    assert m.n_points == exp["points"] and m.meta["format"] == exp["format"]
    # every point against the invented driver the file was written from, within the file's rounding
    # (rel on |Z|, deg on the phase: 4-5 significant digits in the text formats, float32 in .lim)
    Z = corpus.impedance(m.f_hz)
    assert np.abs(m.Z) == pytest.approx(np.abs(Z), rel=exp["rel"])
    if exp["magnitude_only"]:
        assert m.meta["phase"] == "absent" and m.meta["representation"] == "magnitude"
    else:
        assert "phase" not in m.meta
        assert np.degrees(np.angle(m.Z)) == pytest.approx(np.degrees(np.angle(Z)), abs=exp["deg"])
    if exp["bench"]:
        assert m.meta["bench_fit"]["bench"] == exp["bench"]
    if exp["notice"]:
        assert any(exp["notice"] in n for n in m.meta["notices"]), m.meta["notices"]
    if exp["dropped_below_hz"]:
        lo, hi = m.meta["dropped_band_hz"]
        assert lo == pytest.approx(1.029) and hi < exp["dropped_below_hz"] <= m.f_hz[0] + 0.5
    assert not [w for w in caught if "phase is in degrees" in str(w.message)]


@pytest.mark.parametrize("name", REFUSED)
def test_corpus_file_is_refused_with_its_message(name, capsys):
    exp = MANIFEST[name]
    with pytest.raises(DataFormatError) as exc:
        read_measurement(BENCH / name, **exp["options"])
    msg = str(exc.value)
    assert exp["refused"] in msg and "\n" not in msg and msg.startswith(str(BENCH / name))
    assert main(["info", str(BENCH / name)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and exp["refused"] in err[0] and "Traceback" not in err[0]


def test_klippel_keeps_the_fitted_curve_as_the_bench_fit():
    m = read_measurement(BENCH / "klippel_lpm_crlf_short_fit.txt")
    curve = m.meta["bench_fit"]["curve"]
    assert len(curve["f_hz"]) == 120 == len(curve["abs_z_ohm"])
    # the fitted group was written from the driver with Rms 1.05 instead of 1.1 kg/s (make_corpus.klippel)
    f = np.array(curve["f_hz"])
    Zfit = corpus.impedance(f, {**corpus.DRIVER, "Rms": 1.05})
    assert np.array(curve["abs_z_ohm"]) == pytest.approx(np.abs(Zfit), rel=2e-4)


def test_klippel_phase_is_the_minimum_phase_estimate():
    # the invented driver is minimum-phase: Bode's relation from |Z| alone recovers its phase to
    # within the truncation of the band (5 Hz-5.1 kHz here; largest error at the band's ends)
    m = read_measurement(BENCH / "klippel_lpm.txt")
    true = np.degrees(np.angle(corpus.impedance(m.f_hz)))
    est = np.degrees(np.angle(m.Z))
    inner = (m.f_hz > 10) & (m.f_hz < 2000)
    assert np.max(np.abs(est - true)[inner]) < 2.0


def test_lim_note_and_rate():
    m = read_measurement(BENCH / "limp_note.lim")
    assert m.meta["lim_note"] == "woofer, free air, 1 V" and m.meta["sample_rate_hz"] == 48000.0


def test_lim_magic_under_another_name(tmp_path):
    p = tmp_path / "woofer.dat"
    p.write_bytes((BENCH / "limp.lim").read_bytes())
    assert read_measurement(p).meta["format"] == "lim"


def test_minimum_phase_of_power_laws():
    from bayes_emt.io.minphase import minimum_phase_deg

    f = np.logspace(0, 4, 200)
    assert minimum_phase_deg(f, 3.0 * f) == pytest.approx(90.0, abs=1e-9)  # an inductor
    assert minimum_phase_deg(f, 3.0 * f**0.5) == pytest.approx(45.0, abs=1e-9)  # a semi-inductor
    assert minimum_phase_deg(f, np.full(f.size, 4.0)) == pytest.approx(0.0, abs=1e-12)
    # R + jwL: the phase is atan(wL/R) exactly
    Z = 2.0 + 2j * math.pi * f * 1e-3
    est = minimum_phase_deg(f, np.abs(Z))
    inner = (f > 3) & (f < 3000)
    assert est[inner] == pytest.approx(np.degrees(np.angle(Z[inner])), abs=0.5)
