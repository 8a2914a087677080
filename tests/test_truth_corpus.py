"""The truth corpus (scripts/truth/corpus.toml) is well formed: every entry names its source
(repository, a 40-hex commit, a path), a SHA-256, a licence and the provenance of its reference,
and its reference values are SI numbers of the parameters it scores. The interval plot draws."""

from __future__ import annotations

import math
import re
import tomllib
import warnings
from pathlib import Path

import pytest

from bayes_emt.thiele_small.relations import UNITS

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "scripts" / "truth" / "corpus.toml"
#: plausible SI ranges: catches a value left in display units (mH, g, litres, kHz)
SI_RANGE = {"fs": (5.0, 5000.0), "Re": (0.5, 100.0), "Qms": (0.3, 50.0), "Qes": (0.05, 10.0),
            "Qts": (0.05, 5.0), "Bl": (0.1, 50.0), "Mms": (1e-4, 0.5), "Le": (1e-6, 0.05)}


def _corpus():
    with open(CORPUS, "rb") as fh:
        return tomllib.load(fh)["driver"]


def _check_source(s: dict, where: str) -> None:
    assert re.fullmatch(r"[\w.-]+/[\w.-]+", s["repository"]), where
    assert re.fullmatch(r"[0-9a-f]{40}", s["commit"]), where
    assert s["path"] and not s["path"].startswith("/"), where
    assert re.fullmatch(r"[0-9a-f]{64}", s["sha256"]), where
    assert s["sha256_from"] in ("bytes", "stored text"), where
    assert isinstance(s["bytes"], int) and s["bytes"] > 0, where


def test_corpus_entries_are_well_formed():
    entries = _corpus()
    ids = [e["id"] for e in entries]
    assert len(set(ids)) == len(ids)
    for e in entries:
        where = f"corpus entry {e.get('id')}"
        for key in ("unit", "unit_id", "format", "reference_kind", "reference_what", "compare", "reference",
                    "source"):
            assert e.get(key), f"{where}: no {key}"
        s = e["source"]
        _check_source(s, where)
        assert s["licence"], where
        for i, ld in enumerate(e.get("loaded", [])):  # added-mass recordings of the same unit
            _check_source(ld, f"{where} loaded[{i}]")
            assert isinstance(ld["delta_m_kg"], float) and 1e-4 <= ld["delta_m_kg"] <= 1.0, where
        if "reference_file" in e:
            _check_source(e["reference_file"], f"{where} reference_file")
        assert set(e["compare"]) <= set(e["reference"]), where
        for name, v in e["reference"].items():
            assert name in UNITS, f"{where}: {name} is not a T/S name"
            assert isinstance(v, float) and math.isfinite(v), f"{where}: {name}"
            lo, hi = SI_RANGE[name]
            assert lo <= v <= hi, f"{where}: {name} = {v} is not in SI ({lo}..{hi})"
        ref = e["reference"]
        if {"Qms", "Qes", "Qts"} <= set(ref):  # Qts = Qms Qes/(Qms + Qes) to the 4 digits quoted
            qts = ref["Qms"] * ref["Qes"] / (ref["Qms"] + ref["Qes"])
            assert ref["Qts"] == pytest.approx(qts, rel=3e-3), where


def test_corpus_holds_at_least_six_physical_units():
    """Recordings of one unit (break-in stages, a waveguide) share a unit_id: they count once."""
    entries = _corpus()
    units = {e["unit_id"] for e in entries}
    assert len(units) >= 6, sorted(units)
    for u in units:  # one unit, one repository: a unit_id is not reused across sources by mistake
        assert len({e["source"]["repository"] for e in entries if e["unit_id"] == u}) == 1, u


def test_corpus_references_equal_the_bench_fit_in_the_shared_copies():
    """Where the recording carries the bench's own fit (a DATS header) and a copy is at hand, the
    corpus's reference values are that fit's (run.py refuses a mismatch the same way)."""
    from bayes_emt.io import read_measurement

    run = _run_module()
    shared = ROOT / ".." / "shared" / "realdata"
    checked = 0
    for e in _corpus():
        name = e["source"].get("shared_copy")
        if e["format"] != "dats" or not name or not (shared / name).is_file():
            continue
        with warnings.catch_warnings():  # the reader's note on the repeated rows it drops
            warnings.simplefilter("ignore")
            meas = read_measurement(shared / name)
        assert run.bench_fit_mismatch(e, meas) == [], e["id"]
        checked += 1
    if not checked:
        pytest.skip("realdata absent")


def test_bench_fit_mismatch_names_the_parameter():
    import numpy as np

    from bayes_emt.measurement import Measurement

    run = _run_module()
    w = 2 * np.pi * np.array([10.0, 100.0])
    meas = Measurement.from_impedance(w, np.array([6.0 + 0j, 7.0 + 1j]),
                                      meta={"bench_fit": {"values": {"fs": 36.67, "Re": 5.726}}})
    entry = {"reference": {"fs": 36.67, "Re": 5.762, "Mms": 0.016}}
    assert run.bench_fit_mismatch(entry, meas) == ["Re: corpus 5.762, file header 5.726"]
    entry["reference"]["Re"] = 5.726
    assert run.bench_fit_mismatch(entry, meas) == []


