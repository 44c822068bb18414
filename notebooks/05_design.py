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
# # 05 · Designing a test plan
#
# The Fisher information F = Jᵀ Σ⁻¹ J of a plan comes from the same measurement model the fit uses; its inverse is
# the Cramér–Rao bound on the coefficients. `gyrojax.planning.optimal.design` moves the positions of a static plan on a
# two-axis table (and their dwell times) by gradient descent to minimise a criterion — here D-optimality,
# −log det F. We compare a designed 24-position plan with the classical 24-position set, then check the bound by a
# quick Monte Carlo of the designed plan.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

import gyrojax as gj
from gyrojax.inference.identify import fit
from gyrojax.planning import baselines, criteria, fisher
from gyrojax.planning import optimal as design

terms = ["D_F", "D_I", "D_O", "D_S", "D_IS", "D_IO", "D_OS"]
res = design.design(terms, n_positions=24, hours=0.8, criterion="D", starts=2, adam_steps=200, lbfgs_steps=10)
print(f"loss (−log det F) {res.loss:.2f}; compile {res.timing['compile_s']:.1f} s, run {res.timing['run_s']:.1f} s")
print("first positions (deg):", np.round(res.angles_deg[:4], 1).tolist())

# %% [markdown]
# ## Designed versus classical (Cramér–Rao stds at the same measuring time, white noise)

# %%
classical = gj.plans.multiposition(24, minutes=2, dt_s=2)
model = gj.Model.of(terms, "sdf-gyro")
f_cl = fisher.record_fisher(model, gj.simulate(classical, {"coefficients": {}}), res.noise)
f_cl = f_cl * res.dwell_s.sum() / baselines.measured_seconds(classical)
cv_cl = criteria.criterion_values(f_cl, model)
cv_de = criteria.criterion_values(res.fisher, model)
print(f"{'coefficient':<8}{'classical 24':>14}{'designed 24':>14}")
for c in terms:
    print(f"{c:<8}{cv_cl['std'][c]:>14.3e}{cv_de['std'][c]:>14.3e}")
print(f"D = log det F: classical {cv_cl['D']:.2f}, designed {cv_de['D']:.2f}")

# %% [markdown]
# ## A quick Monte Carlo check of the designed plan
# Simulate the designed plan a few times and compare the scatter of the fitted coefficients with the bound.

# %%
plan = design.design_plan(res)
truth = {"coefficients": {"D_F": 0.2, "D_I": 0.4, "D_S": -0.3}, "noise": {"white": res.noise.white}}
est = np.array(
    [[fit(gj.simulate(plan, truth, seed=s), terms, noise="white").values[c] for c in terms] for s in range(4)]
)
mc_std = est.std(axis=0, ddof=1)
for c, s in zip(terms, mc_std):
    print(f"{c:<8} MC std {s:.2e}   bound {cv_de['std'][c]:.2e}")

# %%
x = np.arange(len(terms))
fig, ax = plt.subplots(figsize=(7, 3.4))
ax.bar(x - 0.27, [cv_cl["std"][c] for c in terms], 0.27, label="classical 24-position (bound)")
ax.bar(x, [cv_de["std"][c] for c in terms], 0.27, label="designed 24-position (bound)")
ax.bar(x + 0.27, mc_std, 0.27, label="designed: Monte Carlo std (4 runs)")
ax.set_yscale("log")
ax.set_xticks(x, terms)
ax.set_ylabel("std (report units)")
ax.set_title("D-optimal design vs the classical set", fontsize=10)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig("05_final.png")
Image("05_final.png")
