"""The NL ring count by evidence, beside the Hankel-singular-value choice.

Given the evidences of NL(n) for several n, the choice is the smallest n whose log Z is within
``tolerance`` (1 nat: the inconclusive band of :mod:`.scale`) of the largest: a ring the data
do not support by at least a "positive" Bayes factor is not added. The raw arg-max is reported
too. The Hankel choice is :func:`~bayes_emt.estimation.hankel.select_rings` on an NL(``max_rings``)
least-squares fit.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

from ..estimation.hankel import select_rings
from ..measurement import Measurement
from ..models import Model, build_model
from .records import ModelEvidence

__all__ = ["expand_rings", "rings_by_evidence", "ring_choice", "parse_rings"]


def parse_rings(text: str) -> tuple[int, ...]:
    """``"1-7"`` → (1, ..., 7); ``"2,3,5"`` → (2, 3, 5); a bad range raises ``ValueError``."""
    out: list[int] = []
    for part in str(text).split(","):
        part = part.strip()
        try:
            if "-" in part:
                a, b = (int(x) for x in part.split("-", 1))
                if a > b:
                    raise ValueError
                out += list(range(a, b + 1))
            else:
                out.append(int(part))
        except ValueError:
            raise ValueError(f"--rings: expected ring counts like 1-7 or 2,3,5, got {text!r}") from None
    if not out or min(out) < 1:
        raise ValueError(f"--rings: ring counts must be positive integers, got {text!r}")
    return tuple(sorted(set(out)))


def expand_rings(specs: Sequence[tuple[str, Model]], rings: Sequence[int] | None
                 ) -> tuple[list[tuple[str, Model]], list[str]]:
    """``(name, model)`` candidates with every ringed model (NL, UL) once per count of ``rings``
    (named ``NAME(n)`` when there are several), and the names that were expanded."""
    out, ringed = [], []
    for name, model in specs:
        if model.rings is None or not rings:
            out.append((name, model))
            continue
        ringed.append(name)
        for n in rings:
            out.append((name if len(rings) == 1 else f"{name}({n})",
                        build_model(model.spec, rings=n, n_turns=model.n_turns)))
    return out, ringed


def rings_by_evidence(models: Sequence[ModelEvidence], tolerance: float = 1.0) -> dict:
    """The ring count the evidences of NL(n) candidates support.

    Returns ``{"by_evidence", "argmax", "log_evidence_by_rings", "rule"}`` (``by_evidence`` is
    ``None`` when no candidate has a finite log Z).
    """
    table = {int(m.rings): m.log_evidence for m in models
             if m.rings is not None and math.isfinite(m.log_evidence)}
    if not table:
        return {"by_evidence": None, "argmax": None, "log_evidence_by_rings": {}, "rule": ""}
    top = max(table.values())
    argmax = max(table, key=table.get)
    choice = min(n for n, lz in table.items() if top - lz < tolerance)
    return {"by_evidence": choice, "argmax": argmax,
            "log_evidence_by_rings": {str(n): table[n] for n in sorted(table)},
            "rule": f"smallest n with log Z within {tolerance:g} nat of the largest", "units": "nats"}


def ring_choice(meas: Measurement, models: Sequence[ModelEvidence], *, max_rings: int = 7,
                n_turns: float | None = None) -> dict:
    """:func:`rings_by_evidence` beside the Hankel choice from an NL(``max_rings``) fit, with one
    sentence comparing them."""
    out = rings_by_evidence(models)
    kwargs = {} if n_turns is None else {"n_turns": n_turns}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hk = select_rings(meas, max_rings, **kwargs)
    out["hankel"] = hk.rings
    out["hankel_detail"] = hk.to_json_dict()
    out["hankel_warnings"] = [str(w.message) for w in caught]
    ev = out["by_evidence"]
    if ev is None:
        out["agreement"] = "no ring count by evidence (no NL candidate with a finite log Z)"
    elif ev == hk.rings:
        out["agreement"] = f"evidence and Hankel singular values agree: n = {ev}"
    else:
        out["agreement"] = (f"evidence picks n = {ev}, Hankel singular values n = {hk.rings} "
                            f"({'more' if ev > hk.rings else 'fewer'} rings by evidence)")
    return out
