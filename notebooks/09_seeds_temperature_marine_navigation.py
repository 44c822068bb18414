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
# # 09 · From the seeds: drift processing, temperature, marine reset, navigation cost
#
# Four short stories, one per module that turns a seed's formulas into code:
#
# 1. `gyrojax.seeds.drift_processing` — Hu ch. 4 (moving-average rate, gain 4-11) and ch. 6 (Kalman running mean);
# 2. `gyrojax.seeds.thermal` — seed 001: the two-slope temperature model hinged at 20 °C and what it buys in navigation;
# 3. `gyrojax.seeds.marine` — seed 003: the ψ-angle closed form and why three position fixes cannot reset the INS;
# 4. `gyrojax.seeds.system` — Titterton ch. 12, what a residual gyro drift and a coefficient's uncertainty cost.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image
from scipy.integrate import solve_ivp

import gyrojax as gj
from gyrojax import units
from gyrojax.inference.identify import fit
from gyrojax.seeds import drift_processing as dp
from gyrojax.seeds import marine, system, thermal

rng = np.random.default_rng(9)

# %% [markdown]
# ## 1 · Drift processing (Hu ch. 4 and 6)
# An angle θ = A sin ωt sampled every Δt; the moving-average rate over ΔT = nΔt is K·Aω cos ωt with no phase error
# and gain K = sin(ωΔT/2)/(ωΔT/2) (Hu 4-11). We measure the amplitude ratio and compare.

# %%
dt, n = 1.0, 60  # 1 s samples, 60 s window
t = np.arange(0.0, 3600.0, dt)
amp = 10.0  # arcsec
periods = np.array([300.0, 600.0, 1200.0, 2400.0])
for period in periods:
    w = 2 * np.pi / period
    t_mid, rate = dp.moving_average_rate(amp * np.sin(w * t), dt, n)
    measured = float(np.max(np.abs(rate))) / (amp * w)
    print(
        f"period {period:6.0f} s: measured gain {measured:.4f}, Hu 4-11 {float(dp.moving_average_gain(w, n * dt)):.4f}"
    )

# %% [markdown]
# The Kalman running mean of a constant angle read with white error (Hu 6-21, 6-22): with a diffuse prior the gain
# is 1/(k+1), the estimate is the arithmetic mean, and the book's example — a mean square of **10 sec²** falls to
# **1 sec²** after ten averages — follows from p_k = p_0 R/(k p_0 + R).

# %%
r_var = 10.0  # arcsec², reading-error variance
z = 5.0 + np.sqrt(r_var) * rng.standard_normal(200)
est, var, gain = dp.kalman_running_mean(z, r=r_var, p0=1e8)
print(f"variance after 10 readings: {float(var[9]):.3f} sec²  (Hu: 10 sec² → 1 sec²)")
print("gains K_0..K_4:", np.round(np.asarray(gain[:5]), 4), " vs 1/(k+1):", np.round(1 / np.arange(1, 6), 4))
print(f"estimate after 10 = {float(est[9]):.4f}, arithmetic mean = {z[:10].mean():.4f}")
k_axis = np.arange(1, 201)
sec1 = dict(k=k_axis, var=np.asarray(var), ms=np.cumsum((np.asarray(est) - 5.0) ** 2) / k_axis)

# %% [markdown]
# ## 2 · Temperature compensation (seed 001)
# A gyro bias and an accelerometer bias that follow two different slopes either side of 20 °C. The 001 procedure
# calibrates at room (before), hot, cold and room (after), extrapolates the room runs to 20 °C along their own
# side and averages them into `e`; the slopes K_1, K_2 follow from the hot and cold runs.

# %%
gyro_true = thermal.TwoSlope(e=0.30, k_hot=0.012, k_cold=-0.020)  # deg/h, deg/h/°C
accel_true = thermal.TwoSlope(e=2e-4, k_hot=4e-6, k_cold=-6e-6)  # g, g/°C
temps = {"b": 22.0, "h": 60.0, "d": -45.0, "a": 18.0}


def calibrate(model, noise):
    """Four calibration runs of the model with a small run-to-run error; the 001 two-slope fit."""
    k = {s: float(model(tc)) + noise * rng.standard_normal() for s, tc in temps.items()}
    tau = {s: tc - thermal.T_REF_C for s, tc in temps.items()}
    e, k1, k2, hyst = thermal.two_slope_from_runs(
        k["b"], tau["b"], k["h"], tau["h"], k["d"], tau["d"], k["a"], tau["a"]
    )
    return thermal.TwoSlope(float(e), float(k1), float(k2)), float(hyst)


