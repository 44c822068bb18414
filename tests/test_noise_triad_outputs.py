"""``gyrojax noise`` on imu-triad records (issue 25): ``--plot`` writes one figure per sensor with a panel per
channel (each channel's own ADEV, never pooled) in that channel's units, the accelerometer channels' ``--json`` and
text figures in accelerometer units (VRW m/s/√h, B m/s², K m/s²/√h; :mod:`gyrojax.noise.sensor_units`) tied to
their own ADEV by IEEE 952's closed forms, and bad input refused in one line before any work."""

import json
import math

import numpy as np
import pytest

from gyrojax.cli.app import main
from gyrojax.data import plans
from gyrojax.data.records import save_record
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.report.figures import noise_channels_figure
from gyrojax.simulation.simulator import simulate
from gyrojax.simulation.triad import simulate_multiposition

from .kalibr_reader import kalibr_imu_parameters

BI_FACTOR = math.sqrt(2 * math.log(2) / math.pi)  # IEEE 952 C.1: σ_min = 0.664 B


@pytest.fixture(scope="module")
def triad(tmp_path_factory):
    """A 100 Hz session, 6 rests of 100 s, gyro white 0.05 deg/s and accelerometer white 1 mg per sample, run once
    with --json --plot --kalibr and once as text."""
    d = tmp_path_factory.mktemp("triadout")
    rec = simulate_multiposition(mems_truth(3), poses=6, static_s=100.0, gyro_noise_dps=0.05, acc_noise_g=0.001)
    path = save_record(rec, d)
    return path, d


def _run(capsys, args):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


@pytest.fixture(scope="module")
def report(triad):
    import contextlib
    import io

    path, d = triad
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["noise", str(path), "--json", "--plot", str(d / "adev.png"), "--kalibr", str(d / "imu.yaml")])
    assert rc == 0
    return json.loads(buf.getvalue())


def _strings(x):
    if isinstance(x, dict):
        for k, v in x.items():
            yield k
            yield from _strings(v)
    elif isinstance(x, list):
        for v in x:
            yield from _strings(v)
    elif isinstance(x, str):
        yield x


def test_plot_one_figure_per_sensor(triad, report):
    _, d = triad
    paths = [str(d / "adev_gyro.png"), str(d / "adev_accel.png")]
    assert report["plots"] == paths
    for p in paths:
        with open(p, "rb") as fh:
            assert fh.read(4) == b"\x89PNG"
    assert not (d / "adev.png").exists()


def test_panels_carry_their_channels_units_and_data(report):
    ch = report["channels"]
    for sensor, unit, n_unit in (("gyro", "deg/h", "deg/sqrt(h)"), ("acc", "m/s²", "m/s/sqrt(h)")):
        chans = {k: v for k, v in ch.items() if k.startswith(sensor)}
        fig = noise_channels_figure(chans)
        for ax, (name, out) in zip(fig.axes, chans.items()):
            assert ax.get_ylabel() == f"Allan deviation ({unit})" and ax.get_title() == name
            key = "adev_deg_per_h" if sensor == "gyro" else "adev_mps2"
            adev = next(ln for ln in ax.lines if ln.get_label() == "overlapping ADEV")
            np.testing.assert_array_equal(adev.get_ydata(), out[key])  # this channel's own ADEV, not a pool
            labels = [t.get_text() for t in ax.get_legend().get_texts()]
            assert any(lb.startswith("N = ") and n_unit in lb for lb in labels), labels
            if sensor == "acc":
                assert not any("deg" in lb for lb in labels), labels


