"""Discrepancy-discovery figures: residuals before and after with the bands shaded, and a Bode overlay."""

from __future__ import annotations

from ..models.residual import relative_residual
from . import figure_axes

__all__ = ["plot_residuals", "plot_bode_overlay"]


def _bands(ax, diagnosis):
    for f in diagnosis.findings:
        ax.axvspan(
            f.band.lo / 6.283185307179586, f.band.hi / 6.283185307179586, color="tab:green", alpha=0.12
        )
    for u in diagnosis.unexplained:
        lo, hi = u["band_hz"]
        ax.axvspan(lo, hi, color="tab:red", alpha=0.12)


def plot_residuals(diagnosis, meas, ax=None):
    """Relative residuals ``(Y_model − Y)/|Y|`` [%] over frequency [Hz], real and imaginary parts,
    for the starting and the final model; found bands shaded green, unexplained bands red.

    Parameters
    ----------
    diagnosis : a :class:`~bayes_emt.discovery.Diagnosis`; meas : the measurement it diagnosed.
    ax : two matplotlib axes (real, imaginary) to draw into (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    fig, ax = figure_axes(ax, (8.0, 5.5), rows=2)
    f = meas.f_hz
    for fit, label, color in (
        (diagnosis.baseline_fit, f"start: {diagnosis.baseline_model}", "tab:gray"),
        (diagnosis.final_fit, f"final: {diagnosis.final_model}", "tab:blue"),
    ):
        with np.errstate(all="ignore"):
            r = relative_residual(fit.model, fit.theta, meas)
        ax[0].plot(f, 100 * r.real, lw=0.8, color=color, label=label)
        ax[1].plot(f, 100 * r.imag, lw=0.8, color=color, label=label)
    for a, part in zip(ax, ("real", "imaginary"), strict=True):
        _bands(a, diagnosis)
        a.axhline(0.0, color="k", lw=0.5)
        a.set_xscale("log")
        a.set_ylabel(f"{part} part of residual [% of |Y|]")
    ax[1].set_xlabel("frequency [Hz]")
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"{diagnosis.source}: residuals (green: explained band, red: unexplained)", fontsize=9)
    return fig


def plot_bode_overlay(diagnosis, meas, ax=None):
    """|Z| [Ω] and phase [deg] of the data, the starting and the final model over frequency [Hz].

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    fig, ax = figure_axes(ax, (8.0, 5.5), rows=2)
    f = meas.f_hz
    Z = 1.0 / meas.Y
    ax[0].plot(f, np.abs(Z), ".", ms=2, color="k", label="data")
    ax[1].plot(f, np.degrees(np.angle(Z)), ".", ms=2, color="k", label="data")
    for fit, label, color in (
        (diagnosis.baseline_fit, f"start: {diagnosis.baseline_model}", "tab:gray"),
        (diagnosis.final_fit, f"final: {diagnosis.final_model}", "tab:blue"),
    ):
        Zm = fit.model.bind(meas.omega).impedance(meas.omega, fit.theta)
        ax[0].plot(f, np.abs(Zm), lw=1, color=color, label=label)
        ax[1].plot(f, np.degrees(np.angle(Zm)), lw=1, color=color, label=label)
    for a in ax:
        _bands(a, diagnosis)
        a.set_xscale("log")
    ax[0].set_yscale("log")
    ax[0].set_ylabel("|Z| [ohm]")
    ax[1].set_ylabel("phase of Z [deg]")
    ax[1].set_xlabel("frequency [Hz]")
    ax[0].legend(fontsize=8)
    return fig
