"""Relative residuals of one or more fits against frequency, with flagged bands shaded."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_residuals"]


def plot_residuals(meas, fits: Mapping[str, tuple], *, bands_hz: Sequence[tuple[float, float, str]] = (),
                   title: str | None = None, ax=None) -> Figure:
    """Real and imaginary parts of ``(Y_model − Y_meas) / |Y_meas|`` [%] against frequency [Hz].

    Parameters
    ----------
    meas : the :class:`~bayes_emt.measurement.Measurement`.
    fits : ``{label: (model, theta)}``, one line per entry.
    bands_hz : ``(lo, hi, label)`` frequency bands [Hz] to shade (e.g. a diagnosis' flagged bands).
    title : figure title.
    ax : optional two axes ``(real, imaginary)`` to draw into.
    """
    if ax is None:
        fig = Figure(figsize=(7.5, 5.0), layout="constrained")
        axes = fig.subplots(2, 1, sharex=True)
    else:
        axes = list(ax)
        fig = axes[0].figure
    f = meas.f_hz
    scale = np.abs(meas.Y)
    for label, (model, theta) in fits.items():
        r = 100.0 * (model.bind(meas.omega).admittance(meas.omega, theta) - meas.Y) / scale
        axes[0].plot(f, r.real, lw=0.7, label=label)
        axes[1].plot(f, r.imag, lw=0.7, label=label)
    for i, (lo, hi, label) in enumerate(bands_hz):
        for a in axes:
            a.axvspan(lo, hi, color="tab:red", alpha=0.18, lw=0,
                      label=label if (a is axes[0] and i < 6) else None)
    for a, part in zip(axes, ("real", "imaginary"), strict=True):
        a.set_ylabel(f"{part} part of ΔY/|Y| [%]")
        a.grid(True, which="both", alpha=0.3)
        a.axhline(0.0, color="k", lw=0.5)
    axes[0].set_xscale("log")
    axes[-1].set_xlabel("frequency [Hz]")
    axes[0].legend(fontsize=7, ncol=3)
    axes[0].set_title(title or "relative residuals of the fits", fontsize=9)
    return fig
