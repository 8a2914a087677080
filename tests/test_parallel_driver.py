"""The ``parallel_driver`` term: a second driver of the same type wired in parallel, ``Y = Y_1 + Y_2``.

Its value is checked against the admittances of the two drivers computed by hand (eq. 47 for each,
the second with the first's coil impedance scaled and, in a vented box, the same box branch); exact
to rounding (rtol 1e-12). Discovery proposes it only when the data show more than one mechanical
resonance (two |Z| maxima) or the search ends on the signature of more than one driver.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from bayes_emt.discovery import candidate_physics
from bayes_emt.discovery.locate import Band
from bayes_emt.models import AUGMENTATIONS, TERMS, make_term, model_from_dict, parse_model_spec
from bayes_emt.models import terms as T
from bayes_emt.models.registry import _problems

sys.path.insert(0, str(Path(__file__).parent))
from vented_box import simulate_parallel_vented  # noqa: E402

D1 = {"zeta": 0.08, "omega0": 2 * math.pi * 50, "phi": 49.5, "R0": 3.3, "Lg": 2e-4, "alpha": 8e-5,
      "beta": 0.08}
D2 = {"R0_2": 3.6, "omega0_2": 2 * math.pi * 56, "phi_2": 47.0, "kcoil_2": 1.1}
BOX = {"Lb": 8e-3, "omegab": 2 * math.pi * 42, "zetab": 0.05}
OMEGA = np.geomspace(2 * math.pi * 10, 2 * math.pi * 2e4, 400)


def _zc(s):
    return D1["Lg"] * s + T.bessel_eddy(s, D1["alpha"], D1["beta"])


def _y_mot(s, zeta, w0, phi, box):
    y = (s * s + 2 * zeta * w0 * s + w0 * w0) / (phi * phi * s)
    if box:
        y = y + (s / BOX["Lb"]) / (s * s + 2 * BOX["zetab"] * BOX["omegab"] * s + BOX["omegab"] ** 2)
    return y


@pytest.mark.parametrize("box", [False, True])
def test_the_admittance_is_the_sum_of_the_two_drivers(box):
    spec = "UD+enclosure_port+parallel_driver" if box else "UD+parallel_driver"
    model = parse_model_spec(spec)
    values = {**D1, **D2, **(BOX if box else {})}
    y = model.admittance(OMEGA, model.vector(values))
    s = 1j * OMEGA
    y1 = 1 / (D1["R0"] + _zc(s) + 1 / _y_mot(s, D1["zeta"], D1["omega0"], D1["phi"], box))
    # the second driver: its own R0, resonance and coupling, the first's damping ratio (the same
    # type), the first's coil scaled by kcoil_2, the same box
    y_mot2 = _y_mot(s, D1["zeta"], D2["omega0_2"], D2["phi_2"], box)
    y2 = 1 / (D2["R0_2"] + D2["kcoil_2"] * _zc(s) + 1 / y_mot2)
    np.testing.assert_allclose(y, y1 + y2, rtol=1e-12)
    # the term order does not matter (the second driver is evaluated after the driver it copies)
    other = parse_model_spec("UD+parallel_driver+enclosure_port" if box else spec)
    np.testing.assert_allclose(other.admittance(OMEGA, other.vector(values)), y1 + y2, rtol=1e-12)
    # the shunt's view: the second driver sits across the terminals, a device term
    loop = model.loop(s, model.vector(values))
    np.testing.assert_allclose(loop.y_parallel, y2, rtol=1e-12)
    assert not model.plain_mechanics


def test_the_term_registers_serialises_and_has_proper_priors():
    cls = TERMS["parallel_driver"]
    assert "parallel_driver" in AUGMENTATIONS and _problems(cls) == []
    assert cls.structural and cls.device and cls.needs == ("zeta",)
    t = make_term("parallel_driver")
    for p in t.params:
        assert np.isfinite(p.prior.lower) and np.isfinite(p.prior.upper) and p.prior.lower > 0, p.name
        assert p.unit, p.name
    # the same prior for the same quantity of either driver (evidences stay comparable)
    plant = parse_model_spec("UD")
    for mine, theirs in (("R0_2", "R0"), ("omega0_2", "omega0"), ("phi_2", "phi")):
        assert t.params[mine].prior == plant.params[theirs].prior
    model = parse_model_spec("NL(3)+enclosure_port+parallel_driver")
    back = model_from_dict(json.loads(json.dumps(model.to_dict())))
    assert back == model and back.label == "NL(3)+enclosure_port+parallel_driver"
    theta = model.params.from_z(np.zeros(model.ndim))
    np.testing.assert_allclose(back.admittance(OMEGA, theta), model.admittance(OMEGA, theta), rtol=1e-14)


def test_discovery_proposes_it_only_for_the_signature_of_more_than_one_driver():
    band = Band(1.0, 1e6, 0, 100, ("real", "imag"), 10.0, 5.0, 1e3)
    model = parse_model_spec("UD")
    assert "parallel_driver" not in candidate_physics(band, model, None)
    assert "parallel_driver" in candidate_physics(band, model, None, structure=True)
    assert "parallel_driver" not in candidate_physics(band, parse_model_spec("UD+parallel_driver"), None,
                                                      structure=True)


def test_the_start_splits_the_lumped_driver_into_two():
    """From the lumped fit of a pair, the term's starts double R0 and the coil, raise phi by sqrt 2,
    and one of them (the polished best) fits the pair to the noise with each driver's own values
    within 5 % (simulated pair in a vented box, 0.3 % noise)."""
    from bayes_emt.estimation.augment import augmentation_starts
    from bayes_emt.estimation.fitting import fit_admittance

    meas = simulate_parallel_vented(noise=0.003, seed=1).thin(100)
    lumped = fit_admittance(meas, parse_model_spec("UD+enclosure_port"))
    new, starts = augmentation_starts(meas, lumped.model, lumped.theta, make_term("parallel_driver"))
    v = lumped.parameters
    first = new.as_dict(starts[0])
    assert first["R0"] == pytest.approx(2 * v["R0"]) and first["Lg"] == pytest.approx(2 * v["Lg"])
    assert first["phi"] == pytest.approx(math.sqrt(2) * v["phi"])
    assert first["alpha"] == pytest.approx(v["alpha"])  # a time constant: the same core
    fits = [fit_admittance(meas, new, initial=s, warm=True) for s in starts[:3]]
    best = min(fits, key=lambda f: f.chi2)
    assert best.rms_rel_residual < 1.1 * 0.003 * math.sqrt(2)
    p = best.parameters
    # the simulated pair (tests/vented_box.py): 50 Hz, R0 3.3 ohm and 56 Hz, R0 3.63 ohm; either order
    got = sorted([(p["omega0"], p["R0"]), (p["omega0_2"], p["R0_2"])])
    want = [(2 * math.pi * 50, 3.3), (2 * math.pi * 56, 3.63)]
    for (w, r), (w_true, r_true) in zip(got, want, strict=True):
        assert w == pytest.approx(w_true, rel=0.05) and r == pytest.approx(r_true, rel=0.05)
