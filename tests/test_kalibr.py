"""``gyrojax noise --kalibr imu.yaml`` (issue 25): Kalibr's keys and units (ethz-asl/kalibr wiki "IMU Noise Model",
"YAML formats"), read back by PyYAML (pinned in constraints.txt), the noise density N·(π/180)/60 rad/s/√Hz within
1 % of the N the report gives, the same numbers in --json, and imu-triad records analysed per channel (never
pooled), the accelerometer ones included."""

import json
import math

import numpy as np
import pytest
import yaml

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.simulation.simulator import simulate
from gyrojax.simulation.triad import simulate_multiposition

KEYS = {"gyroscope_noise_density", "gyroscope_random_walk", "rostopic", "update_rate"}


def _run(capsys, args):
    rc = main(args)
    return rc, capsys.readouterr().out


def test_sdf_record_to_kalibr(tmp_path, capsys):
    noise = {"white": 0.01, "random_walk": 0.5}
    rec = simulate(plans.fixed_position(hours=2.0, dt_s=0.5), {"coefficients": {"D_F": 0.4}, "noise": noise}, seed=3)
    path = save_record(rec[0], tmp_path)
    out_yaml = tmp_path / "imu.yaml"
    rc, out = _run(capsys, ["noise", str(path), "--json", "--kalibr", str(out_yaml), "--rostopic", "/gyro"])
    assert rc == 0
    o = json.loads(out)
    y = yaml.safe_load(out_yaml.read_text())
    assert KEYS <= set(y) and y["rostopic"] == "/gyro" and y["update_rate"] == pytest.approx(2.0)
    n = o["model"]["parameters"]["white"]["value"]  # deg/√h, the model has the white term
    assert y["gyroscope_noise_density"] == pytest.approx(n * math.pi / 180 / 60, rel=0.01)
    # against the simulated truth: N 0.01 deg/√h -> 2.909e-6 rad/s/√Hz; K 0.5 deg/h/√h -> 4.04e-8 rad/s²/√Hz
    assert y["gyroscope_noise_density"] == pytest.approx(0.01 * math.pi / 180 / 60, rel=0.1)
    assert y["gyroscope_random_walk"] == pytest.approx(0.5 * math.pi / 180 / 3600 / 60, rel=0.5)
    for k in KEYS - {"rostopic"}:
        assert o["kalibr"][k] == pytest.approx(y[k], rel=1e-5)
    assert "accelerometer_noise_density" not in y  # the record has none, the file says so in a comment
    rc = main(["noise", str(path), "--kalibr", str(out_yaml)])
    assert rc == 2  # exists: --force needed


def test_triad_per_channel_with_accelerometer(tmp_path, capsys):
    """A simulated hand-IMU session at 100 Hz, 12 static poses of 200 s: gyro white 0.05 deg/s per sample on
    every channel (N = 0.05·3600·√0.01/60 = 0.3 deg/√h) and, on z only, white of twice that added (N_z = √5·0.3);
    accelerometer white 1 mg per sample (100 µg/√Hz). Each channel keeps its own N (not pooled); Kalibr's gyro
    density is the largest (z); the accelerometer density 100e-6·g0 m/s²/√Hz within 10 %."""
    rec = simulate_multiposition(mems_truth(7), poses=12, static_s=200.0, gyro_noise_dps=0.05, acc_noise_g=0.001)
    z = np.asarray(rec.columns["gyro_z_dps"], float)
    rec.columns["gyro_z_dps"] = z + np.random.default_rng(5).normal(0.0, 0.1, len(z))
    path = save_record(rec, tmp_path)
    out_yaml = tmp_path / "imu.yaml"
    rc, out = _run(capsys, ["noise", str(path), "--json", "--kalibr", str(out_yaml)])
    assert rc == 0
    o = json.loads(out)
    ch = o["channels"]
    assert set(ch) == {f"{s}_{c}" for s in ("gyro", "acc") for c in "xyz"}
    arw = {"x": 0.3, "y": 0.3, "z": 0.3 * math.sqrt(5.0)}
    for c, truth in arw.items():
        assert ch[f"gyro_{c}"]["headline"]["arw"]["curve"]["value"] == pytest.approx(truth, rel=0.05), c
    y = yaml.safe_load(out_yaml.read_text())
    assert y["gyroscope_noise_density"] == pytest.approx(arw["z"] * math.pi / 180 / 60, rel=0.05)
    assert y["accelerometer_noise_density"] == pytest.approx(100e-6 * 9.80665, rel=0.1)
    assert y["update_rate"] == pytest.approx(100.0) and o["kalibr"]["update_rate"] == pytest.approx(100.0)
