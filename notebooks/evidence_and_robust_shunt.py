# %% [markdown]
# # Which model, and a shunt that survives the uncertainty
#
# On the bundled recording (simulated from the paper's NL model, Table 5, 0.2 % noise) we ask two
# questions an engineer has before building a shunt damper:
#
# 1. **Which coil model do the data support?** The log evidence log Z [nats] of each candidate, by
#    bridge sampling on its emcee posterior with the Laplace approximation beside it, and Bayes
#    factors on Kass & Raftery's scale. (`bayes-emt compare` adds nested sampling, the second,
#    independent estimator; it is left out here to keep the notebook short.)
# 2. **Which RC shunt?** Every posterior draw has its own H∞-optimal (Rs, Cs) and its own stability
#    threshold in Rs. The robust shunt minimises the CVaR of the attenuation over draws subject to
#    P(unstable) ≤ 1e-3, chosen on half the draws and reported on the other half.

# %%
import warnings

import bayes_emt as be

meas = be.load_paper_bench()
print(f"{meas.n_points} points, {meas.f_hz[0]:.4g}..{meas.f_hz[-1]:.4g} Hz")

# %% [markdown]
# ## Evidence of three coil models
# Each model's posterior is sampled to the convergence rule (the sampler starts at the posterior
# mode; tens of seconds per model here).

# %%
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    cmp = be.compare(meas, ["I", "UD", "NL(5)"], methods=("laplace", "bridge"), loo=False, sensitivity=False,
                     seed=1)
print(cmp.summary())
print("preferred:", cmp.best)

# %% [markdown]
# ## The robust shunt over the preferred model's posterior

# %%
posterior = be.sample(meas, "NL(5)", seed=1, progress=False)
rob = be.robust_shunt(posterior, n_draws=1000, seed=0)
print(rob.summary())
