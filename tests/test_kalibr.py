"""``gyrojax noise --kalibr imu.yaml`` (issue 25): Kalibr's keys and units (ethz-asl/kalibr wiki "IMU Noise Model",
"YAML formats"), read back the way Kalibr's own reader does (tests/kalibr_reader.py), the figures against
the closed form of Kalibr's noise model, the noise density N·(π/180)/60 rad/s/√Hz within 1 % of the N the report
gives, the same numbers in --json, and imu-triad records analysed per channel (never pooled), the accelerometer ones
included; a gyro-only record's accelerometer pair only from the user (--kalibr-accel), else a refusal."""

import json
import math

import numpy as np
import pytest
import yaml

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.noise import kalibr
from gyrojax.noise.readoff import noise_report
from gyrojax.noise.sensor_units import accelerometer_report
from gyrojax.noise.spec import NoiseSpec
from gyrojax.simulation.simulator import simulate
from gyrojax.simulation.triad import simulate_multiposition

from .kalibr_reader import kalibr_imu_parameters

ACCEL = "3.0e-3,2.0e-4"  # a datasheet's accelerometer pair: m/s²/√Hz, m/s³/√Hz


def _run(capsys, args):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_the_reader_refuses_what_kalibr_refuses(tmp_path):
    """The reader of this test fails where Kalibr's does: a gyro-only file (what gyrojax wrote before), a
    non-string topic, a zero random walk; PyYAML reads ``1e-05`` (no point) as a string, which Kalibr's ``<=``
    cannot compare."""
    good = {k: 1.0e-3 for k in kalibr.KEYS} | {"rostopic": "/imu0", "update_rate": 100.0}
    cases = {
        "gyro-only": {k: v for k, v in good.items() if not k.startswith("accelerometer")},
        "topic": good | {"rostopic": 7},
        "zero": good | {"gyroscope_random_walk": 0.0},
    }
    p = tmp_path / "imu.yaml"
    p.write_text(yaml.safe_dump(good))
    assert kalibr_imu_parameters(p)[1] == 100.0
    for data in cases.values():
        p.write_text(yaml.safe_dump(data))
        with pytest.raises(RuntimeError):
            kalibr_imu_parameters(p)
    assert isinstance(yaml.safe_load("x: 1e-05")["x"], str) and isinstance(yaml.safe_load("x: 1.0e-05")["x"], float)


@pytest.mark.parametrize("n, k", [(0.01, 0.5), (2.3, 0.02), (0.3, 40.0)])
def test_gyro_figures_against_kalibrs_closed_form(n, k):
    """Kalibr's model, σ²(τ) = σ_g²/τ + σ_bg²·τ/3 (SI, the wiki's white noise and bias random walk), equals the
    IEEE 952 model's Allan deviation (NoiseSpec, deg/h → rad/s) at every τ with σ_g, σ_bg the Kalibr figures; and
    σ_g = N·(π/180)/60, σ_bg = K·(π/180)/(3600·60) (not /60^{3/2})."""
    nd, rw = kalibr.to_kalibr(n, "deg/sqrt(h)"), kalibr.to_kalibr(k, "deg/h/sqrt(h)")
    assert nd == pytest.approx(n * math.pi / 180 / 60, rel=1e-12)
    assert rw == pytest.approx(k * math.pi / 180 / 216000, rel=1e-12)
    taus = np.geomspace(0.01, 1e5, 15)
    adev_rad_s = NoiseSpec(white=n, random_walk=k).adev(taus) * math.pi / 180 / 3600
    np.testing.assert_allclose(adev_rad_s, np.sqrt(nd**2 / taus + rw**2 * taus / 3), rtol=1e-9)


def test_accelerometer_figures_against_kalibrs_closed_form():
    """An accelerometer series in m/s² simulated as Kalibr's wiki discretises its model (white σ_a/√Δt per sample,
    bias steps σ_ba·√Δt), σ_a = 2e-3 m/s²/√Hz, σ_ba = 1e-4 m/s³/√Hz, 100 Hz, 3000 s: the report in accelerometer
    units gives VRW = 60·σ(τ)·√τ m/s/√h on its −½ slope (the ADEV it prints), and Kalibr's figures of it recover σ_a
    and σ_ba within 4 of their own standard errors."""
    dt, n, sa, sba = 0.01, 300_000, 2e-3, 1e-4
    rng = np.random.default_rng(11)
    series = sa / math.sqrt(dt) * rng.standard_normal(n) + np.cumsum(sba * math.sqrt(dt) * rng.standard_normal(n))
    out = accelerometer_report(noise_report([series], dt, model="white+rw")[0])
    arw = out["headline"]["arw"]["curve"]
    i = out["taus_s"].index(arw["tau_s"])
    assert arw["unit"] == "m/s/sqrt(h)"
    assert arw["value"] == pytest.approx(60 * out["adev_mps2"][i] * math.sqrt(arw["tau_s"]), rel=1e-12)
    d = kalibr.densities(out)
    p = out["model"]["parameters"]
    assert p["white"]["unit"] == "m/s/sqrt(h)" and p["random_walk"]["unit"] == "m/s^2/sqrt(h)"
    assert abs(d["noise_density"] - sa) < 4 * p["white"]["std"] / 60
    assert abs(d["random_walk"] - sba) < 4 * p["random_walk"]["std"] / 60
    assert d["noise_density"] == pytest.approx(sa, rel=0.05) and d["random_walk"] == pytest.approx(sba, rel=0.5)


