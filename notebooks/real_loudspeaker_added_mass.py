# %% [markdown]
# # A real loudspeaker and the added-mass pair
#
# A Dayton Audio LS10-44 10" woofer measured twice: in free air, and with 0.100 kg added to the
# cone (`../shared/realdata`, see its README; these files are not shipped with bayes_emt). From the
# admittance alone the model gives the mass-normalised quantities (ζ, ω0, φ̄); the added mass turns
# them into the physical moving mass m [kg], suspension stiffness k [N/m], damping c [N s/m] and
# force factor φ = Bl [N/A] (the added-mass method), here by a joint fit of both recordings.
#
# Set `BAYES_EMT_REALDATA` to the folder if it is not found next to the project.

# %%
import math
import os
from pathlib import Path

import bayes_emt as be
from bayes_emt.added_mass.fit import fit_added_mass
from bayes_emt.io.datasets import load_realdata


def find_realdata() -> Path | None:
    if os.environ.get("BAYES_EMT_REALDATA"):
        return Path(os.environ["BAYES_EMT_REALDATA"])
    for parent in [Path.cwd(), *Path.cwd().parents]:
        if (parent / "shared" / "realdata").is_dir():
            return parent / "shared" / "realdata"
    return None


REAL = find_realdata()
if REAL is None or not (REAL / "dayton_LS10-44_freeair_run2.txt").exists():
    raise FileNotFoundError("the real recordings (shared/realdata) are not here: set BAYES_EMT_REALDATA")
free = load_realdata(REAL, "dayton_LS10-44_freeair_run2.txt")
loaded = load_realdata(REAL, "dayton_LS10-44_added100g_run2.txt")
for m in (free, loaded):
    print(f"{Path(m.source).name}: {m.n_points} points, {m.f_hz[0]:.4g}..{m.f_hz[-1]:.4g} Hz")

# %% [markdown]
# ## Each recording on its own
# The resonance falls when mass is added: fs = ω0 / 2π.

# %%
fits = {name: be.fit(m, "UD") for name, m in (("free air", free), ("+0.100 kg", loaded))}
for name, f in fits.items():
    p = f.parameters
    print(f"{name:10s} fs = {p['omega0'] / (2 * math.pi):6.2f} Hz, zeta = {p['zeta']:.4f}, "
          f"R0 = {p['R0']:.3f} ohm, rms relative residual {f.rms_rel_residual:.3f}")

# %% [markdown]
# ## Both recordings jointly: the physical parameters
# One set of m, c, k, φ, R0 and coil parameters explains both files; Δm = +0.100 kg.

# %%
r = fit_added_mass(free, loaded, 0.100, be.build_model("UD"))
units = {"m": "kg", "c": "N s/m", "k": "N/m", "phi_raw": "N/A"}
for name, unit in units.items():
    print(f"{name:8s} {r.values[name]:10.4g} ± {r.stderr[name]:.2g} {unit}   "
          f"(two separate fits: {r.two_fit[name]:.4g} {unit})")
fs = math.sqrt(r.values["k"] / r.values["m"]) / (2 * math.pi)
print(f"free-air resonance from m and k: {fs:.2f} Hz")
assert 0.05 < r.values["m"] < 0.3 and 30 < fs < 50