gyro_fit, gyro_hyst = calibrate(gyro_true, 0.002)
accel_fit, accel_hyst = calibrate(accel_true, 2e-6)
print("gyro  truth", gyro_true, "\n      fit  ", gyro_fit, f"S01−S04 = {gyro_hyst:+.4f} deg/h")
print("accel truth", accel_true, "\n      fit  ", accel_fit, f"S01−S04 = {accel_hyst:+.2e} g")

# %% [markdown]
# Compensating a rate series: the INS warms up from 20 °C to 45 °C in the first hour while sitting still
# (true rate 0 on a level east gyro, say); ω̂ = (ω_ind − b̂(T)).

# %%
nav_dt = 10.0
t_nav = np.arange(0.0, 2 * 3600.0, nav_dt)
temp_c = 20.0 + 25.0 * (1 - np.exp(-t_nav / 1800.0))
indicated = gyro_true(temp_c) + 0.003 * rng.standard_normal(t_nav.size)
comp = thermal.compensate_rate(indicated, temp_c, bias=gyro_fit)
print(
    f"rms rate before {np.sqrt(np.mean(np.asarray(indicated) ** 2)):.4f} deg/h, "
    f"after {np.sqrt(np.mean(np.asarray(comp) ** 2)):.4f} deg/h"
)

# %% [markdown]
# Navigation: the residual gyro and accelerometer errors drive the single-channel Schuler loop. Uncompensated means
# only the room-temperature value (at 20 °C) is removed.

# %%
x_unc = thermal.navigation_position_error(nav_dt, temp_c, gyro_true, accel_true)
x_cmp = thermal.navigation_position_error(nav_dt, temp_c, gyro_true, accel_true, gyro_fit, accel_fit)
peak_unc, peak_cmp = float(np.max(np.abs(x_unc))), float(np.max(np.abs(x_cmp)))
print(f"peak position error over 2 h: uncompensated {peak_unc:.0f} m, compensated {peak_cmp:.1f} m")
assert peak_cmp < peak_unc
sec2 = dict(t=np.arange(t_nav.size + 1) * nav_dt / 3600, unc=np.asarray(x_unc), cmp=np.asarray(x_cmp))

# %% [markdown]
# ## 3 · Marine INS reset (seed 003)
# The ψ-angle equation ψ̇ = −[ω_ip×]ψ + ε (003 eq. 2) has the closed form of eq. 3 for constant drift. Check it
# against scipy's integrator over a day.

# %%
lat = np.deg2rad(30.0)
psi0 = np.array([20.0, -10.0, 30.0]) * units.ARCSEC
eps = np.array([0.01, -0.008, 0.005]) * units.DEG_PER_H
t_psi = np.linspace(0.0, 24 * 3600.0, 97)
closed = np.asarray(marine.psi_closed_form(psi0, eps, t_psi))
ode = solve_ivp(
    lambda _, y: np.asarray(marine.psi_rhs(y, eps)),
    (0, t_psi[-1]),
    psi0,
    t_eval=t_psi,
    rtol=1e-11,
    atol=1e-16,
    method="DOP853",
)
err = np.max(np.abs(closed - ode.y.T))
print(
    f"max |closed form − numerical| = {err / units.ARCSEC:.2e} arcsec over 24 h "
    f"(ψ reaches {np.max(np.abs(closed)) / units.ARCSEC:.0f} arcsec)"
)
sec3 = dict(t=t_psi / 3600, closed=closed / units.ARCSEC, ode=ode.y.T / units.ARCSEC)

# %% [markdown]
# Three position fixes give six equations (δl, δL at t_1, t_2, t_3) in u = (ψ(t_1), ε/ω_ie) (003 eq. 10). The
# matrix has rank 5: an east drift balanced by ψ_q = a, ψ_p = a tan L is an equilibrium of eq. 2 that never shows
# in position. One heading reference (the φ_d row) restores full rank.

# %%
fixes = np.array([0.0, 4.0, 8.0]) * 3600.0
a_fix = marine.fix_matrix(lat, fixes)
rank, null = marine.rank_and_null_space(a_fix)
v = np.asarray(null[:, 0])
v = v / v[0]
print(f"three-fix matrix {a_fix.shape}: rank {rank}")
print("null vector (scaled to u_0 = 1):", np.round(v, 6), f"  expected (1, 0, tan L = {np.tan(lat):.6f}, 0, 1, 0)")
a_head = np.vstack([np.asarray(a_fix), np.asarray(marine.heading_row(lat, 8 * 3600.0))])
print("with one heading reference: rank", marine.rank_and_null_space(a_head)[0])

# %% [markdown]
# ## 4 · Navigation cost (Titterton ch. 12)
# A residual horizontal drift of 0.01 deg/h: without the Schuler loop the position error grows as g δω t³/6; the
# loop bounds the tilt and leaves R_0 δω (t − sin ω_s t/ω_s), a steady ≈ R_0 δω per hour plus the 84.4-min
# oscillation. Check the closed form against the loop propagated by `simulate_channel`.