def test_sdf_record_to_kalibr(tmp_path, capsys):
    """A gyro-only record: refused without an accelerometer pair (Kalibr's reader needs one), before any work and
    without writing; with ``--kalibr-accel`` the file loads in Kalibr's reader, the pair as given."""
    noise = {"white": 0.01, "random_walk": 0.5}
    rec = simulate(plans.fixed_position(hours=2.0, dt_s=0.5), {"coefficients": {"D_F": 0.4}, "noise": noise}, seed=3)
    path = save_record(rec[0], tmp_path)
    out_yaml = tmp_path / "imu.yaml"
    rc, _, err = _run(capsys, ["noise", str(path), "--kalibr", str(out_yaml)])
    assert rc == 2 and "--kalibr-accel" in err and "accelerometer_noise_density" in err and len(err.splitlines()) == 1
    assert not out_yaml.exists()
    for bad in ("3e-3", "3e-3,0", "a,b", "3e-3,-1", "nan,1e-4"):
        rc, _, err = _run(capsys, ["noise", str(path), "--kalibr", str(out_yaml), "--kalibr-accel", bad])
        assert rc == 2 and "--kalibr-accel" in err and len(err.splitlines()) == 1, (bad, err)
    rc, _, err = _run(capsys, ["noise", str(path), "--kalibr-accel", ACCEL])
    assert rc == 2 and "only with --kalibr" in err
    args = ["noise", str(path), "--json", "--kalibr", str(out_yaml), "--rostopic", "/gyro", "--kalibr-accel", ACCEL]
    rc, out, _ = _run(capsys, args)
    assert rc == 0
    o = json.loads(out)
    topic, rate, acc, gyro = kalibr_imu_parameters(out_yaml)
    assert topic == "/gyro" and rate == pytest.approx(2.0)
    assert acc[2] == 3.0e-3 and acc[1] == 2.0e-4
    assert "given by --kalibr-accel" in out_yaml.read_text()
    n = o["model"]["parameters"]["white"]["value"]  # deg/√h, the model has the white term
    assert gyro[2] == pytest.approx(n * math.pi / 180 / 60, rel=0.01)
    # against the simulated truth: N 0.01 deg/√h -> 2.909e-6 rad/s/√Hz; K 0.5 deg/h/√h -> 4.04e-8 rad/s²/√Hz
    assert gyro[2] == pytest.approx(0.01 * math.pi / 180 / 60, rel=0.1)
    assert gyro[1] == pytest.approx(0.5 * math.pi / 180 / 3600 / 60, rel=0.5)
    y = yaml.safe_load(out_yaml.read_text())
    for k in kalibr.KEYS:
        assert o["kalibr"][k] == (y[k] if k == "rostopic" else pytest.approx(y[k], rel=1e-5))
    good = out_yaml.read_bytes()
    rc = main(["noise", str(path), "--kalibr", str(out_yaml), "--kalibr-accel", ACCEL])
    assert rc == 2 and out_yaml.read_bytes() == good  # exists: --force needed, the file untouched


def test_triad_per_channel_with_accelerometer(tmp_path, capsys):
    """A simulated hand-IMU session at 100 Hz, 12 static poses of 200 s: gyro white 0.05 deg/s per sample on
    every channel (N = 0.05·3600·√0.01/60 = 0.3 deg/√h) and, on z only, white of twice that added (N_z = √5·0.3);
    accelerometer white 1 mg per sample (100 µg/√Hz, VRW 60·100e-6·g0 = 0.0588 m/s/√h). Each channel keeps its own
    N (not pooled); Kalibr's gyro density is the largest (z); the accelerometer density 100e-6·g0 m/s²/√Hz within
    10 %; the file loads in Kalibr's reader; an accelerometer pair given besides the record's is refused."""
    rec = simulate_multiposition(mems_truth(7), poses=12, static_s=200.0, gyro_noise_dps=0.05, acc_noise_g=0.001)
    z = np.asarray(rec.columns["gyro_z_dps"], float)
    rec.columns["gyro_z_dps"] = z + np.random.default_rng(5).normal(0.0, 0.1, len(z))
    path = save_record(rec, tmp_path)
    out_yaml = tmp_path / "imu.yaml"
    rc, _, err = _run(capsys, ["noise", str(path), "--kalibr", str(out_yaml), "--kalibr-accel", ACCEL])
    assert rc == 2 and "have accelerometer channels" in err and not out_yaml.exists()
    rc, out, _ = _run(capsys, ["noise", str(path), "--json", "--kalibr", str(out_yaml)])
    assert rc == 0
    o = json.loads(out)
    ch = o["channels"]
    assert set(ch) == {f"{s}_{c}" for s in ("gyro", "acc") for c in "xyz"}
    arw = {"x": 0.3, "y": 0.3, "z": 0.3 * math.sqrt(5.0)}
    for c, truth in arw.items():
        assert ch[f"gyro_{c}"]["headline"]["arw"]["curve"]["value"] == pytest.approx(truth, rel=0.05), c
        acc = ch[f"acc_{c}"]["headline"]["arw"]["curve"]
        assert acc["unit"] == "m/s/sqrt(h)" and acc["value"] == pytest.approx(60e-4 * 9.80665, rel=0.05), c
    topic, rate, acc, gyro = kalibr_imu_parameters(out_yaml)
    assert gyro[2] == pytest.approx(arw["z"] * math.pi / 180 / 60, rel=0.05)
    assert acc[2] == pytest.approx(100e-6 * 9.80665, rel=0.1)
    assert rate == pytest.approx(100.0) and o["kalibr"]["update_rate"] == pytest.approx(100.0)