def test_accelerometer_json_in_accelerometer_units(report):
    """No accelerometer string says deg; each headline figure equals its closed form of the ADEV it was read from
    (VRW = 60·σ·√τ m/s/√h, B = σ/0.664 m/s², K = σ·√(3·3600/τ) m/s²/√h, at the point or the upper band edge);
    gyro channels keep deg/h."""
    for c in "xyz":
        acc, gyro = report["channels"][f"acc_{c}"], report["channels"][f"gyro_{c}"]
        assert not [s for s in _strings(acc) if "deg" in s]
        assert "adev_deg_per_h" not in acc and len(acc["adev_mps2"]) == len(acc["taus_s"])
        assert acc["model"]["parameters"]["white"]["unit"] == "m/s/sqrt(h)"
        assert gyro["headline"]["arw"]["curve"]["unit"] == "deg/sqrt(h)" and "adev_deg_per_h" in gyro
        closed = {
            "arw": lambda s, t: 60 * s * math.sqrt(t),
            "bias_instability": lambda s, t: s / BI_FACTOR,
            "rrw": lambda s, t: s * math.sqrt(3 * 3600 / t),
        }
        for name, f in closed.items():
            v = acc["headline"][name]["curve"]
            if v["value"] is None:
                continue
            i = acc["taus_s"].index(v["tau_s"])
            if v["kind"] == "upper bound":  # one-sided at BOUND_LEVEL: beyond the ±1σ end (headline module doc)
                assert v["value"] > f(acc["adev_high"][i], v["tau_s"]), (c, name)
            else:
                assert v["value"] == pytest.approx(f(acc["adev_mps2"][i], v["tau_s"]), rel=1e-9), (c, name)
        for name, fig in acc["headline"].items():  # every interval in the same unit as its value: it brackets it
            for side in ("curve", "model"):
                v = fig[side]
                if v.get("value") is not None and v.get("ci") is not None and v.get("kind") != "upper bound":
                    assert v["ci"][0] <= v["value"] <= v["ci"][1], (c, name, side, v)
        # 1 mg white at 100 Hz: σ_a = 9.80665e-3·√0.01 m/s²/√Hz, VRW = 60 σ_a m/s/√h
        assert acc["headline"]["arw"]["model"]["value"] == pytest.approx(60 * 9.80665e-4, rel=0.05)


def test_text_output_in_channel_units(triad, capsys):
    path, d = triad
    rc, out, _ = _run(capsys, ["noise", str(path), "--plot", str(d / "text.png")])
    assert rc == 0
    blocks = out.split("acc_")
    assert "deg/sqrt(h)" in blocks[0] and all("deg" not in b.split("gyro_")[0] for b in blocks[1:])
    assert "m/s/sqrt(h)" in out and "m/s^2" in out
    assert f"plot -> {d / 'text_gyro.png'}" in out and f"plot -> {d / 'text_accel.png'}" in out


def test_bad_input_refused_cleanly(triad, capsys, tmp_path):
    path, d = triad
    (tmp_path / "p_accel.png").write_bytes(b"keep")
    rc, _, err = _run(capsys, ["noise", str(path), "--plot", str(tmp_path / "p.png")])
    assert rc == 2 and "p_accel.png: exists" in err and len(err.splitlines()) == 1
    assert (tmp_path / "p_accel.png").read_bytes() == b"keep" and not (tmp_path / "p_gyro.png").exists()
    sdf = simulate(plans.fixed_position(hours=0.2, dt_s=0.5), {"noise": {"white": 0.01}}, seed=1)
    sdf_path = save_record(sdf[0], tmp_path)
    rc, _, err = _run(capsys, ["noise", str(path), str(sdf_path), "--plot", str(tmp_path / "q.png")])
    assert rc == 2 and "cannot be analysed together" in err and not list(tmp_path.glob("q*.png"))
    for bad in (str(tmp_path), ""):  # a directory or no name: no STEM for the per-sensor files
        rc, _, err = _run(capsys, ["noise", str(path), "--plot", bad])
        assert rc == 2 and "--plot" in err and len(err.splitlines()) == 1, err


def test_gyro_only_triad(tmp_path, capsys):
    """A triad record without accelerometer columns: --kalibr refused before any work unless --kalibr-accel gives
    the pair; with it the file holds the pair as given, and --plot writes the gyro figure only."""
    rec = simulate_multiposition(mems_truth(4), poses=6, static_s=60.0, gyro_noise_dps=0.05, acc_noise_g=0.001)
    seg = np.asarray(rec.columns["segment"])
    acc = np.stack([np.asarray(rec.columns.pop(f"acc_{c}_g")) for c in "xyz"], axis=1)
    for spec in rec.meta["segments"]:  # without an accelerometer a rest names its Up (conventions §9.3)
        if spec["type"] == "static":
            up = acc[seg == spec["label"]].mean(axis=0)
            spec["up"] = [float(u) for u in up / np.linalg.norm(up)]
    path = save_record(rec, tmp_path)
    y = tmp_path / "imu.yaml"
    rc, _, err = _run(capsys, ["noise", str(path), "--kalibr", str(y)])
    assert rc == 2 and "--kalibr-accel" in err and not y.exists()
    rc, out, _ = _run(
        capsys,
        ["noise", str(path), "--kalibr", str(y), "--kalibr-accel", "2e-3,3e-4", "--plot", str(tmp_path / "a.png")],
    )
    assert rc == 0 and f"plot -> {tmp_path / 'a_gyro.png'}" in out and "a_accel" not in out
    _, _, acc, _ = kalibr_imu_parameters(y)
    assert acc[2] == 2e-3 and acc[1] == 3e-4
