"""Plots of a shunt designed under uncertainty (:class:`~bayes_emt.shunt.robust.RobustShunt`):
gain curves of the nominal and robust shunts with posterior bands, the distributions of the
attenuation and of each draw's optimal Rs and Cs, and the stability boundary in the (Rs, Cs) plane
with the draws. Each function takes the result (and, where it draws a single panel, an optional ``ax``) and
returns the figure.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..shunt import rc_impedance, receptance
from . import figure_axes

__all__ = ["plot_gain_bands", "plot_attenuation_distributions", "plot_stability_boundary"]

_COLOURS = {"nominal": "tab:blue", "robust": "tab:red", "open": "k"}


def _axes(ax, size=(6.8, 4.4)):
    if ax is None:
        fig = Figure(figsize=size, layout="constrained")
        return fig, fig.add_subplot()
    return ax.figure, ax


def _held_draws(res, limit, seed=0):
    """Per group: a subset (at most ``limit`` in all, in proportion) of its held-back draws."""
    rng = np.random.default_rng(seed)
    total = int(res.held.sum())
    off = np.cumsum([0] + [g.n for g in res.groups])
    out = []
    for i, g in enumerate(res.groups):
        idx = np.flatnonzero(res.held[off[i] : off[i + 1]])
        k = min(idx.size, max(1, int(round(limit * idx.size / max(total, 1))))) if idx.size else 0
        out.append((g, g.thetas[np.sort(rng.choice(idx, size=k, replace=False))] if k else None))
    return out


def plot_gain_bands(res, *, draws: int = 200, span: float = 2.0) -> Figure:
    """``|m·G(jω)|`` [dB re 1 s²] (eq. 50) of the open terminals, the nominal and the robust shunt
    on held-back draws: median and 5–95 % band against frequency [Hz] (top), and the same relative
    to the nominal shunt's median curve, around the shunted peaks (bottom).

    Parameters
    ----------
    res : the result. draws : held-back draws drawn (at most).
    span : frequency range ``ω0/span .. ω0·span`` around the median ω0.
    """
    fig = Figure(figsize=(6.8, 6.4), layout="constrained")
    top, bottom = fig.subplots(2, 1, height_ratios=(3, 2))
    sets = [(g, th) for g, th in _held_draws(res, draws) if th is not None]
    w0 = float(np.median(np.concatenate([g.model.mechanics(th)[1] for g, th in sets])))
    omega = np.geomspace(w0 / span, w0 * span, 800)
    f = omega / (2 * math.pi)
    curves = {"open": None, "nominal": res.nominal, "robust": res.robust}
    bands = {}
    for name, on in curves.items():
        mags = []
        for g, th in sets:
            zs = None if on is None else (lambda s, on=on: rc_impedance(s, on.Rs, on.Cs))
            mags.append(20 * np.log10(np.abs(receptance(g.model, th, omega, zs))))
        bands[name] = np.concatenate(mags, axis=0)
    ref = np.median(bands["nominal"], axis=0)
    near = (omega > w0 / 1.6) & (omega < w0 * 1.6)
    for name, on in curves.items():
        lo, med, hi = np.quantile(bands[name], [0.05, 0.5, 0.95], axis=0)
        label = "open terminals" if on is None else f"{name}: Rs = {on.Rs:.5f} Ω, Cs = {on.Cs:.4g} F"
        top.semilogx(f, med, color=_COLOURS[name], lw=1.2, label=label)
        top.fill_between(f, lo, hi, color=_COLOURS[name], alpha=0.25, lw=0)
        if on is not None:
            bottom.semilogx(f[near], med[near] - ref[near], color=_COLOURS[name], lw=1.2)
            bottom.fill_between(f[near], lo[near] - ref[near], hi[near] - ref[near], color=_COLOURS[name],
                                alpha=0.25, lw=0)
    top.set_ylabel("|m G| [dB re 1 s²]")
    top.set_title(f"receptance on {sum(th.shape[0] for _, th in sets)} held-back draws: median, 5–95 % band")
    top.legend(fontsize=8)
    bottom.set_xlabel("frequency [Hz]")
    bottom.set_ylabel("relative to nominal median [dB]")
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    return fig


def plot_attenuation_distributions(res, *, bins: int = 40) -> Figure:
    """Histograms: attenuation [dB] of the nominal and robust shunts on the held-back draws and of
    each draw's own optimum; each draw's optimal Rs [Ω] and Cs [F] with the two shunts marked."""
    fig = Figure(figsize=(12.0, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    ax = axes[0]
    held = res.held
    series = [("each draw's own optimum", res.optimum_attenuation[held], "0.6"),
              ("nominal", res.nominal.attenuation[held], _COLOURS["nominal"]),
              ("robust", res.robust.attenuation[held], _COLOURS["robust"])]
    finite = np.concatenate([a[np.isfinite(a)] for _, a, _ in series])
    edges = np.linspace(finite.min(), finite.max(), bins + 1) if finite.size else bins
    for label, a, colour in series:
        unstable = int(np.count_nonzero(~np.isfinite(a)))
        extra = f", {unstable} unstable" if unstable else ""
        ax.hist(a[np.isfinite(a)], bins=edges, histtype="step", color=colour, lw=1.3, label=f"{label}{extra}")
    ax.set_xlabel("attenuation [dB] (held-back draws)")
    ax.set_ylabel("draws")
    ax.legend(fontsize=7)
    panels = ((axes[1], res.optimum_Rs, "Rs", "Ω"), (axes[2], res.optimum_Cs, "Cs", "F"))
    for ax, values, name, unit in panels:
        for g, grp in enumerate(res.groups):
            sel = res.group == g
            ax.hist(values[sel], bins=bins, alpha=0.5, label=f"optimum per draw, {grp.label}")
        for on in (res.nominal, res.robust):
            ax.axvline(getattr(on, name), color=_COLOURS[on.name], lw=1.5, label=on.name)
        ax.set_xlabel(f"{name} [{unit}]")
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.legend(fontsize=7)
    fig.suptitle("shunt design under uncertainty: distributions over posterior draws")
    return fig


def plot_stability_boundary(res, *, ax=None) -> Figure:
    """The (Rs [Ω], Cs [F]) plane: each draw's optimum, the instability threshold Rs(Cs) over the
    draws (median and largest; unstable to the left), and the nominal and robust shunts."""
    if not res.boundary:
        raise ValueError("the result holds no stability-boundary data: design with boundary_points > 0")
    fig, ax = figure_axes(ax, (6.8, 4.4))
    cs = res.boundary["Cs"]
    for g, grp in enumerate(res.groups):
        sel = res.group == g
        pts = ax.scatter(res.optimum_Rs[sel], res.optimum_Cs[sel], s=4, alpha=0.4,
                         label=f"optimum per draw, {grp.label}")
        b = res.boundary.get(grp.label)
        if b is not None:
            colour = pts.get_facecolor()[0]
            ax.plot(b["median"], cs, color=colour, ls="--", lw=1.0,
                    label=f"threshold, median draw ({grp.label})")
            ax.plot(b["max"], cs, color=colour, ls=":", lw=1.2,
                    label=f"threshold, most demanding draw ({grp.label})")
    for on in (res.nominal, res.robust):
        ax.plot(on.Rs, on.Cs, marker="*", ms=12, color=_COLOURS[on.name], ls="none",
                label=f"{on.name} ({np.min(on.margin):.4f} Ω from the nearest threshold)")
    ax.set_xlabel("Rs [Ω]")
    ax.set_ylabel("Cs [F]")
    ax.set_title("stability boundary (loop unstable to the left of a threshold)")
    ax.legend(fontsize=7)
    return fig
