"""The figure of a T/S fit: |Z| and phase of the recording with the fitted curve, its 90 %
posterior predictive band and the bench's own fit where the file carried one, and the residual,
drawn from the result's saved ``curve`` alone (:mod:`bayes_emt.thiele_small.curve`), as REW,
Speakerbench and VituixCAD show an impedance fit."""

from __future__ import annotations

import numpy as np

from . import figure_axes

__all__ = ["plot_ts_fit"]


def plot_ts_fit(ts, *, ax=None):
    """|Z| [Ω], phase [deg] and the relative residual of |Z| [%] against frequency [Hz].

    Parameters
    ----------
    ts : a :class:`~bayes_emt.thiele_small.ThieleSmall` with a ``curve`` (``thiele_small`` sets it),
        or the ``curve`` dict itself.
    ax : optional three axes ``(|Z|, phase, residual)`` to draw into.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        When the result carries no curve (read from an older JSON file).
    """
    curve = ts if isinstance(ts, dict) else getattr(ts, "curve", None)
    if not curve:
        raise ValueError("this T/S result carries no fitted curve (saved by an older version): rerun ts")
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(7.5, 7.5), layout="constrained")
        axes = fig.subplots(3, 1, sharex=True, height_ratios=[3, 2, 1.3])
    else:
        fig, axes = figure_axes(ax, rows=3)
    a_mag, a_ph, a_res = axes
    f = np.asarray(curve["f_hz"], float)
    zd, zf = np.asarray(curve["data_abs_z_ohm"]), np.asarray(curve["fit_abs_z_ohm"])
    blo, bhi = (np.asarray(b, float) for b in curve["band_abs_z_ohm"])
    plo, phi = (np.asarray(b, float) for b in curve["band_phase_deg"])
    model = curve.get("model", "model")
    a_mag.fill_between(f, blo, bhi, color="tab:orange", alpha=0.35, lw=0, label="90 % posterior predictive")
    a_mag.plot(f, zd, ".", ms=2.5, color="k", label="recording")
    a_mag.plot(f, zf, "-", lw=1.0, color="tab:red", label=f"fit ({model}, posterior median)")
    bench = curve.get("bench")
    if bench:
        a_mag.plot(bench["f_hz"], bench["abs_z_ohm"], "--", lw=1.0, color="tab:blue",
                   label=f"{bench.get('label', 'bench')}'s own fit (from the file)")
    a_mag.set_yscale("log")
    from matplotlib.ticker import LogLocator, ScalarFormatter

    # ohms as plain numbers: every integer step within a decade, 1-2-5 over more than one
    span = float(np.nanmax(zd) / np.nanmin(zd))
    a_mag.yaxis.set_major_formatter(ScalarFormatter())
    a_mag.yaxis.set_minor_locator(LogLocator(subs=(2.0, 3.0, 4.0, 6.0) if span < 10 else (2.0, 5.0)))
    a_mag.yaxis.set_minor_formatter(ScalarFormatter())
    a_mag.set_ylabel("|Z| [Ω]")
    a_mag.legend(fontsize=8, loc="best")
    a_ph.fill_between(f, plo, phi, color="tab:orange", alpha=0.35, lw=0)
    a_ph.plot(f, curve["data_phase_deg"], ".", ms=2.5, color="k")
    a_ph.plot(f, curve["fit_phase_deg"], "-", lw=1.0, color="tab:red")
    a_ph.set_ylabel("phase of Z [deg]")
    a_res.fill_between(f, 100 * (blo / zf - 1), 100 * (bhi / zf - 1), color="tab:orange", alpha=0.35, lw=0)
    a_res.plot(f, 100 * (zd / zf - 1), ".", ms=2.5, color="k")
    a_res.axhline(0.0, color="tab:red", lw=0.8)
    a_res.set_ylabel("|Z| data/fit − 1 [%]")
    a_res.set_xlabel("frequency [Hz]")
    for a in axes:
        a.set_xscale("log")
        a.grid(True, which="both", alpha=0.3)
    from pathlib import PurePath

    rms = 100 * float(curve.get("rms_rel_residual", float("nan")))
    a_mag.set_title(f"{PurePath(str(curve.get('source', ''))).name}: fit of {model} with its 90 % band "
                    f"(rms relative residual {rms:.2g} %)", fontsize=9)
    return fig
