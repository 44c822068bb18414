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
# Gyro channels are in deg/h (N deg/√h, B deg/h, K deg/h/√h), accelerometer channels in m/s² (velocity random walk
# N m/s/√h, B m/s², K m/s²/√h): each figure carries its unit.

# %%
import contextlib
import io
import json
import tempfile
from pathlib import Path

import yaml
from IPython.display import Image

import gyrojax
from gyrojax.cli.app import main
from gyrojax.data.importers import import_imucal
from gyrojax.data.records import save_record
from gyrojax.report.figures import noise_channels_figure

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
# shows no +½ slope, and the file says so); for the accelerometer VRW/60 m/s²/√Hz and K/60 m/s³/√Hz. `--plot`
# writes one figure per sensor, a panel per channel (`adev_gyro.png`, `adev_accel.png`).

# %%
out_yaml = work / "imu.yaml"
buf = io.StringIO()
with contextlib.redirect_stdout(buf):
    rc = main(["noise", str(work), "--json", "--kalibr", str(out_yaml), "--plot", str(work / "adev.png")])
report = json.loads(buf.getvalue())
for name, ch in report["channels"].items():
    h = ch["headline"]
    arw, b = h["arw"], h["bias_instability"]["curve"]
    n_model = "not read" if arw["model"]["value"] is None else f"{arw['model']['value']:.3g}"
    print(
        f"{name}: model {ch['model']['info']['model']:12s} N curve {arw['curve']['value']:.3g} | model {n_model} "
        f"{arw['curve']['unit']}; B {b.get('kind', 'not read')} {b.get('value') or float('nan'):.3g} {b['unit']}; "
        f"glitches {ch['glitches']['spikes']['count']} spikes, {ch['glitches']['stuck']['count']} stuck"
    )
print(report["plots"])
print(out_yaml.read_text())
print(yaml.safe_load(out_yaml.read_text()))

# %% [markdown]
# ## The accelerometer channels: ADEV in m/s², its 95 % band, the model and the read-offs (what `--plot` wrote)

# %%
Image(report["plots"][1])

# %% [markdown]
# ## The gyro channels: ADEV in deg/h, its 95 % band, the model and the read-offs

# %%
fig = noise_channels_figure({k: v for k, v in report["channels"].items() if k.startswith("gyro_")})
fig.savefig("12_final.png")
Image("12_final.png")
