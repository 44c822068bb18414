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
# # 11 · An exact alias → diagnose → design the separating test → joint fit
#
# On a polar tumble the OA lies along the table axis, so a_I² + a_S² is the same in every position: a hidden
# D_SS·a_S² reads as −D_SS·a_I² plus a constant. The campaign cannot tell D_SS from D_II; `diagnose` says so and
# points to `gyrojax design --separate`, which designs by gradients a static test on the same table (positions,
# dwells, and how the gyro's case is turned on its mounting) that maximises the weaker of the two score-test powers
# of the joint fit. Simulating it and fitting both campaigns together resolves the alias.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

import gyrojax as gj
from gyrojax.inference.diagnose import diagnose
from gyrojax.inference.identify import fit
from gyrojax.planning.separate import separate

truth = {"coefficients": {"D_F": 0.5, "D_I": 0.2, "D_O": -0.1, "D_S": 0.05, "D_SS": 0.15}, "noise": {"white": 0.01}}
tumble = gj.simulate(gj.plans.tumble(revolutions=1.0, dt_s=60.0), truth, seed=5)
base = ["D_F", "D_I", "D_O", "D_S"]
d = diagnose(tumble, base)
c = next(c for c in d.candidates if c.name == "D_SS")
print("D_SS aliases:", c.aliases)
print("separated by:", *c.separated_by, sep="\n  ")

# %% [markdown]
# ## Design the follow-up test on the same table (2 h of dwell)

# %%
res, before = separate(tumble, "D_II", "D_SS", hours=2.0, n_positions=8, starts=1, steps=200)
s = res.summary()
print("power:", {k: round(v, 3) for k, v in s["power"].items()}, "| power 0.9 needs", round(s["hours_needed"], 2), "h")
print("mounting (platform axes):", {k: np.round(v, 3).tolist() for k, v in s["mounting"].items()})
follow_up = gj.simulate(res.plan(), truth, seed=6)

# %% [markdown]
# ## Joint fit of the tumble and the follow-up test

# %%
joint = fit(tumble + follow_up, base + ["D_II", "D_SS"])
for name in ("D_II", "D_SS"):
    alone = f"{before.values[name]:+.4f}" if name in before.values else "not in that model"
    print(
        f"{name}: tumble alone (D_II only) {alone}; "
        f"joint {joint.values[name]:+.4f} ± {joint.stds[name]:.4f}; truth {truth['coefficients'].get(name, 0.0):+.4f}"
    )

# %%
names = ["D_II", "D_SS"]
x = np.arange(2)
fig, ax = plt.subplots(figsize=(6, 3.4))
ax.bar(x - 0.27, [truth["coefficients"].get(n, 0.0) for n in names], 0.27, label="truth")
ax.bar(x, [before.values.get(n, 0.0) for n in names], 0.27, label="tumble alone (alias absorbed by D_II)")
ax.bar(
    x + 0.27,
    [joint.values[n] for n in names],
    0.27,
    yerr=[2 * joint.stds[n] for n in names],
    capsize=4,
    label="tumble + designed test (±2σ)",
)
ax.axhline(0.0, color="k", lw=0.6)
ax.set_xticks(x, names)
ax.set_ylabel("deg/h/g²")
ax.set_title("The designed test resolves the D_II / D_SS alias", fontsize=10)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig("11_final.png")
Image("11_final.png")
