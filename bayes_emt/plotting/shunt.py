"""Shunt plots: receptance magnitudes and the attenuation map over (Rs, Cs) (the paper's Fig. 11).

Each function takes a :class:`~bayes_emt.shunt.ShuntDesign` with the model and parameter vector it
is drawn on, and an optional ``ax``; it returns the figure (never ``show``).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ..models import Model
from ..shunt import Plant, ShuntEvaluation, instability_threshold, rc_impedance
from ..shunt.stability import threshold_grid
from . import figure_axes

__all__ = ["plot_receptance", "plot_attenuation_map"]


def plot_receptance(design: ShuntEvaluation, model: Model, theta, *, ax=None, span: float = 3.0,
                    others: tuple[ShuntEvaluation, ...] = ()) -> Figure:
    """``|m·G_open|`` and ``|m·G_RC|`` [dB re 1 s²] of (50) against frequency [Hz].

    Parameters
    ----------
    design : the shunt to draw (a design or an evaluation: its ``Rs``, ``Cs`` are used).
    model, theta : the plant it is drawn on.
    ax : axes to draw into (default: a new figure).
    span : frequency range ``ω0/span .. ω0·span``.
    others : further shunts drawn on the same plant (e.g. other models' designs).
    """
    fig, ax = figure_axes(ax)
    plant = Plant(model, theta)
    omega = np.geomspace(plant.omega0 / span, plant.omega0 * span, 2000)
    f = omega / (2 * math.pi)
    open_pk = plant.open_peak().value
    ax.semilogx(f, 20 * np.log10(np.abs(plant.receptance(omega))), color="k", label="open terminals")
    for d in (design, *others):
        g = plant.receptance(omega, lambda s, d=d: rc_impedance(s, d.Rs, d.Cs))
        att = 20 * math.log10(plant.peak(lambda s, d=d: rc_impedance(s, d.Rs, d.Cs)).value / open_pk)
        ax.semilogx(f, 20 * np.log10(np.abs(g)),
                    label=f"{d.model}: Rs = {d.Rs:.4g} Ω, Cs = {d.Cs:.4g} F ({att:.1f} dB)")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|m G| [dB re 1 s²]")
    ax.set_title(f"model {model.label}: mass-normalised receptance (eq. 50)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def plot_attenuation_map(design: ShuntEvaluation, model: Model, theta, *, ax=None,
                         rs_span: float | None = None, cs_span: float = 0.6, points: int = 61) -> Figure:
    """Contour map of the attenuation [dB] over ``(Rs [Ω], Cs [F])`` around the optimum (marked), with
    the stability limit ``Rs_instability(Cs)`` (the paper's Fig. 11).

    Parameters
    ----------
    design : the optimum to mark.
    model, theta : the plant the map is computed on.
    ax : axes to draw into (default: a new figure).
    rs_span : half-width in Rs [Ω] (default: 1.2 × the design's stability margin, so the limit shows).
    cs_span : Cs from ``Cs·(1 − cs_span)`` to ``Cs·(1 + cs_span)``.
    points : grid points per axis.
    """
    fig, ax = figure_axes(ax)
    plant = Plant(model, theta)
    grid = threshold_grid(model, theta)
    if rs_span is None:
        rs_span = 1.2 * design.stability_margin if math.isfinite(design.stability_margin) else 0.2
    rs = np.linspace(design.Rs - rs_span, design.Rs + rs_span, points)
    cs = design.Cs * np.linspace(1 - cs_span, 1 + cs_span, points)
    open_pk = plant.open_peak().value
    att = np.full((points, points), np.nan)
    limit = np.empty(points)
    for j, c in enumerate(cs):
        limit[j] = instability_threshold(model, theta, c, grid=grid, refine=False)
        for i, r in enumerate(rs):
            if r > limit[j]:
                att[j, i] = 20 * math.log10(plant.rc_peak_fast(r, c) / open_pk)
    lo = math.floor(np.nanmin(att))
    levels = np.r_[np.arange(lo, lo + 6, 1.0), np.arange(lo + 6, 1, 3.0)]
    cont = ax.contour(rs, cs, att, levels=levels, cmap="viridis")
    ax.clabel(cont, fontsize=7, fmt="%.0f")
    ax.plot(limit, cs, color="crimson", lw=1.2, ls="--", label="stability limit (unstable to the left)")
    ax.plot(design.Rs, design.Cs, "k*", ms=11, label=f"optimum {design.attenuation_db:.2f} dB")
    ax.set_xlim(rs[0], rs[-1])
    ax.set_xlabel("Rs [Ω]")
    ax.set_ylabel("Cs [F]")
    ax.set_title(f"model {model.label}: attenuation [dB] of the RC shunt")
    ax.legend(loc="upper right", fontsize=8)
    return fig
