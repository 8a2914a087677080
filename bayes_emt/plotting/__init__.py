"""All of bayes_emt's matplotlib code (never imported by the package ``__init__``).

Functions take results and an optional ``ax``, reject unknown keywords, return the figure, and
never call ``plt.show()``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["save_figure", "figure_axes"]


def figure_axes(ax, size=(6.4, 4.4), rows: int = 1):
    """``(figure, axes)``: the caller's ``ax`` (one axis, or ``rows`` axes) and its figure, or a new
    constrained-layout figure of ``size`` [inch] with ``rows`` axes sharing x. The figure is not
    registered with pyplot, so it is freed with its last reference."""
    if ax is not None:
        return (ax.figure if rows == 1 else ax[0].figure), ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    if rows == 1:
        return fig, fig.add_subplot()
    return fig, fig.subplots(rows, 1, sharex=True)


def save_figure(fig, path: str | Path, dpi: int = 100) -> Path:
    """Write ``fig`` to ``path`` atomically (format from the suffix) and release its memory.

    A crash mid-write leaves the previous file, never half an image; the figure is closed after,
    whether or not the write succeeded, so a command that draws many figures does not accumulate them.
    """
    import matplotlib.pyplot as plt

    from .._atomic import atomic_path

    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    return path
