# %% [markdown]
# # bayes_emt walkthrough
# A notebook in the percent format (open it with Jupyter + jupytext, VS Code or Spyder; or run it
# as a script: `.venv/bin/python notebooks/walkthrough.py`). It goes from a measured admittance to
# parameters with uncertainty and a shunt design, on the bundled data (simulated from the paper's
# Table 5) — swap in `be.read("your_file.zma")` for a recording of your own.

# %%
import bayes_emt as be

meas = be.load_paper_bench()
print(meas.n_points, "points,", meas.f_hz[0], "..", meas.f_hz[-1], "Hz")

# %% [markdown]
# ## Deterministic fits: no initial guess needed

# %%
fits = {name: be.fit(meas, name) for name in ("I", "UD", "NL(5)")}
for fit in fits.values():
    print(f"{fit.model.label:6s} rms relative residual {fit.rms_rel_residual:.4f}")
nl = fits["NL(5)"]
for (name, value), se in zip(nl.parameters.items(), nl.stderr.values(), strict=True):
    print(f"  {name:7s} {value:.4g} ± {se:.2g}")

# %% [markdown]
# ## The optimal RC shunt for the best model

# %%
d = be.design_shunt(nl)
print(f"Rs = {d.Rs:.4f} ohm, Cs = {d.Cs:.4f} F, {d.attenuation_db:.1f} dB; "
      f"unstable below Rs = {d.Rs_instability:.4f} ohm")

# %% [markdown]
# ## The posterior (about two minutes on two cores)
# ```python
# post = be.sample(meas, fit=nl, seed=0)
# post.save("nl_posterior.nc")      # an ArviZ DataTree: az.from_netcdf("nl_posterior.nc")
# ```
assert d.attenuation_db < 0
