"""imu_tk's Xsens multi-position recording (tests/data/imutk, BSD; 37 static poses moved by hand, 100 Hz, raw
counts): ``gyrojax import imutk`` detects the poses, calibrates the accelerometer, and the triad fit uses the
gravity-to-gravity moves between poses to find scale factor and misalignment as well as bias. Checked
independently: the calibrated rates (``apply``), integrated with scipy's rotations, carry each pose's measured
gravity direction onto the next pose's, far better than the nominal scale does."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax.cli.app import main
from gyrojax.data.importers import import_csv
from gyrojax.data.records import load_records
from gyrojax.data.segments import static_intervals
from gyrojax.errors import RecordError
from gyrojax.inference.triad import fit_triad

from .conftest import DATA

IMUTK = DATA / "imutk"
SCALE = 6258.0 * np.pi / 180.0  # imu_tk's nominal Xsens gyro scale, 6258 counts per rad/s, in counts per deg/s


@pytest.fixture(scope="module")
def xsens(tmp_path_factory):
    out = tmp_path_factory.mktemp("imutk")
    args = ["import", "imutk", str(IMUTK / "xsens_acc.mat.gz"), str(IMUTK / "xsens_gyro.mat.gz")]
    args += ["--gyro-scale", str(SCALE), "--gravity", "9.81744", "--out", str(out), "--json"]
    assert main(args) == 0
    (rec,) = load_records(out)
    return rec, fit_triad(rec)


def _move_errors(rec, rates_dps):
    """Angle (deg) between each next pose's measured Up and the previous pose's Up carried by the rates."""
    seg = rec.columns["segment"]
    acc = np.stack([rec.columns[f"acc_{c}_g"] for c in "xyz"], axis=1)
    dt = np.diff(rec.time_s).mean()
    errs = []
    for s in rec.meta["segments"]:
        if s["type"] != "move":
            continue
        u0 = acc[seg == s["from"]].mean(axis=0)
        u1 = acc[seg == s["to"]].mean(axis=0)
        idx = np.flatnonzero(seg == s["label"])
        w = np.radians(rates_dps[idx[0] - 1 : idx[-1] + 2])
        rot = Rotation.identity()
        for v in 0.5 * (w[1:] + w[:-1]) * dt:
            rot = rot * Rotation.from_rotvec(v)
        pred = rot.inv().apply(u0 / np.linalg.norm(u0))
        errs.append(np.degrees(np.arccos(np.clip(pred @ (u1 / np.linalg.norm(u1)), -1, 1))))
    return np.array(errs)


def test_imutk_poses_and_accelerometer(xsens):
    rec, _ = xsens
    kinds = [s["type"] for s in rec.meta["segments"]]
    # 38 rests: the 37 of the 2 s detector and the 3.3 s rest at 208.4–211.7 s between two moves that it missed
    # (its 1 s window trimmed twice left 1.3 s < its 2 s minimum); tests/test_importers.py checks each gap turns
    assert kinds.count("static") == 38 and kinds.count("move") == 37
    acc = np.stack([rec.columns[f"acc_{c}_g"] for c in "xyz"], axis=1)
    seg = rec.columns["segment"]
    norms = [np.linalg.norm(acc[seg == s["label"]].mean(axis=0)) for s in rec.meta["segments"] if s["type"] == "static"]
    assert np.allclose(norms, 9.81744 / 9.80665, atol=2e-3)  # |a| = local g at every pose


def test_imutk_moves_give_scale_factor_and_misalignment(xsens):
    rec, res = xsens
    v, s = res.values, res.stds
    for ch in "xyz":
        for name in ("E_SF", "M_O", "M_S", "D_F"):
            assert s[f"{name}[{ch}]"] is not None and np.isfinite(s[f"{name}[{ch}]"]), name
        # the nominal 6258 counts per rad/s is off by the same factor on all three axes
        assert abs(v[f"E_SF[{ch}]"] - v["E_SF[x]"]) < 0.02e6
    nominal = (np.stack([rec.columns[f"gyro_{c}_counts"] for c in "xyz"], axis=1) - 32768.0) / SCALE
    before = _move_errors(rec, nominal)
    after = _move_errors(rec, res.apply(rec) / 3600.0)
    assert np.median(after) < 0.2 and np.median(before) > 5 * np.median(after), (np.median(before), np.median(after))
    # the bias is the mean of the initial 50 s rest, within a few σ (plus the Earth rate, ≤ 15 deg/h, and the
    # g-sensitivity of that pose)
    seg = rec.columns["segment"]
    g0 = np.stack([rec.columns[f"gyro_{c}_counts"] for c in "xyz"], axis=1)[seg == 0].mean(axis=0) / SCALE * 3600
    a0 = np.stack([rec.columns[f"acc_{c}_g"] for c in "xyz"], axis=1)[seg == 0].mean(axis=0)
    m = res.matrices()
    assert np.all(np.abs(g0 - (m["b"] + m["G"] @ a0)) < 5 * np.array([s[f"D_F[{c}]"] for c in "xyz"]) + 15.1)


def test_generic_csv_importer(tmp_path):
    acc = np.loadtxt(IMUTK / "xsens_acc.mat.gz")[:20400]
    gyr = np.loadtxt(IMUTK / "xsens_gyro.mat.gz")[:20400]
    path = tmp_path / "log.csv"
    header = "t,ax,ay,az,gx,gy,gz"
    np.savetxt(path, np.column_stack([acc, gyr[:, 1:]]), delimiter=",", header=header, comments="")
    mapping = {
        "time_s": "t",
        "acc_x": "ax",
        "acc_y": "ay",
        "acc_z": "az",
        "gyro_x": "gx",
        "gyro_y": "gy",
        "gyro_z": "gz",
    }
    rec = import_csv(path, mapping, acc_unit="counts", gyro_unit="counts", gyro_counts_per_dps=SCALE)
    kinds = [s["type"] for s in rec.meta["segments"]]
    assert kinds.count("static") >= 12 and kinds.count("move") == kinds.count("static") - 1
    assert (
        main(
            [
                "import",
                "csv",
                str(path),
                "--map",
                ",".join(f"{k}={v}" for k, v in mapping.items()),
                "--acc-unit",
                "counts",
                "--gyro-scale",
                str(SCALE),
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 0
    )
    short = tmp_path / "short.csv"
    short.write_text("\n".join(path.read_text().splitlines()[:12001]) + "\n")
    with pytest.raises(RecordError, match=r"found \d static poses; the calibration needs at least 9"):
        import_csv(short, mapping, acc_unit="counts", gyro_unit="counts", gyro_counts_per_dps=SCALE)
    with pytest.raises(RecordError, match=r"\['gyro_z'\] missing"):
        import_csv(path, {k: v for k, v in mapping.items() if k != "gyro_z"})
    iv = static_intervals(acc[:, 1:], 100.0, gyro=gyr[:, 1:])
    assert iv[0][0] == 0 and iv[0][1] > 4500  # the initial 50 s rest comes first


def test_cli_import_imutk_needs_a_scale(tmp_path, capsys):
    args = [
        "import",
        "imutk",
        str(IMUTK / "xsens_acc.mat.gz"),
        str(IMUTK / "xsens_gyro.mat.gz"),
        "--out",
        str(tmp_path),
    ]
    assert main(args) == 2
    assert "nominal scale" in capsys.readouterr().err
    assert main(["import", "imutk", str(IMUTK / "xsens_acc.mat.gz"), "--out", str(tmp_path)]) == 2
    assert "ACC GYRO" in capsys.readouterr().err


def test_imutk_fit_does_not_depend_on_the_nominal_scale(xsens, tmp_path):
    """The same recording imported with a nominal scale 24 % below imu_tk's (83.25 counts per deg/s, near the
    fitted one): the indicated rates are k = SCALE / 83.25 times larger, so S, b, G and σ scale by k and χ² stays
    (it was 319.7 against 254.9 on 167 dof while the moves' noise stayed at the nominal scale)."""
    rec, res = xsens
    low = 83.25
    args = ["import", "imutk", str(IMUTK / "xsens_acc.mat.gz"), str(IMUTK / "xsens_gyro.mat.gz")]
    assert main(args + ["--gyro-scale", str(low), "--gravity", "9.81744", "--out", str(tmp_path), "--json"]) == 0
    (rec2,) = load_records(tmp_path)
    other = fit_triad(rec2)
    k = SCALE / low
    assert other.dof == res.dof
    assert other.chi2 == pytest.approx(res.chi2, rel=1e-7)  # tolerance derived in tests/test_triad_moves.py
    for name in res.values:
        assert other.stds[name] == pytest.approx(k * res.stds[name], rel=1e-6), name


def test_its_38_rests_determine_the_accelerometer(xsens):
    """Each axis up and down, 29 rests beyond the ellipsoid's 9 parameters: scale factors to ±0.06 % and biases to
    ±0.6 mg at 0.1 % of g per rest, and no note that the rests determine the calibration poorly (the MPU-6050
    session's 10 rests get one, tests/test_importers.py)."""
    rec, fit = xsens
    std = rec.meta["accelerometer_calibration"]["std_at_rest_error"]
    assert max(std["scale"]) < 1e-3 and max(std["bias"]) < 1e-3 and max(std["misalignment"]) < 1e-2
    assert not any("determine the accelerometer's calibration poorly" in n for n in rec.meta["import"]["notes"])
    assert not any("determine the accelerometer's calibration poorly" in n for n in fit.notes)
