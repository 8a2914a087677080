"""Bar chart of log evidence per model and estimator, with error bars."""

from __future__ import annotations

import math

__all__ = ["plot_evidence"]

_METHODS = (("nested", "nested sampling"), ("bridge", "bridge sampling"), ("laplace", "Laplace (screen)"))


def plot_evidence(comparison, ax=None):
    """log Z − max log Z [nats] per model (groups) and estimator (bars), error bars one standard error.

    Parameters
    ----------
    comparison : a :class:`~bayes_emt.evidence.records.Comparison`.
    ax : matplotlib axes to draw into (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    import numpy as np

    if ax is None:
        fig, ax = plt.subplots(figsize=(max(5.0, 1.6 + 1.2 * len(comparison.models)), 4.0))
    else:
        fig = ax.figure
    models = list(comparison.models)
    finite = [m.log_evidence for m in models if math.isfinite(m.log_evidence)]
    ref = max(finite) if finite else 0.0
    width = 0.8 / len(_METHODS)
    x = np.arange(len(models))
    for j, (key, label) in enumerate(_METHODS):
        vals, errs = [], []
        for m in models:
            v = m.by_method.get(key, {})
            lz = v.get("log_evidence")
            vals.append(np.nan if lz is None else lz - ref)
            e = v.get("err")
            errs.append(0.0 if e is None else e)
        if np.all(np.isnan(vals)):
            continue
        ax.bar(x + (j - 1) * width, vals, width, yerr=errs, capsize=3, label=label)
    ax.set_yscale("symlog", linthresh=10.0)  # differences of 0.1 to 10,000 nats on one chart
    ax.axhline(0.0, color="k", lw=0.8)
    ax.axhline(-1.0, color="0.5", lw=0.8, ls="--", label="1 nat below the best")
    ax.set_xticks(x, [m.name for m in models])
    ax.set_ylabel("log Z − log Z$_{best}$ [nats]")
    ax.set_title(f"log evidence (best {comparison.best}: log Z = {ref:.1f} nats)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
