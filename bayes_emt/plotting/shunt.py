"""Shunt plots: receptance magnitudes and the attenuation map over (Rs, Cs) (the paper's Fig. 11)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ..shunt import Plant, ShuntDesign, instability_threshold, rc_impedance
from ..shunt.stability import wide_grid_impedance

__all__ = ["plot_receptance", "plot_attenuation_map"]


def _axes(ax):
    if ax is None:
        fig = Figure(figsize=(6.4, 4.2), layout="constrained")
        return fig, fig.add_subplot()
    return ax.figure, ax


def plot_receptance(plant: Plant, design: ShuntDesign, *, ax=None, span: float = 3.0):
    """|m·G_open| and |m·G_RC| [dB re 1 s²] against frequency [Hz]."""
    fig, ax = _axes(ax)
    omega = np.geomspace(plant.omega0 / span, plant.omega0 * span, 1500)
    g_open = plant.receptance(omega)
    g_rc = plant.receptance(omega, lambda s: rc_impedance(s, design.Rs, design.Cs))
    f = omega / (2 * math.pi)
    ax.semilogx(f, 20 * np.log10(np.abs(g_open)), label="open terminals")
    ax.semilogx(f, 20 * np.log10(np.abs(g_rc)),
                label=f"RC shunt: Rs = {design.Rs:.4g} Ω, Cs = {design.Cs:.4g} F "
                      f"({design.attenuation_db:.1f} dB)")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|m G| [dB re 1 s²]")
    ax.set_title(f"model {design.model}: mass-normalised receptance")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return fig


def plot_attenuation_map(plant: Plant, design: ShuntDesign, *, ax=None, rs_span: float = 0.08,
                         cs_span: float = 0.5, points: int = 61):
    """Contour map of attenuation [dB] over (Rs [Ω], Cs [F]) around the optimum, marked."""
    fig, ax = _axes(ax)
    rs = np.linspace(min(design.Rs - rs_span, design.Rs_instability - 0.1 * rs_span),
                     design.Rs + rs_span, points)
    cs = design.Cs * np.geomspace(1 - cs_span, 1 + cs_span, points)
    open_pk = plant.open_peak().value
    grid = wide_grid_impedance(plant.model, plant.theta)
    att = np.full((points, points), np.nan)
    limit = np.empty(points)
    for j, c in enumerate(cs):
        limit[j] = instability_threshold(plant.model, plant.theta, c, grid=grid, refine=False)
        for i, r in enumerate(rs):
            if r > limit[j]:
                att[j, i] = 20 * math.log10(plant.rc_peak_fast(r, c) / open_pk)
    levels = np.arange(math.floor(np.nanmin(att)), min(0.0, math.ceil(np.nanmax(att))) + 1, 1.0)
    cont = ax.contour(rs, cs, att, levels=levels, cmap="viridis")
    ax.clabel(cont, fontsize=7, fmt="%.0f")
    ax.plot(limit, cs, color="crimson", lw=1, ls="--", label="stability limit")
    ax.plot(design.Rs, design.Cs, "k*", ms=10, label=f"optimum {design.attenuation_db:.1f} dB")
    ax.set_xlabel("Rs [Ω]")
    ax.set_ylabel("Cs [F]")
    ax.set_title(f"model {design.model}: attenuation [dB]")
    ax.legend(loc="upper right", fontsize=8)
    return fig