# %%
drift = 0.01  # deg/h
t_sys = np.arange(0.0, 4 * 3600.0 + 1, 60.0)
beta = np.array([drift * units.DEG_PER_H, 0, 0, 0, 0])
x_sch = np.asarray(system.position_error_closed_form(t_sys, beta))
x_free = np.asarray(system.position_error_closed_form(t_sys, beta, schuler=False))
x_loop = np.asarray(system.simulate_channel(60.0, np.full(t_sys.size - 1, drift * units.DEG_PER_H)))[:, 3]
print(
    f"Schuler period {float(system.schuler_period_min()):.1f} min; "
    f"long-run growth {float(system.drift_to_position_rate(drift)):.0f} m/h"
)
print(
    f"after 4 h: with Schuler {x_sch[-1] / 1e3:.2f} km (loop {x_loop[-1] / 1e3:.2f} km), "
    f"without {x_free[-1] / 1e3:.0f} km"
)

# %% [markdown]
# The navigation cost of a fitted coefficient's uncertainty: fit a short tumble, then take the drift of a level gyro
# with its spin axis vertical (a_S = 1 g: drift = D_F + D_S) and push the coefficients' covariance through the
# loop, σ_x(t)² = trace(W(t) Σ_c) with W = Jᵀ s sᵀ J.

# %%
plan = gj.plans.tumble(revolutions=1, dt_s=10)
truth = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "D_O": 0.05, "D_S": -0.3}, "noise": {"white": 0.0005}}
res = fit(gj.simulate(plan, truth, seed=9), ["D_F", "D_I", "D_O", "D_S"])
jac = np.array([1.0, 0.0, 0.0, 1.0])  # deg/h per unit of (D_F, D_I, D_O, D_S) with a_S = 1 g
sigma_drift = float(np.sqrt(jac @ res.cov @ jac))
sigma_x = np.array([float(system.position_error_std(tt, res.cov, jac)) for tt in t_sys[::10]])
print("fitted σ:", {k: f"{v:.2e}" for k, v in res.stds.items()}, f"→ σ(drift) = {sigma_drift:.2e} deg/h")
print(
    f"1σ position error after 4 h: {sigma_x[-1]:.1f} m "
    f"(= |s(t)| σ(drift): {abs(x_sch[-1]) / drift * sigma_drift:.1f} m)"
)
sec4 = dict(t=t_sys / 3600, sch=x_sch, free=x_free, loop=x_loop, ts=t_sys[::10] / 3600, sx=sigma_x)

# %% [markdown]
# ## One figure, one panel per story

# %%
fig, ax = plt.subplots(2, 2, figsize=(11, 8))
a = ax[0, 0]
a.loglog(sec1["k"], sec1["var"], label="Kalman p_k (Hu 6-22)")
a.loglog(sec1["k"], r_var / sec1["k"], "k:", label="R/k")
a.axhline(1.0, color="grey", lw=0.5)
a.axvline(10, color="grey", lw=0.5)
a.set(xlabel="readings k", ylabel="variance (sec²)", title="1 · Kalman running mean: 10 → 1 sec² at k = 10")
a.legend()
a = ax[0, 1]
a.semilogy(sec2["t"], np.abs(sec2["unc"]), label="uncompensated (20 °C value only)")
a.semilogy(sec2["t"], np.abs(sec2["cmp"]), label="two-slope compensated")
a.set(xlabel="time (h)", ylabel="|position error| (m)", title="2 · warm-up 20 → 45 °C: navigation error")
a.set_ylim(1e-2, None)
a.legend()
a = ax[1, 0]
for i, name in enumerate("qep"):
    a.plot(sec3["t"], sec3["closed"][:, i], label=f"ψ_{name} closed form")
    a.plot(sec3["t"], sec3["ode"][:, i], "k.", ms=2)
a.set(xlabel="time (h)", ylabel="ψ (arcsec)", title=f"3 · ψ-angles (dots: ODE); 3-fix rank = {rank}")
a.legend()
a = ax[1, 1]
a.semilogy(sec4["t"], np.abs(sec4["free"]) / 1e3, label="no Schuler loop: g δω t³/6")
a.semilogy(sec4["t"], np.abs(sec4["sch"]) / 1e3, label="Schuler loop, 0.01 deg/h")
a.semilogy(sec4["ts"], sec4["sx"] / 1e3, "o-", ms=3, label="1σ from fitted D_F + D_S")
a.set(xlabel="time (h)", ylabel="position error (km)", title="4 · residual drift → position error", ylim=(1e-4, None))
a.legend()
fig.tight_layout()
fig.savefig("09_final.png", dpi=90)
plt.close(fig)
Image("09_final.png")
