"""Posterior plots: corner plot, Bode plot with posterior-predictive bands, trace with τ history.

Each function takes a :class:`~bayes_emt.inference.posterior.Posterior`, builds a
``matplotlib.figure.Figure`` (no pyplot state, never ``show``) and returns it.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..inference.posterior import Posterior

__all__ = ["plot_corner", "plot_bode_bands", "plot_trace"]


def _columns(post: Posterior, names, log_positive: bool):
    names = list(names or post.names)
    unknown = [n for n in names if n not in post.names]
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown}; this posterior has {list(post.names)}")
    idx = [post.names.index(n) for n in names]
    labels, logs = [], []
    for n in names:
        spec = post.likelihood.params[n]
        use_log = log_positive and spec.transform == "log"
        logs.append(use_log)
        labels.append(f"log10 {n} [{spec.unit}]" if use_log else f"{n} [{spec.unit}]")
    return names, idx, labels, np.array(logs)


def plot_corner(post: Posterior, *, names: list[str] | None = None, log_positive: bool = True,
                prob: float = 0.9) -> Figure:
    """``corner.corner`` of the kept draws with the median and central ``prob`` interval marked.

    Parameters
    ----------
    post : the posterior.
    names : parameters to show (default: all, noise scales included).
    log_positive : plot log10 of positive (log-sampled) parameters, which span decades.
    prob : probability of the marked central interval.
    """
    import corner

    names, idx, labels, logs = _columns(post, names, log_positive)
    x = post.flat()[:, idx].copy()
    x[:, logs] = np.log10(x[:, logs])
    fig = Figure(figsize=(1.9 * len(names) + 1, 1.9 * len(names) + 1))
    corner.corner(x, labels=labels, quantiles=[(1 - prob) / 2, 0.5, (1 + prob) / 2], show_titles=False,
                  fig=fig, label_kwargs={"fontsize": 8})
    fig.suptitle(f"model {post.model.label}: posterior ({x.shape[0]} draws; lines: median, "
                 f"{prob:.0%} interval)", fontsize=9)
    return fig


def plot_bode_bands(post: Posterior, *, n_draws: int = 400, prob: float = 0.9, seed: int = 0,
                    ax=None) -> Figure:
    """|Z| [Ω] and phase [deg] against frequency [Hz]: data, posterior median, and central ``prob``
    bands of the model (parameter uncertainty) and of the posterior predictive (model + noise);
    under each, the same relative to the posterior median (|Z| in %, phase in deg), where bands
    of a fraction of a percent become visible.

    Parameters
    ----------
    post : the posterior.
    n_draws : posterior draws used for the bands.
    prob : probability of the central bands.
    seed : seed of the draw subset and of the predictive noise.
    ax : optional four axes ``(|Z|, |Z| deviation, phase, phase deviation)`` to draw into.
    """
    meas = post.likelihood.meas
    Ym, Yp = post.predictive(n_draws, seed)
    if ax is None:
        fig = Figure(figsize=(7.5, 8.0), layout="constrained")
        axes = fig.subplots(4, 1, sharex=True, height_ratios=[3, 1.4, 3, 1.4])
    else:
        axes = list(ax)
        fig = axes[0].figure
    f = meas.f_hz
    lo_q, hi_q = (1 - prob) / 2, (1 + prob) / 2
    mag = (lambda y: np.abs(1 / y), lambda y, ref: 100 * (np.abs(1 / y) / np.abs(1 / ref) - 1),
           "|Z| [Ω]", "Δ|Z| [%]")
    pha = (lambda y: np.degrees(np.angle(1 / y)), lambda y, ref: np.degrees(np.angle(ref / y)),
           "phase of Z [deg]", "Δphase [deg]")
    Ymed = np.median(Ym.real, axis=0) + 1j * np.median(Ym.imag, axis=0)
    for (ax_abs, ax_dev), (fn, dev, unit, dunit) in zip((axes[0:2], axes[2:4]), (mag, pha), strict=True):
        for ax_, g, lab in ((ax_abs, fn, unit), (ax_dev, lambda y, d=dev: d(y, Ymed), dunit)):
            ax_.fill_between(f, *np.quantile(g(Yp), [lo_q, hi_q], axis=0), color="tab:orange", alpha=0.35,
                             lw=0, label=f"posterior predictive {prob:.0%}")
            ax_.fill_between(f, *np.quantile(g(Ym), [lo_q, hi_q], axis=0), color="tab:red", alpha=0.6, lw=0,
                             label=f"model {prob:.0%}")
            ax_.plot(f, g(meas.Y), ".", ms=2, color="k", label="data")
            ax_.plot(f, g(Ymed), "-", lw=0.8, color="tab:red", label="posterior median")
            ax_.set_ylabel(lab)
            ax_.grid(True, which="both", alpha=0.3)
    axes[0].set_xscale("log")
    axes[0].set_yscale("log")
    axes[-1].set_xlabel("frequency [Hz]")
    axes[0].set_title(f"model {post.model.label}: data and posterior bands")
    axes[0].legend(fontsize=8)
    return fig


def plot_trace(post: Posterior, *, names: list[str] | None = None, log_positive: bool = True,
               max_walkers: int = 16) -> Figure:
    """Kept draws against sampler step for each parameter (one line per walker), the log
    posterior, and the τ_max estimate at every stopping-rule check against the ``n/50`` line
    (τ below that line: the chain is long enough to trust τ).

    Parameters
    ----------
    post : the posterior.
    names : parameters to show (default: all).
    log_positive : plot log10 of positive (log-sampled) parameters.
    max_walkers : at most this many walkers are drawn (evenly chosen).
    """
    names, idx, labels, logs = _columns(post, names, log_positive)
    rows = len(names) + 2
    fig = Figure(figsize=(7.5, 1.3 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=False)
    walkers = np.unique(np.linspace(0, post.n_walkers - 1, min(max_walkers, post.n_walkers)).astype(int))
    steps = post.steps
    for ax, j, label, lg in zip(axes, idx, labels, logs, strict=False):
        y = post.draws[walkers, :, j]
        ax.plot(steps, (np.log10(y) if lg else y).T, lw=0.5, alpha=0.6)
        ax.set_ylabel(label, fontsize=7)
    axes[-2].plot(steps, post.log_prob[walkers].T, lw=0.5, alpha=0.6)
    axes[-2].set_ylabel("log posterior", fontsize=7)
    axes[-2].set_xlabel(f"step (burn-in {post.burn}, thin {post.thin})")
    for ax in axes[:-1]:
        ax.set_xlim(0, post.n_steps)
    hist = [h for h in post.history if "tau_max" in h]
    if hist:
        n = np.array([h["step"] for h in hist], float)
        axes[-1].plot(n, [h["tau_max"] for h in hist], "o-", label="τ_max estimate")
        settings = dict(post.settings)
        mult = float(settings.get("min_tau_multiple", 50.0))
        axes[-1].plot(n, n / mult, "k--", lw=0.8, label=f"n / {mult:g}")
        axes[-1].legend(fontsize=7)
    axes[-1].set_xlabel("step")
    axes[-1].set_ylabel("τ [steps]", fontsize=7)
    axes[0].set_title(f"model {post.model.label}: {'converged' if post.converged else 'NOT converged'}, "
                      f"{post.n_steps} steps × {post.n_walkers} walkers")
    return fig
