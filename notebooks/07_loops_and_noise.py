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
# # 07 · The rebalance loop and the noise of the drift
#
# Two things sit between the gyro's physics and a drift record: the **torque-rebalance loop** that turns the float
# angle into a torquer current (Hu 2-50 to 2-63), and the **random drift** that limits every coefficient. We look at
# the loop's frequency and step response (`gyrojax.dynamics.loops`) and then at the Allan deviation of a static record
# (`gyrojax.noise.allan`, IEEE 952) next to the noise terms the fit itself estimates.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

import gyrojax as gj
from gyrojax.dynamics import loops
from gyrojax.inference.identify import fit
from gyrojax.noise import allan
from gyrojax.noise.spec import gauss_markov_avar

p = loops.default_rebalance(crossover_hz=30.0)
f_hz = np.logspace(-1, 3, 200)
T = loops.rebalance_closed_loop_tf(p, 2j * np.pi * f_hz)
T3 = loops.rebalance_closed_loop_tf(p, 2j * np.pi * f_hz, third_order=True)
i3 = int(np.argmax(np.abs(T) < 1 / np.sqrt(2)))
print(f"closed-loop |T| at 0.1 Hz: {abs(T[0]):.6f}; first below −3 dB at {f_hz[i3]:.1f} Hz")

# %% [markdown]
# ## Step response: a 10 deg/h input step, read at the 1 kHz loop rate (exact ZOH discretisation)

# %%
dt = 1e-3
w_in = np.where(np.arange(200) * dt >= 0.02, 10.0, 0.0)
u = np.asarray(loops.simulate_rebalance(p, w_in, dt))
print(f"indicated rate after 0.18 s: {u[-1]:.4f} deg/h")

# %% [markdown]
# ## Allan deviation of a static drift record
# Two hours at a fixed position with white noise (ARW N = 0.002 deg/√h) and a Gauss–Markov drift. The fit of the
# record estimates white + Gauss–Markov noise by REML; the Allan analysis fits the IEEE 952 terms independently.

# %%
truth = {"coefficients": {"D_F": 0.2, "D_I": 0.3}, "noise": {"white": 0.002, "gauss_markov": [0.03, 300.0]}}
rec = gj.simulate(gj.plans.fixed_position(hours=2, dt_s=1), truth, seed=2)[0]
res = fit([rec], ["D_F", "D_I"], allow_aliases=True)
nz = res.to_json()["records"][0]["noise_model"]
print("fit noise model:", {k: nz.get(k) for k in ("kind", "white_std", "gauss_markov_std", "tau_s")})
arw_fit = nz.get("white_std", np.nan) * np.sqrt(1.0) / 60.0  # σ per 1 s sample → deg/√h
print(f"ARW from the fit: {arw_fit:.5f} deg/√h (truth 0.002)")
ar, nf = allan.analyze(rec.indicated - rec.indicated.mean(), 1.0, gauss_markov=True)
print("Allan noise fit (IEEE 952):", {k: round(nf.value(k), 6) for k in nf.names}, "converged:", nf.converged)

# %%
fig, axs = plt.subplots(1, 2, figsize=(10, 3.8))
ax = axs[0]
ax.semilogx(f_hz, 20 * np.log10(np.abs(T)), label="2nd order (Hu 2-52)")
ax.semilogx(f_hz, 20 * np.log10(np.abs(T3)), "--", label="with gimbal compliance (Hu 2-57/2-58)")
ax.set_xlabel("frequency (Hz)")
ax.set_ylabel("|u/ω_in| (dB)")
ax.set_ylim(-40, 10)
ax.set_title("rebalance loop", fontsize=9)
ax.legend(fontsize=7)
ins = ax.inset_axes([0.08, 0.12, 0.38, 0.38])
ins.plot(np.arange(u.size) * dt * 1e3, u, lw=1)
ins.set_xlabel("ms", fontsize=6)
ins.tick_params(labelsize=6)
ax = axs[1]
ax.loglog(ar.taus_s, ar.adev, "k.", ms=3, label="Allan deviation")
ax.fill_between(ar.taus_s, ar.low, ar.high, color="0.8")
for k, v in nf.term_avar(ar.taus_s).items():
    ax.loglog(ar.taus_s, np.sqrt(v), lw=1, label=f"fit: {k}")
ax.loglog(ar.taus_s, 60 * 0.002 / np.sqrt(ar.taus_s), "C3:", label="true ARW 0.002 deg/√h")
if nz.get("kind") == "white+gauss_markov":
    gm = gauss_markov_avar(ar.taus_s, nz["gauss_markov_std"], nz["tau_s"])
    wv = (60 * arw_fit) ** 2 / ar.taus_s
    ax.loglog(ar.taus_s, np.sqrt(wv + gm), "m--", lw=1.5, label="GLS fit's white + Gauss–Markov")
ax.set_xlabel("τ (s)")
ax.set_ylabel("σ(τ) (deg/h)")
ax.set_title("static drift record", fontsize=9)
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig("07_final.png")
Image("07_final.png")
