"""The Bessel ratio of models III and UD on the imaginary axis, against scipy's ``jv``.

``bessel_speedup`` is the time of ``jv(1, z)/jv(0, z)`` (``z = sqrt(−jαω)``, the SPEC's form)
over the time of :func:`bayes_emt.models.terms.bessel_ratio_jw` for the same ratio, both complex
results, at 64 values of α log-uniform over 1e-6..1e-2 s (decades around the paper's III and UD
values, where samplers go) times the 2000 frequencies of the bundled data: ``|w| = sqrt(αω)``
from 3e-3 to 32. Accuracy is checked against a backward continued fraction evaluated to
convergence (``I1/I0 = w/(2 + w²/(4 + w²/(6 + …)))``, independent of both), and the ratio is
evaluated where ``jv`` overflows (``|w|`` 1e3–1e5).
"""

import numpy as np
from scipy import special
from timing import best_interleaved

from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.models import terms as T


def continued_fraction_ratio(w, terms: int | None = None) -> np.ndarray:
    """``I1(w)/I0(w)`` by the backward continued fraction (complex ``w``), to convergence."""
    w = np.asarray(w, complex)
    w2 = w * w
    k_max = terms or int(2 * np.max(np.abs(w))) + 60
    acc = np.zeros_like(w)
    for k in range(k_max, 0, -1):
        acc = w2 / (2.0 * k + acc)
    return acc / w


def _points():
    omega = load_paper_bench().omega
    alpha = np.geomspace(1e-6, 1e-2, 64)[:, None]
    return alpha, omega


def measure() -> dict:
    alpha, omega = _points()
    z = np.sqrt(-1j * alpha * omega)
    t = best_interleaved({"jv": lambda: special.jv(1, z) / special.jv(0, z),
                          "table": lambda: T.bessel_ratio_jw(alpha, omega)})
    ours = T.bessel_ratio_jw(alpha, omega)
    ref = continued_fraction_ratio(np.sqrt(1j * alpha * omega))
    err = float(np.max(np.abs(ours - ref) / np.abs(ref)))
    via_jv = 1j * (special.jv(1, z) / special.jv(0, z))  # I1(w)/I0(w) = j J1(z)/J0(z), z = −jw
    err_jv = float(np.max(np.abs(via_jv - ref) / np.abs(ref)))
    big = np.geomspace(1e3, 1e5, 50)  # |w|: where jv(1, z) overflows
    zb = big * np.exp(-0.25j * np.pi)
    with np.errstate(all="ignore"):
        jv_big = special.jv(1, zb) / special.jv(0, zb)
    ours_big = T.bessel_ratio_jw(big**2, 1.0)
    err_big = float(np.max(np.abs(ours_big - continued_fraction_ratio(big * np.exp(0.25j * np.pi)))
                           / np.abs(ours_big)))
    return {
        "results": {"bessel_speedup": t["jv"] / t["table"], "bessel_max_rel_error": err},
        "targets": {"bessel_speedup": [">=", 5.0], "bessel_max_rel_error": ["<=", 1e-12]},
        "details": {"jv_seconds": t["jv"], "table_seconds": t["table"], "points": int(z.size),
                    "abs_w_range": [float(np.sqrt(alpha.min() * omega.min())),
                                    float(np.sqrt(alpha.max() * omega.max()))],
                    "jv_max_rel_error": err_jv,
                    "jv_finite_fraction_abs_w_1e3_to_1e5": float(np.mean(np.isfinite(jv_big))),
                    "table_finite_fraction_abs_w_1e3_to_1e5": float(np.mean(np.isfinite(ours_big))),
                    "table_max_rel_error_abs_w_1e3_to_1e5": err_big,
                    "notes": ["64 alpha log-uniform over 1e-6..1e-2 s times the bundled data's 2000 "
                              "frequencies; best of >= 7 interleaved calls; both return the complex ratio",
                              "reference: backward continued fraction to convergence"]},
    }
