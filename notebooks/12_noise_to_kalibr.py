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
# # 11 · From a raw static log to a Kalibr imu.yaml
#
# A navigation filter (Kalibr, OpenVINS, VINS) wants two numbers per sensor: the white-noise density and the bias
# random walk. Here a real MEMS session (imucal's BMI160-class IMU at 204.8 Hz, vendored in `tests/data/imucal`)
# goes from its raw CSV to Kalibr's `imu.yaml`: the rests are the static log, each gyro and accelerometer channel is
# analysed on its own (`gyrojax noise` on an `imu-triad` record), with the Allan deviation and its band, the
# identified GMWM model, the IEEE 952 read-offs of the curve and of the model side by side, and the glitch check.
# (The accelerometer channels are analysed in m/s² where the report's units say deg/h.)

# %%
import contextlib
import io
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import yaml
from IPython.display import Image

import gyrojax
from gyrojax.cli.app import main
from gyrojax.data.importers import import_imucal
from gyrojax.data.records import save_record

DATA = Path(gyrojax.__file__).resolve().parents[1] / "tests" / "data" / "imucal"
work = Path(tempfile.mkdtemp())

# %% [markdown]
# ## The raw log as a record
# The importer finds the six rests (static segments) and the hand turns; only the rests enter the noise analysis.
# Each rest is short (about 5 s), so the long-τ figures are bounds, not read-offs: the output says which.

# %%
rec = import_imucal(DATA / "annotated_session.csv", rate_hz=204.8, gyro_counts_per_dps=16.4)
save_record(rec, work)
print([(s["name"], s["type"]) for s in rec.meta["segments"]])

# %% [markdown]
# ## `gyrojax noise REC --kalibr imu.yaml --json`
# One report per channel (never pooled), and the Kalibr figures: the largest channel of each sensor, the noise
# density N·(π/180)/60 rad/s/√Hz, the random walk K·(π/180)/(60·3600) rad/s²/√Hz (an upper bound when the record
# shows no +½ slope, and the file says so).

# %%
out_yaml = work / "imu.yaml"
buf = io.StringIO()
with contextlib.redirect_stdout(buf):
    rc = main(["noise", str(work), "--json", "--kalibr", str(out_yaml)])
report = json.loads(buf.getvalue())
for name, ch in report["channels"].items():
    h = ch["headline"]
    arw, b = h["arw"], h["bias_instability"]["curve"]
    n_model = "not read" if arw["model"]["value"] is None else f"{arw['model']['value']:.3g}"
    print(
        f"{name}: model {ch['model']['info']['model']:12s} N curve {arw['curve']['value']:.3g} | model {n_model}; "
        f"B {b.get('kind', 'not read')} {b.get('value') or float('nan'):.3g}; glitches "
        f"{ch['glitches']['spikes']['count']} spikes, {ch['glitches']['stuck']['count']} stuck"
    )
print(out_yaml.read_text())
print(yaml.safe_load(out_yaml.read_text()))

# %% [markdown]
# ## The ADEV of each gyro channel, its 95 % band and the model

# %%
fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
for ax, c in zip(axes, "xyz"):
    ch = report["channels"][f"gyro_{c}"]
    t = np.array(ch["taus_s"])
    ax.fill_between(t, ch["adequacy"]["low"], ch["adequacy"]["high"], color="0.85", label="empirical 95 %")
    ax.loglog(t, ch["adev_deg_per_h"], "k.", label="overlapping ADEV")
    ax.loglog(t, ch["adev_model_deg_per_h"], "C0-", label=f"model {ch['model']['info']['model']}")
    n = ch["headline"]["arw"]["curve"]["value"]
    ax.loglog(t, 60 * n / np.sqrt(t), "C1--", lw=1, label=f"N = {n:.2f} deg/√h")
    ax.set_title(f"gyro {c}")
    ax.set_xlabel("τ [s]")
    ax.legend(fontsize=7)
axes[0].set_ylabel("Allan deviation [deg/h]")
fig.tight_layout()
fig.savefig("12_final.png")
Image("12_final.png")
