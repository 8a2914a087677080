"""The truth corpus (scripts/truth/corpus.toml) is well formed: every entry names its source
(repository, a 40-hex commit, a path), a SHA-256, a licence and the provenance of its reference,
and its reference values are SI numbers of the parameters it scores. The interval plot draws."""

from __future__ import annotations

import math
import re
import tomllib
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


def test_corpus_entries_are_well_formed():
    entries = _corpus()
    assert len(entries) >= 6
    ids = [e["id"] for e in entries]
    assert len(set(ids)) == len(ids)
    for e in entries:
        where = f"corpus entry {e.get('id')}"
        for key in ("unit", "format", "reference_kind", "reference_what", "compare", "reference", "source"):
            assert e.get(key), f"{where}: no {key}"
        s = e["source"]
        assert re.fullmatch(r"[\w.-]+/[\w.-]+", s["repository"]), where
        assert re.fullmatch(r"[0-9a-f]{40}", s["commit"]), where
        assert s["path"] and not s["path"].startswith("/"), where
        assert re.fullmatch(r"[0-9a-f]{64}", s["sha256"]), where
        assert s["sha256_from"] in ("bytes", "stored text"), where
        assert isinstance(s["bytes"], int) and s["bytes"] > 0, where
        assert s["licence"], where
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
