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
# # 01 · Quick start: find the hidden effect, add it, watch the error fall
#
# We simulate a polar tumble test (Hu 3-12 to 3-21: normal and flipped mounting, CCW and CW) of a floated gyro
# whose truth carries an anisoelastic term **D_IS** that the laboratory's first model does not have. Then we fit
# the four-term model D_F, D_I, D_O, D_S, ask `diagnose` what is missing, add it and refit.

# %%
from IPython.display import Image

import gyrojax as gj
from gyrojax import report
from gyrojax.diagnose import add_and_refit, diagnose
from gyrojax.identify import fit

plan = gj.plans.tumble(revolutions=1, dt_s=10)  # small plan: 1 revolution, one sample every 10 s
truth = {
    "coefficients": {"D_F": 0.4, "D_I": 0.6, "D_O": 0.05, "D_S": -0.3, "D_IS": 0.05},  # deg/h, deg/h/g, deg/h/g²
    "noise": {"white": 0.0005},  # deg/√h
}
records = gj.simulate(plan, truth, seed=1)
[(r.name, len(r.time_s)) for r in records]

# %% [markdown]
# ## Fit the first model
# A joint GLS fit of all four records; each record gets its own noise model.

# %%
terms = ["D_F", "D_I", "D_O", "D_S"]
res = fit(records, terms)
print(report.fit_table(res))
print(f"residual RMS {res.residual_rms:.5f} deg/h, white-noise floor {res.noise_floor:.5f} deg/h")

# %% [markdown]
# ## What is missing?
# `diagnose` ranks every named effect the model lacks by a score test (Holm-adjusted) and names its aliases.

# %%
d = diagnose(records, terms, result=res, suggest_tests=False)
print(d.verdict, "→ top candidate:", d.top.name, "aliases:", d.top.aliases)
report.residual_figure(res, records, title="model: " + ", ".join(terms))

# %% [markdown]
# ## Add it and refit

# %%
terms2, res2, d2, added = add_and_refit(records, terms, diagnosis=d, suggest_tests=False)
print("added", added, "→ verdict", d2.verdict)
print(report.fit_table(res2))
print(f"residual RMS {res2.residual_rms:.5f} deg/h, floor {res2.noise_floor:.5f} deg/h")

# %% [markdown]
# ## The error falls
# The residual RMS of each model against the white-noise floor.

# %%
steps = [
    (", ".join(terms), res.residual_rms, res.noise_floor),
    (f"+ {added}", res2.residual_rms, res2.noise_floor),
]
fig = report.error_falling_figure(steps)
fig.savefig("01_final.png")
Image("01_final.png")
