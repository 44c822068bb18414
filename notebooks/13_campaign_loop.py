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
# # 13 · The test campaign as a loop: from the lab's records to the next test, until the model is right and sharp
#
# Hu's procedure is a fixed sequence — multi-position, then tumble, then servo — chosen before anything is known about
# the gyro. Here the laboratory asks after every test: *given what I have measured, what should the table do next, and
# when can I stop?* Each step diagnoses all the records so far, adds the effect the data ask for (at a level that
# spends a campaign-wide false-effect rate of 5 %: look j tests at α/(j(j+1))), states what still stands between the
# data and the goal — a σ above target, a candidate that could hide, an alias — and designs by gradients the static test
# on the lab's two-axis table that removes it in the fewest hours.
#
# The gyro below carries two effects the lab's model (D_F, D_I, D_S) lacks: spin-axis compliance D_SS, which the
# first test — a polar tumble in one mounting, OA along the polar axis — cannot tell from D_II (a_I² + a_S² is constant
# there), and output-axis unbalance D_O, which it cannot see at all (a_O is constant: D_O reads as D_F). The goal:
# every coefficient of the final model to σ ≤ 0.004 (deg/h, deg/h/g, deg/h/g²); the table may run 4 h a test.

# %%
from IPython.display import Image

import gyrojax as gj
from gyrojax.data import plans

truth = {
    "coefficients": {"D_F": 0.35, "D_I": -0.5, "D_S": 0.25, "D_SS": 0.12, "D_O": -0.08},
    "noise": {"white": 0.005},
}
first = plans.tumble(revolutions=2.0, earth_rates=20.0, dt_s=60.0, flip=False, both_directions=False)
goal = gj.Goal(sigma=0.004)
lab = {"axes": plans.TWO_AXIS, "turn_case": False, "mountings_per_test": 1, "positions": 8, "hours_per_test": 4.0}
print(f"first test: a polar tumble, OA along the axis, one mounting, {first.duration_s / 3600:.2f} h")


# %% [markdown]
# ## The loop, step by step
#
# Every step prints what the diagnosis added, what it could not name, and why the next test is what it is.


# %%
def show(nt):
    added = ", ".join(a["effect"] for a in nt.added) or "nothing"
    print(f"— model {', '.join(nt.terms)}; added {added}; verdict {nt.diagnosis.verdict if nt.diagnosis else '—'}")
    if nt.alias:
        print(f"  aliased in the records: {' / '.join(nt.alias)}")
    print(f"  [{nt.status}] {nt.reason[:420]}{' …' if len(nt.reason) > 420 else ''}")


result = gj.run_campaign(
    truth, first, ["D_F", "D_I", "D_S"], goal, seed=3, lab_options=lab, on_step=show, starts=1, steps=120
)

# %% [markdown]
# ## The tests it chose, the σ after each, and the classical sequence for the same σ

# %%
# the error falling: the residual RMS of the model after each test against the noise floor (deg/h; what is left
# above the floor is effects the model still lacks), and the σ shrinking: the worst σ of the model's coefficients
for step in result.steps:
    sig = step.state["coefficients"]
    worst = max(sig, key=lambda c: sig[c]["std"])
    print(
        f"{step.plan.name:8s} {step.hours:5.2f} h (total {step.cumulative_hours:5.2f} h)  model {', '.join(sig)}; "
        f"residual {step.state['residual_rms']:.4f} (floor {step.state['noise_floor']:.4f}); "
        f"worst σ {worst} = {sig[worst]['std']:.4f}"
    )
cl = result.classical
print(f"\nloop: {result.table_hours:.1f} table hours; Hu's classical sequence scaled to the same σ: {cl.hours:.1f} h")
print(f"(its best split of time among its three tests, Fisher only: {cl.best_split_hours:.1f} h)")
# and what no campaign from the same first test can go below: the fewest hours of static dwell on this table that
# meet the last look's requirements — the final model's σ and ruling out the watched candidates at the sizes that
# matter (a convex-duality bound over every design on a 10° grid of the table's angles)
print(result.hours_bound()["statement"])
fit = result.last.fit
for c in fit.coefficient_names:
    t = truth["coefficients"].get(c, 0.0)
    z = (fit.values[c] - t) / fit.stds[c]
    print(f"  {c:5s} {fit.values[c]:+.4f} ± {fit.stds[c]:.4f}   truth {t:+.4f}   ({z:+.1f} σ)")

# %%
fig = gj.report.campaign_figure(result)
gj.report.save(fig, "13_final.png")
Image("13_final.png")
