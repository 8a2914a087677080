"""Posterior plots: corner plot, Bode plot with posterior-predictive bands, trace of τ."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..posterior import Posterior

__all__ = ["plot_corner", "plot_bode_bands"]


def plot_corner(post: Posterior, *, names: list[str] | None = None, log_positive: bool = True):
    """corner.corner of the kept draws (log10 of positive parameters by default, so parameters
    spanning decades are readable); returns the figure."""
    import corner

    names = list(names or post.names)
    idx = [post.names.index(n) for n in names]
    x = post.flat()[:, idx]
    labels = []
    for j, n in enumerate(names):
        spec = post.likelihood.params[n]
        if log_positive and spec.transform == "log":
            x[:, j] = np.log10(x[:, j])
            labels.append(f"log10 {n} [{spec.unit}]")
        else:
            labels.append(f"{n} [{spec.unit}]")
    fig = Figure(figsize=(2.0 * len(names), 2.0 * len(names)))
    corner.corner(x, labels=labels, quantiles=[0.05, 0.5, 0.95], show_titles=False, fig=fig,
                  label_kwargs={"fontsize": 8})
    return fig


def plot_bode_bands(post: Posterior, *, n_draws: int = 400, prob: float = 0.9, seed: int = 0, ax=None):
    """|Z| [Ω] and phase [deg] against frequency [Hz]: data, posterior median, and central
    ``prob`` bands of the model (epistemic) and of the posterior predictive (model + noise)."""
    lik = post.likelihood
    meas = lik.meas
    rng = np.random.default_rng(seed)
    flat = post.flat()
    take = flat[rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)]
    th, srel, sfl = lik.split(take)
    Ym = post.model.admittance(meas.omega, th)
    sig = lik.sigma(srel, sfl)
    Yp = Ym + sig * (rng.standard_normal(Ym.shape) + 1j * rng.standard_normal(Ym.shape))
    if ax is None:
        fig = Figure(figsize=(7.5, 6.0), layout="constrained")
        ax_mag, ax_ph = fig.subplots(2, 1, sharex=True)
    else:
        ax_mag, ax_ph = ax
        fig = ax_mag.figure
    f = meas.f_hz
    lo_q, hi_q = (1 - prob) / 2, 1 - (1 - prob) / 2
    for ax_, fn, unit in ((ax_mag, lambda y: np.abs(1 / y), "|Z| [Ω]"),
                          (ax_ph, lambda y: np.degrees(np.angle(1 / y)), "phase of Z [deg]")):
        pp = fn(Yp)
        mm = fn(Ym)
        ax_.fill_between(f, *np.quantile(pp, [lo_q, hi_q], axis=0), color="tab:orange", alpha=0.3,
                         lw=0, label=f"posterior predictive {prob:.0%}")
        ax_.fill_between(f, *np.quantile(mm, [lo_q, hi_q], axis=0), color="tab:red", alpha=0.6, lw=0,
                         label=f"model {prob:.0%}")
        ax_.plot(f, fn(meas.Y), ".", ms=2, color="k", label="data")
        ax_.plot(f, np.median(mm, axis=0), "-", lw=0.8, color="tab:red", label="posterior median")
        ax_.set_ylabel(unit)
        ax_.grid(True, which="both", alpha=0.3)
    ax_mag.set_xscale("log")
    ax_mag.set_yscale("log")
    ax_ph.set_xlabel("frequency [Hz]")
    ax_mag.set_title(f"model {post.model.label}: data and posterior bands")
    ax_mag.legend(fontsize=8)
    return fig
