"""The main job, ``bayes-emt demo``, end to end on the bundled data (a short sampler budget, so the
posterior part runs but is not expected to converge; convergence itself is the slow test
``test_posterior.py::test_paper_bench_nl5_converges_with_ess_1000``)."""

import json
import warnings

import numpy as np
import pytest

from bayes_emt.cli import main
from bayes_emt.errors import ConvergenceWarning
from bayes_emt.reference import PAPER_TABLES


def test_demo_runs_end_to_end_and_says_when_the_posterior_did_not_converge(tmp_path, capsys):
    out = tmp_path / "demo"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        rc = main(["demo", "--out", str(out), "--max-steps", "200", "--seed", "3"])
    text = capsys.readouterr().out
    # 200 steps are far too few for NL(5) (tau_max ~ 144 steps; the rule asks for >= 50 tau):
    # the demo must say so and exit 1
    assert rc == 1 and "NOT CONVERGED" in text and "exit code 1" in text
    expected = {"fits.json", "hankel.json", "shunts.json", "posterior.nc", "posterior.json",
                "posterior_corner.png", "posterior_bode.png"}
    assert {p.name for p in out.iterdir()} >= expected
    fits = json.loads((out / "fits.json").read_text())
    assert list(fits) == ["I", "II", "III", "UD", "NL", "UL"]
    # the bundled data are Table 5 NL(5) with 0.2 % noise: the NL fit is within 4 standard errors of
    # the truth, and the plain-inductance model is far worse than NL
    nl = fits["NL"]
    z = [abs(nl["parameters"][k] - v) / nl["stderr"][k] for k, v in PAPER_TABLES["NL"].items()]
    assert max(z) < 4, z
    assert nl["rms_rel_residual"] < 0.004 < 0.1 < fits["I"]["rms_rel_residual"]
    assert json.loads((out / "hankel.json").read_text())["rings"] == 5  # SPEC §3.3
    shunts = json.loads((out / "shunts.json").read_text())
    # SPEC §5: the NL design attenuates by -24.7 dB (here from the fitted, not the printed, parameters)
    assert shunts["NL"]["evaluated_on_NL"]["attenuation_db"] == pytest.approx(-24.7, abs=0.1)
    post = json.loads((out / "posterior.json").read_text())
    assert post["converged"] is False and post["n_steps"] == 200 and post["seed"] == 3
    # issue 9: every fit carries its warnings; the adequate NL(5) fit none, model I (no eddy
    # currents) model_inadequate; the posterior's JSON carries the NL fit's, plus not_converged
    assert all(isinstance(f["warnings"], list) for f in fits.values())
    assert nl["warnings"] == [] and "model_inadequate" in [w["code"] for w in fits["I"]["warnings"]]
    assert [w["code"] for w in post["warnings"]] == ["not_converged"]
    assert "WARNING [model_inadequate]" in text
    import arviz as az

    dt = az.from_netcdf(out / "posterior.nc")
    assert np.all(np.isfinite(dt["posterior"]["R0"].values))
    for line in text.splitlines():  # outputs are listed with absolute paths (./run demo changes folder)
        if line.startswith("  ") and "kB)" in line:
            assert line.strip().startswith(str(out.resolve()))
