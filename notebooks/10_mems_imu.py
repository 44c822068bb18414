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
# # 10 · MEMS IMU: six faces and three hand rotations
#
# A real calibration session of a six-axis MEMS IMU (imucal's annotated Ferraris session, 204.8 Hz, raw counts,
# vendored in `tests/data/imucal`): the IMU rests on each of its six faces, then is turned by hand through one full
# turn about x, y and z. No turntable, no angle log, heading and site unknown. We import it, fit every gyro channel
# as an SDF-like rate gyro (bias, g-sensitivity, scale-factor error, misalignment) with honest σ, compare with
# imucal's own calibration, diagnose the fit, and write calibrated rates.

# %%
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

import gyrojax
from gyrojax import report
from gyrojax.data.importers import import_imucal
from gyrojax.inference.triad import fit_triad

DATA = Path(gyrojax.__file__).resolve().parents[1] / "tests" / "data" / "imucal"

# %% [markdown]
# ## Import
# The importer reads imucal's `part` column (`x_p` … `z_rot`), calibrates the accelerometer from the six faces
# (raw = A a + b by least squares) and writes one `imu-triad` record: static segments for the faces, rotation
# segments "360° about x, sign from the data" for the turns. The gyro stays in counts with a nominal scale of
# 16.4 counts per deg/s (a ±2000 deg/s 16-bit gyro); E_SF is the departure from it.

# %%
rec = import_imucal(DATA / "annotated_session.csv", rate_hz=204.8, gyro_counts_per_dps=16.4)
print(rec.n, "samples;", [(s["name"], s["type"]) for s in rec.meta["segments"]])

# %% [markdown]
# ## Fit: every channel, jointly
# Each face gives the three channels' means; each turn the integral constraint ∫ω_ind dt = model (the angle
# history's shape from the data, its total 360°). The site latitude is unknown: the vertical Earth rate stays in
# D_I (the fit says so), and the horizontal Earth rate of each face of unknown heading is marginalised — it widens
# σ(D_F) a little. All coefficients enter linearly: one GLS solve.

# %%
res = fit_triad(rec, ["D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment"])
print(report.fit_table(res))

# %% [markdown]
# ## Beside imucal
# imucal's calibration of the same session (raw = K_g R_g ω + K_ga a + b_g, its default −360° turn sign undone),
# converted to the same coefficients, and the distance in units of gyrojax's σ.

# %%
cal = json.loads((DATA / "example_cal.json").read_text())
k = 16.4
s_ref = -np.array(cal["K_g"]) @ np.array(cal["R_g"]) / k
m = res.matrices()
print("scale-and-misalignment S, gyrojax:\n", np.round(m["S"], 5))
print("imucal:\n", np.round(s_ref, 5))
print("bias (deg/h), gyrojax:", np.round(m["b"], 1), " imucal:", np.round(np.array(cal["b_g"]) / k * 3600, 1))
ref = {}
for c, ch in enumerate("xyz"):
    ref[f"E_SF[{ch}]"] = (s_ref[c, c] - 1) * 1e6
    ref[f"D_F[{ch}]"] = cal["b_g"][c] / k * 3600
z = {n: float((res.values[n] - v) / res.stds[n]) for n, v in ref.items()}
print("(gyrojax − imucal) / σ:", {n: round(v, 2) for n, v in z.items()})

# %% [markdown]
# ## Diagnosis
# χ² of the segment means against the noise model, and the residual of every face and turn in units of its σ.
# g-sensitivities: which are significant at all? With a ±20 deg/h/g σ for a session of one minute, none is once
# nine are tested together (the largest |t| is about 2; Holm at 5 % would need 2.8).

# %%
fit_json = res.to_json()
print(
    "chi2",
    round(fit_json["fit"]["chi2"], 2),
    "on",
    fit_json["fit"]["dof"],
    "dof, p =",
    round(fit_json["fit"]["p_value"], 3),
)
for n in res.names:
    if n.startswith(("D_I", "D_O", "D_S")):
        t = res.values[n] / res.stds[n]
        print(f"{n:8s} {res.values[n]:8.1f} ± {res.stds[n]:5.1f} deg/h/g   t = {t:+.2f}")

# %% [markdown]
# ## What the fit is missing: `diagnose` on the triad
# The loop of a turntable on the six faces and three turns: every named effect a channel can carry (g² terms,
# scale-factor asymmetry and nonlinearity, trend), the model-free shapes (rate products, |ω|, t²) and the noise
# processes between segments, tested against this fit with one Holm family (`gyrojax diagnose RECORDS`).

# %%
diag = gyrojax.diagnose(rec, result=res)
print(report.diagnosis_text(diag))

# %% [markdown]
# ## Calibrated rates
# `apply` inverts ω_ind = S ω + G a + b sample by sample. The integral of each turn, from the nominal scale and from
# the calibration:

# %%
w_cal = res.apply(rec) / 3600.0  # deg/s
w_nom = np.stack([rec.columns[f"gyro_{c}_counts"] for c in "xyz"], axis=1) / k
seg = rec.columns["segment"]
dt = 1 / 204.8
turns = [s for s in rec.meta["segments"] if s["type"] == "rotation"]
for s in turns:
    a = "xyz".index(s["axis"])
    sel = seg == s["label"]
    print(f"{s['name']}: nominal {w_nom[sel, a].sum() * dt:8.2f} deg, calibrated {w_cal[sel, a].sum() * dt:8.3f} deg")

# %%
fig, axs = plt.subplots(1, 2, figsize=(9, 3.6))
names = [s["name"] for s in rec.meta["segments"]]
resid = np.array([r["residual_deg_per_h"] for r in fit_json["segments"]])
for c, ch in enumerate("xyz"):
    axs[0].plot(range(len(names)), resid[:, c], "o-", ms=4, label=f"channel {ch}")
axs[0].axhline(0, color="k", lw=0.5)
axs[0].set_xticks(range(len(names)), names, rotation=60, fontsize=7)
axs[0].set_ylabel("segment-mean residual (deg/h)")
axs[0].legend(fontsize=7)
axs[0].set_title(f"fit residuals, chi2 {fit_json['fit']['chi2']:.1f} on {fit_json['fit']['dof']} dof", fontsize=9)
sel = seg == turns[2]["label"]
t = np.arange(sel.sum()) * dt
axs[1].plot(t, np.cumsum(w_nom[sel, 2]) * dt, label="nominal scale")
axs[1].plot(t, np.cumsum(w_cal[sel, 2]) * dt, label="calibrated")
axs[1].axhline(360, color="k", lw=0.5, ls="--")
axs[1].set_xlabel("time in the z turn (s)")
axs[1].set_ylabel("integrated z rate (deg)")
axs[1].legend(fontsize=7)
axs[1].set_title("the hand turn about z", fontsize=9)
fig.tight_layout()
fig.savefig("10_final.png")
Image("10_final.png")
