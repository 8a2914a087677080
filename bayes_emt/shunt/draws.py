"""Posterior draws for the robust design: one group per model, an evidence-weighted mixture of
several models' posteriors, and the split into a design half and a held-back half.

**Mixture.** With log evidences ``log Z_k`` the posterior probability of model ``k`` (equal prior
odds) is ``w_k = exp(log Z_k − max) / Σ``; the mixture's ``N`` draws are ``round(w_k N)`` draws
of model ``k`` (largest remainders, so they add up to ``N``), each group drawn without
replacement from that model's kept draws (with replacement, and a warning, only if it holds
fewer). Without evidences the weights are equal (and the result says so).

**Halves.** Every group is shuffled and cut in two (stratified, so both halves keep the model
proportions); the robust shunt is chosen on the first half and reported on the second, so that
its reported risk is not the optimiser's own sample (no optimisation bias).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..models import Model

__all__ = ["DrawGroup", "mixture_weights", "sample_mixture", "split_halves"]


@dataclass(frozen=True, eq=False)
class DrawGroup:
    """Draws of one model's posterior.

    Attributes
    ----------
    model : the model. thetas : ``(n, k)`` physical parameter vectors [SI].
    source : where they came from (a file path). weight : mixture weight (0..1).
    log_evidence : the model's log evidence [nats], if given. available : kept draws in the source.
    spare : ``(m, k)`` the source's kept draws not picked (for checking a shunt on draws it was not
        chosen on, :mod:`bayes_emt.shunt.bound`), or None.
    """

    model: Model
    thetas: np.ndarray
    source: str = ""
    weight: float = 1.0
    log_evidence: float | None = None
    available: int = 0
    spare: np.ndarray | None = None

    @property
    def label(self) -> str:
        return self.model.label

    @property
    def n(self) -> int:
        return int(self.thetas.shape[0])

    def to_json_dict(self) -> dict:
        return {"name": self.model.spec, "rings": self.model.rings, "label": self.label,
                "source": self.source, "weight": self.weight, "log_evidence": self.log_evidence,
                "n_draws": self.n, "draws_available": self.available}


def mixture_weights(log_evidences: Sequence[float | None]) -> tuple[np.ndarray, str]:
    """Posterior model probabilities from log evidences [nats] (equal prior odds), and a note.

    All ``None``: equal weights (the note says so). Some ``None``: ``ValueError``.
    """
    n = len(log_evidences)
    if n == 0:
        raise ValueError("no posterior given")
    given = [v is not None for v in log_evidences]
    if not any(given):
        note = "" if n == 1 else ("no log evidence given: the models are weighted equally, which says "
                                  "nothing about which is right (give --log-evidence or --compare)")
        return np.full(n, 1.0 / n), note
    if not all(given):
        raise ValueError("give a log evidence for every posterior, or for none")
    lz = np.array([float(v) for v in log_evidences])
    if not np.all(np.isfinite(lz)):
        raise ValueError(f"log evidences must be finite numbers, got {list(lz)}")
    w = np.exp(lz - lz.max())
    return w / w.sum(), "weights from the log evidences (equal prior odds)"


def _allocate(weights: np.ndarray, n: int) -> np.ndarray:
    raw = weights * n
    k = np.floor(raw).astype(int)
    rest = n - k.sum()
    k[np.argsort(-(raw - k), kind="stable")[:rest]] += 1
    return k


def sample_mixture(posteriors: Sequence[tuple[Model, np.ndarray, str]], weights, n_draws: int, *,
                   seed: int = 0, log_evidences: Sequence[float | None] | None = None
                   ) -> tuple[list[DrawGroup], list[str]]:
    """``n_draws`` draws of the mixture (module docstring): one :class:`DrawGroup` per posterior
    ``(model, thetas (m, k), source)``, and warnings. Groups allotted no draw are kept (empty)."""
    if int(n_draws) != n_draws or n_draws < 2:
        raise ValueError(f"the number of draws must be an integer >= 2, got {n_draws!r}")
    weights = np.asarray(weights, float)
    rng = np.random.default_rng(seed)
    counts = _allocate(weights, int(n_draws))
    groups, warns = [], []
    lzs = list(log_evidences) if log_evidences is not None else [None] * len(posteriors)
    for (model, thetas, source), w, k, lz in zip(posteriors, weights, counts, lzs, strict=True):
        thetas = np.asarray(thetas, float)
        m = thetas.shape[0]
        replace = k > m
        if replace:
            warns.append(f"{source}: {k} draws asked of {m} kept draws: drawn with replacement "
                         "(repeated draws add no information)")
        pick = rng.choice(m, size=k, replace=replace) if k else np.empty(0, int)
        rest = np.ones(m, bool)
        rest[pick] = False
        groups.append(DrawGroup(model, thetas[pick], source, float(w), lz, m, thetas[rest]))
    return groups, warns


def split_halves(groups: Sequence[DrawGroup], *, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per group, ``(design_idx, held_idx)``: a seeded shuffle cut in two (module docstring)."""
    rng = np.random.default_rng(seed)
    out = []
    for g in groups:
        perm = rng.permutation(g.n)
        half = int(math.ceil(g.n / 2))
        out.append((np.sort(perm[:half]), np.sort(perm[half:])))
    return out