def test_fetch_reads_a_local_clone_and_checks_the_hash(tmp_path, capsys):
    """fetch.py --git: the bytes at the pinned commit from a local clone, kept only when their
    SHA-256 is the corpus's; a wrong hash is one skip line and no file."""
    import hashlib
    import subprocess
    import sys

    sys.path.insert(0, str(ROOT / "scripts" / "truth"))
    import fetch

    repo = tmp_path / "clone"
    data = b"* f(s)= 36.67 Hz\r\n1.0 5.7 3.7\r\n"
    (repo / "d").mkdir(parents=True)
    (repo / "d" / "x.txt").write_bytes(data)
    git = ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    subprocess.run([*git, "add", "-A"], check=True)
    subprocess.run([*git, "commit", "-qm", "x"], check=True)
    commit = subprocess.run([*git, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    src = {"repository": "o/n", "commit": commit, "path": "d/x.txt",
           "sha256": hashlib.sha256(data).hexdigest()}
    gitdirs = fetch.parse_git_options([f"o/n={repo / '.git'}"])
    got = fetch.fetch_source(src, "t", tmp_path / "cache", gitdirs=gitdirs)
    assert got == tmp_path / "cache" / "o+n" / commit[:12] / "d" / "x.txt" and got.read_bytes() == data
    bad = {**src, "sha256": "0" * 64, "commit": commit}
    assert fetch.fetch_source(bad, "t2", tmp_path / "cache2", gitdirs=gitdirs) is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "skip t2:" in err and "the corpus says 000" in err
    with pytest.raises(SystemExit, match="OWNER/NAME=PATH"):
        fetch.parse_git_options(["no-equals-sign"])
    # an entry's added-mass recordings: all of them with their masses, or None if one is missing
    entry = {"id": "e", "source": src, "loaded": [{**src, "delta_m_kg": 0.008}]}
    assert fetch.fetch_loaded(entry, tmp_path / "cache", gitdirs=gitdirs) == [(got, 0.008)]
    entry["loaded"].append({**bad, "delta_m_kg": 0.016})
    assert fetch.fetch_loaded(entry, tmp_path / "cache3", gitdirs=gitdirs) is None
    assert "skip e loaded[1]:" in capsys.readouterr().err
    assert fetch.fetch_loaded({"id": "f", "source": src}, tmp_path / "cache", gitdirs=gitdirs) == []


def test_corpus_shared_copies_match_their_hash():
    """The entries with a copy in ../shared/realdata: the copy's SHA-256 is the corpus's."""
    import hashlib

    shared = ROOT / ".." / "shared" / "realdata"
    checked = 0
    for e in _corpus():
        name = e["source"].get("shared_copy")
        if name and (shared / name).is_file():
            assert hashlib.sha256((shared / name).read_bytes()).hexdigest() == e["source"]["sha256"], e["id"]
            assert (shared / name).stat().st_size == e["source"]["bytes"]
            checked += 1
    if not checked:
        pytest.skip("realdata absent")


def test_reference_interval_plot_draws():
    from bayes_emt.plotting.truth import plot_reference_intervals

    rows = [{"driver": d, "parameter": p, "reference": 10.0,
             "columns": {"default": {"value": 10.2, "ci90": [10.1, 10.3]},
                         "white": {"value": 10.0, "ci90": [9.9, 10.1]}}}
            for d in ("a", "b") for p in ("fs", "Qms")]
    fig = plot_reference_intervals(rows, title="t")
    assert len(fig.axes) == 2 and [a.get_title() for a in fig.axes] == ["fs", "Qms"]
    with pytest.raises(ValueError, match="no rows"):
        plot_reference_intervals([])


def _run_module():
    import importlib.util
    import sys

    sys.path.insert(0, str(ROOT / "scripts" / "truth"))
    spec = importlib.util.spec_from_file_location("truth_run", ROOT / "scripts" / "truth" / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_run_scores_and_summarises():
    run = _run_module()
    inside = run.score({"value": 10.2, "ci90": [9.9, 10.4]}, 10.0)
    assert inside["covered"] and inside["error_pct"] == pytest.approx(2.0)
    assert inside["half_width_pct"] == pytest.approx(100 * 0.25 / 10.2)
    outside = run.score({"value": 10.2, "ci90": [10.1, 10.3]}, 10.0)
    assert not outside["covered"]
    assert "covered" not in run.score({"value": 10.2, "ci90": None}, 10.0)
    rows = [{"columns": {"default": inside}}, {"columns": {"default": outside}}, {"columns": {}}]
    s = run.summarise(rows, "default")
    assert s["pairs"] == 2 and s["covered"] == 1 and s["coverage"] == 0.5
    mean_hw = (inside["half_width_pct"] + outside["half_width_pct"]) / 2
    assert s["median_half_width_pct"] == pytest.approx(mean_hw)
    assert run.summarise(rows, "white") == {"pairs": 0}


def test_run_minimal_dats_parser_matches_the_header():
    """The script's fallback parser (for packages without a DATS reader): the header's values in
    SI, the repeated rows below the analyser's resolution dropped (267 of 344 rows kept)."""
    run = _run_module()
    path = ROOT / ".." / "shared" / "realdata" / "grs_12SW-4HE_dats_0h.txt"
    if not path.is_file():
        pytest.skip("realdata absent")
    meas = run.read_dats_minimal(path)
    vals = meas.meta["bench_fit"]["values"]
    assert vals == {"fs": 25.07, "Re": 4.2, "Qms": 3.929, "Qes": 0.5885, "Qts": 0.5118,
                    "Le": pytest.approx(2.855e-3)}
    assert meas.n_points == 267 and meas.f_hz[0] == pytest.approx(9.514)
