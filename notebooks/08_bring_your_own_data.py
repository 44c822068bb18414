# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 08 · Bring your own data
#
# A record is two files (conventions §5): `NAME.json` (site, table axes, instrument axes, mode, nominal scale
# factor) and `NAME.csv` (`time_s`, one `angle_<axis>_deg` per table axis, `current_mA`, optional
# `rate_<axis>_dps`). Here we write one by hand — a polar tumble of a floated gyro, as a lab's data logger would —
# load it, see what a broken file looks like, fit it, and then teach gyrojax an effect of our own.

# %%
import json
import shutil
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import Image

import gyrojax as gj
from gyrojax import report
from gyrojax.inference.identify import fit
from gyrojax.physics.effects import Effect, register

# %% [markdown]
# ## The metadata
# Polar table axis at latitude φ (East–North–Up); at zero angle the input axis points East, the output axis along
# the table axis, and the spin axis completes the right-handed triad (IA × OA = SA).

# %%
lat = 40.0
phi = np.deg2rad(lat)
polar = [0.0, np.cos(phi), np.sin(phi)]
ia, oa = np.array([1.0, 0.0, 0.0]), np.array(polar)
sa = np.cross(ia, oa)
S = 17.0  # deg/h per mA
meta = {
    "format": "gyrojax-record-1",
    "name": "lab-tumble",
    "site": {"latitude_deg": lat, "gravity_mps2": 9.8016},
    "table": {"axes": [{"name": "polar", "axis_enu": polar}]},
    "instrument": {"kind": "sdf-gyro", "ia": ia.tolist(), "oa": oa.tolist(), "sa": sa.tolist()},
    "mode": "rebalance",
    "scale_factor_deg_per_h_per_mA": S,
}

# %% [markdown]
# ## The data
# The table turns at 10 Earth rates (150 °/h) for one revolution, one sample every 10 s. Our "gyro" drifts as
# D_F + D_I a_I + D_S a_S (a_I = −g cosφ sinθ, a_S = g cosφ cosθ, Hu 3-12) **plus a g-sensitivity that grows in
# time**, D_IT · a_I · t — something the built-in library does not name. The IA stays normal to the Earth's axis,
# so the rebalance current carries drift only.

# %%
rng = np.random.default_rng(0)
g = meta["site"]["gravity_mps2"] / 9.80665  # specific force in g
t = np.arange(0.0, 2.4 * 3600, 10.0)
theta = 150.0 / 3600 * t  # deg
a_I = -g * np.cos(phi) * np.sin(np.deg2rad(theta))
a_S = g * np.cos(phi) * np.cos(np.deg2rad(theta))
D_F, D_I, D_S, D_IT = 0.3, 0.5, -0.2, 0.04  # deg/h, deg/h/g, deg/h/g, deg/h/g/h
drift = D_F + D_I * a_I + D_S * a_S + D_IT * a_I * (t / 3600) + 0.003 * rng.standard_normal(t.size)
df = pd.DataFrame(
    {
        "time_s": t,
        "angle_polar_deg": theta,
        "rate_polar_dps": 150.0 / 3600 / 3600 * np.ones_like(t),
        "current_mA": drift / S,
    }
)
lab = Path("lab")
lab.mkdir(exist_ok=True)
df.to_csv(lab / "lab-tumble.csv", index=False)
(lab / "lab-tumble.json").write_text(json.dumps(meta, indent=1))
df.head()

# %% [markdown]
# ## Load it — and see what a broken copy says
# `load_record` validates everything first; errors name the file and key (or the row and column).

# %%
rec = gj.load_record(lab / "lab-tumble")
print(rec.name, rec.kind, rec.mode, len(rec.time_s), "samples")

broken = Path("broken")
broken.mkdir(exist_ok=True)
bad = json.loads(json.dumps(meta))
bad["name"] = "lab-tumble"
bad["instrument"]["sa"] = (-sa).tolist()  # a left-handed triad
(broken / "lab-tumble.json").write_text(json.dumps(bad))
shutil.copy(lab / "lab-tumble.csv", broken / "lab-tumble.csv")
try:
    gj.load_record(broken / "lab-tumble")
except gj.RecordError as e:  # one error naming the file and the key
    print(type(e).__name__, ":", e)

# also a bad value in the CSV
rows = (lab / "lab-tumble.csv").read_text().splitlines()
rows[5] = rows[5].replace(rows[5].split(",")[-1], "oops")
(broken / "lab-tumble.csv").write_text("\n".join(rows) + "\n")
(broken / "lab-tumble.json").write_text(json.dumps(meta))
try:
    gj.load_record(broken / "lab-tumble")
except gj.RecordError as e:
    print(type(e).__name__, ":", e)

# %% [markdown]
# ## Fit it with the built-in effects

# %%
res = fit([rec], ["D_F", "D_I", "D_S"])
print(report.fit_table(res))

# %% [markdown]
# The residual is well above the noise floor (0.003 deg/h): something is missing.
#
# ## Add an effect of our own
# An `Effect` names its coefficients and units and gives its contribution to the drift (deg/h) from the
# instrument inputs `x` (a_I, a_O, a_S in g; w_I … in deg/h; t_h in hours) and the coefficients `c`.

# %%
register(
    Effect(
        name="D_I_trend",
        coefficients=("D_IT",),
        units=("deg/h/g/h",),
        kinds=("sdf-gyro",),
        contribution=lambda x, c: c[0] * x["a_I"] * x["t_h"],
        description="g-sensitivity that drifts in time",
        reference="user",
    )
)
res2 = fit([rec], ["D_F", "D_I", "D_S", "D_I_trend"])
print(report.fit_table(res2))
print("truth: D_F 0.3, D_I 0.5, D_S -0.2, D_IT 0.04")

# %%
fig, axs = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
for ax, r, lbl in zip(axs, (res, res2), ("D_F, D_I, D_S", "+ D_I_trend (user-defined)")):
    ax.plot(rec.angles_deg[: len(r.residuals[0]), 0], r.residuals[0], ".", ms=2)
    ax.set_title(f"{lbl}: residual RMS {r.residual_rms:.4f} deg/h", fontsize=9)
    ax.set_ylabel("deg/h")
axs[-1].set_xlabel("table angle (deg)")
fig.tight_layout()
fig.savefig("08_final.png")
Image("08_final.png")
