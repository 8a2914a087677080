# %% [markdown]
# # Quickstart: from a measured admittance to parameters, uncertainty and a shunt
#
# The bundled recording is simulated from the paper's Table 5 (NL coil model, 5 rings) with 0.2 %
# complex noise, 2000 log-spaced points over 10..1e5 rad/s, so the truth is known. Replace
# `load_paper_bench()` with `be.read("your_file.zma")` for a recording of your own.
#
# The sampler budget below (`MAX_STEPS`) is cut short so the notebook runs in about a minute: the
# posterior is then flagged *not converged* (a warning says so). Use the default budget
# (`max_steps=None`, 20000 steps with the stopping rule) for numbers you mean to trust.

# %%
import warnings

import numpy as np

import bayes_emt as be

MAX_STEPS = 200  # a demonstration budget; None runs to the convergence rule

meas = be.load_paper_bench()
print(f"{meas.n_points} points, {meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz "
      f"({meas.omega[0]:.4g}..{meas.omega[-1]:.4g} rad/s)")

# %% [markdown]
# ## A deterministic fit: no initial guess needed
# `be.fit` finds its own start (a Levy linearisation) and runs the paper's two-step weighted least
# squares. Standard errors come from the Jacobian.

# %%
fit = be.fit(meas, "UD")
print(fit.summary())

# %% [markdown]
# ## The posterior by emcee, started from the fit

# %%
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    post = be.sample(meas, fit=fit, seed=1, max_steps=MAX_STEPS, progress=False)
print(("converged: " if post.converged else "NOT converged: ") + post.message)
for w in caught:
    print("warning:", w.message)
print(post.summary())

# %% [markdown]
# ## The optimal RC shunt for the fitted model (H∞ design)

# %%
design = be.design_shunt(fit)
print(f"Rs = {design.Rs:.4f} ohm, Cs = {design.Cs:.4f} F, peak attenuation {design.attenuation_db:.1f} dB")

# %% [markdown]
# ## Bode plot with the posterior's 90 % predictive band

# %%
from bayes_emt.plotting.posterior import plot_bode_bands  # noqa: E402

fig = plot_bode_bands(post, n_draws=50)
assert np.isfinite(design.attenuation_db) and post.n_steps == (MAX_STEPS or post.n_steps)
