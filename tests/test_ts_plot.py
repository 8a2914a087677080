"""``ts --plot DIR`` on real recordings: the figure of the fit with its 90 % posterior predictive
band (acceptance 5), drawn from the result's saved curve, so that the report's T/S section shows
the same figure. Checked by eye on both files (PNG in the commit message's run); here: the files
are written, the curve spans the recording, the band contains the fitted curve, and the recording
lies inside the band at most frequencies (a structured misfit of a few per cent is visible outside)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.plotting.thiele_small import plot_ts_fit
from bayes_emt.thiele_small import read_thiele_small


@pytest.mark.parametrize("name", ["seas_E0018_freeair.zma", "dayton_LS10-44.zma"])
def test_ts_plot_on_a_real_recording(realdata, tmp_path, name):
    if not (realdata / name).is_file():
        pytest.skip(f"{name} not present")
    out = tmp_path / "ts.json"
    rc = main(["ts", str(realdata / name), "--model", "UD", "--fast", "--spread-models", "none",
               "--omega-min", "10Hz", "--json", str(out), "--plot", str(tmp_path / "fig"), "--quiet"])
    assert rc == 0
    png = tmp_path / "fig" / "ts_fit.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    c = json.loads(out.read_text())["curve"]
    f = np.array(c["f_hz"])
    assert f[0] >= 10.0 and f[-1] > 15_000 and np.all(np.diff(f) > 0)
    lo, hi = (np.array(b) for b in c["band_abs_z_ohm"])
    fit, data = np.array(c["fit_abs_z_ohm"]), np.array(c["data_abs_z_ohm"])
    assert np.all(lo <= fit) and np.all(fit <= hi)
    assert np.mean((lo <= data) & (data <= hi)) > 0.6
    # the same figure from the saved result (what the report draws)
    fig = plot_ts_fit(read_thiele_small(out))
    assert len(fig.axes) == 3 and fig.axes[2].get_xlabel() == "frequency [Hz]"


def test_a_result_without_a_curve_says_so():
    from bayes_emt.thiele_small import ThieleSmall

    with pytest.raises(ValueError, match="carries no fitted curve"):
        plot_ts_fit(ThieleSmall(model="UD", method="free_air", parameters={}))


def test_the_bench_fit_is_drawn_when_the_reader_provides_it(tmp_path):
    """The readers' interface: meta['bench_fit'] = {'bench': 'DATS', 'curve': {'f_hz', 'abs_z_ohm'}}."""
    from dataclasses import replace
    from types import MappingProxyType

    from bayes_emt.thiele_small import thiele_small
    from bayes_emt.thiele_small.simulate import simulate_driver

    sim = simulate_driver("I+semi_inductance", deltas=(), n_points=200, seed=1)
    f = sim.free.f_hz
    bench = {"bench": "DATS", "curve": {"f_hz": f.tolist(), "abs_z_ohm": np.abs(sim.free.Z).tolist()}}
    meas = replace(sim.free, meta=MappingProxyType({**sim.free.meta, "bench_fit": bench}))
    r = thiele_small(meas, "I+semi_inductance", fast=True, models_for_spread=[])
    assert r.curve["bench"]["label"] == "DATS" and len(r.curve["bench"]["f_hz"]) == 200
    fig = plot_ts_fit(r)
    assert any("DATS" in t.get_text() for t in fig.axes[0].get_legend().get_texts())
