"""Bayes factors between candidates and their verbal scale.

The scale is Kass & Raftery's (1995, "Bayes factors", J. Am. Stat. Assoc. 90, p. 777), stated
there on ``2 ln B``: 0–2 "not worth more than a bare mention", 2–6 "positive", 6–10 "strong",
> 10 "very strong". On ``ln B`` [nats] that is

    |ln B| < 1: inconclusive,  1–3: positive,  3–5: strong,  ≥ 5: very strong,

and the lowest band is called *inconclusive* here (the issue's rule: |Δ log Z| < 1 decides
nothing). A comparison is also inconclusive when ``|ln B|`` is within two combined standard
errors of zero, however large it looks: an estimator's noise must not pick the winner.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["verbal", "bayes_factor", "SCALE_REFERENCE"]

SCALE_REFERENCE = "Kass & Raftery (1995), on ln B: <1 inconclusive, 1-3 positive, 3-5 strong, >=5 very strong"


def verbal(log_b: float, err: float = 0.0) -> str:
    """The verbal strength of ``ln B`` [nats] with standard error ``err`` (module docstring)."""
    a = abs(log_b)
    if not math.isfinite(a) or a < 1.0 or a < 2.0 * err:
        return "inconclusive"
    if a < 3.0:
        return "positive"
    if a < 5.0:
        return "strong"
    return "very strong"


def bayes_factor(a: Mapping, b: Mapping) -> dict:
    """``ln B_{a/b}`` from two model records with ``name``, ``log_evidence``, ``log_evidence_err``:
    value, error [nats], verbal strength and the favoured model (``None`` when inconclusive)."""
    lb = float(a["log_evidence"]) - float(b["log_evidence"])
    err = math.hypot(float(a["log_evidence_err"]), float(b["log_evidence_err"]))
    word = verbal(lb, err)
    return {"log_bayes_factor": lb, "err": err, "units": "nats", "verdict": word,
            "favours": None if word == "inconclusive" else (a["name"] if lb > 0 else b["name"])}
