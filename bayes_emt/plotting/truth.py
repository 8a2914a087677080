"""Credible intervals against independent references: one panel per parameter, one row of bars per
driver, each interval drawn as its error relative to the reference [%] (the reference is the
zero line), one colour per way of computing the interval."""

from __future__ import annotations

import math

from . import figure_axes

__all__ = ["plot_reference_intervals"]

_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e")


def plot_reference_intervals(rows: list[dict], *, columns: tuple[str, ...] | None = None,
                             parameters: tuple[str, ...] | None = None, title: str | None = None, ax=None):
    """Intervals as bars against their references.

    Parameters
    ----------
    rows : ``{"driver", "parameter", "reference", "columns": {name: {"value", "ci90": [lo, hi] |
        None}}}`` records (SI; one per driver and parameter).
    columns : which interval columns to draw, in order (default: every one found, in first-seen order).
    parameters : the panels, in order (default: every parameter found).
    title : the figure's title.
    ax : a sequence of axes, one per parameter (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not rows:
        raise ValueError("no rows to plot")
    params = list(parameters) if parameters else list(dict.fromkeys(r["parameter"] for r in rows))
    cols = list(columns) if columns else list(dict.fromkeys(c for r in rows for c in r["columns"]))
    drivers = list(dict.fromkeys(r["driver"] for r in rows))
    fig, axes = figure_axes(ax, size=(3.2 * len(params), 0.35 * len(drivers) + 1.6), rows=1)
    if len(params) > 1 and ax is None:
        fig.clear()
        axes = fig.subplots(1, len(params), sharey=True)
    axes = list(axes) if isinstance(axes, list | tuple) or hasattr(axes, "__len__") else [axes]
    step = 0.8 / max(len(cols), 1)
    for a, name in zip(axes, params, strict=True):
        labelled: set[str] = set()
        a.axvline(0.0, color="k", lw=0.8)
        for i, d in enumerate(drivers):
            r = next((x for x in rows if x["driver"] == d and x["parameter"] == name), None)
            if r is None or not r.get("reference"):
                continue
            ref = r["reference"]
            for j, c in enumerate(cols):
                e = r["columns"].get(c)
                if not e or e.get("value") is None or not math.isfinite(e["value"]):
                    continue
                y = i - 0.4 + step * (j + 0.5)
                v = 100.0 * (e["value"] / ref - 1)
                ci = e.get("ci90")
                if ci is not None:
                    lo, hi = (100.0 * (ci[0] / ref - 1), 100.0 * (ci[1] / ref - 1))
                    inside = lo <= 0.0 <= hi
                    a.plot([lo, hi], [y, y], color=_COLOURS[j % len(_COLOURS)], lw=3 if inside else 1.5,
                           solid_capstyle="butt")
                a.plot([v], [y], "o", ms=3, color=_COLOURS[j % len(_COLOURS)],
                       label=None if c in labelled else c)
                labelled.add(c)
        a.set_title(name)
        a.set_xlabel("error vs reference [%]")
        a.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(drivers)))
    axes[0].set_yticklabels(drivers, fontsize=7)
    axes[0].invert_yaxis()
    handles, labels = axes[0].get_legend_handles_labels()
    uniq = dict(zip(labels, handles, strict=True))
    if uniq:
        fig.legend(list(uniq.values()), list(uniq.keys()), loc="outside lower center", ncol=len(uniq),
                   fontsize=8, title="90 % interval (thick: holds the reference)", title_fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
