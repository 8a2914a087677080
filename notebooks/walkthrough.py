# %% [markdown]
# # bayes_emt walkthrough
# A notebook in the percent format (open it with Jupyter + jupytext, VS Code or Spyder; or run it
# as a script: `.venv/bin/python notebooks/walkthrough.py`). It goes from a measured admittance to
# parameters with uncertainty and a shunt design, on the bundled data (simulated from the paper's
# Table 5) — swap in `read_measurement("your_file.zma")` for a recording of your own.

# %%
import numpy as np

from bayes_emt import build_model
from bayes_emt.io.datasets import load_paper_bench
from bayes_emt.estimation.fitting import fit_admittance
from bayes_emt.shunt import design_rc_shunt

meas = load_paper_bench()
print(meas.n_points, "points,", meas.f_hz[0], "..", meas.f_hz[-1], "Hz")

# %% [markdown]
# ## Deterministic fits: no initial guess needed

# %%
fits = {name: fit_admittance(meas, build_model(name)) for name in ("I", "UD", "NL")}
for fit in fits.values():
    print(f"{fit.model.label:6s} rms relative residual {fit.rms_rel_residual:.4f}")
nl = fits["NL"]
for (name, value), se in zip(nl.parameters.items(), nl.stderr.values(), strict=True):
    print(f"  {name:7s} {value:.4g} ± {se:.2g}")

# %% [markdown]
# ## The optimal RC shunt for the best model

# %%
d = design_rc_shunt(nl.model, nl.theta)
print(f"Rs = {d.Rs:.4f} ohm, Cs = {d.Cs:.4f} F, {d.attenuation_db:.1f} dB; "
      f"unstable below Rs = {d.Rs_instability:.4f} ohm")

# %% [markdown]
# ## The posterior (about two minutes on two cores)
# ```python
# from bayes_emt.inference.sampling import sample_posterior
# post = sample_posterior(meas, nl.model, fit=nl, seed=0)
# post.save("nl_posterior.nc")      # an ArviZ DataTree: az.from_netcdf("nl_posterior.nc")
# ```
assert np.isfinite(d.attenuation_db)
