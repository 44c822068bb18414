"""Gyro-only sessions: rotations of known angle and rests, no accelerometer (:mod:`gyrojax.data.gyroonly`).

The real session: imucal's Ferraris recording (tests/data/imucal, MIT) with its accelerometer columns dropped. That
is a real gyro-only session for imucal's gyro calibration too: imucal's FerrarisCalibration (mad-lab-fau/imucal
8716e4c, ``ferraris_calibration.py``) takes the gyro bias b_g as the mean of the six static faces, the
g-sensitivity K_ga from the faces' gyro means against their labels (±grav), and K_g R_g from the integrals of the
three 360° turns less b_g + K_ga a, where a is the calibrated accelerometer during the turn — the one place the
accelerometer enters. Replacing that a by the face the turn is made on (grav along the turn's axis) changes imucal's
integrals by at most 2e-3° of 356–366° (measured on this session; the hand's wobble times a K_ga of 0.02 counts per
m/s²), so its published K_g R_g and b_g are the reference of a gyro-only calibration of the same session."""

import json

import numpy as np
import pandas as pd
import pytest

from gyrojax import units
from gyrojax.cli.app import main
from gyrojax.data.records import load_record
from gyrojax.physics.triad import FRAMES

from .conftest import IMUCAL
from .test_triad_imucal import SCALE, imucal_reference

MAP = "sample=samples,gyro_x=gyr_x,gyro_y=gyr_y,gyro_z=gyr_z"


@pytest.fixture(scope="module")
def gyro_only_csv(tmp_path_factory):
    """imucal's session without its accelerometer: a sample counter and three gyro columns, in the session's order."""
    d = tmp_path_factory.mktemp("gyro-only")
    df = pd.read_csv(IMUCAL / "annotated_session.csv").sort_values("samples")
    df[["samples", "gyr_x", "gyr_y", "gyr_z"]].to_csv(d / "session.csv", index=False)
    return d / "session.csv"


@pytest.fixture(scope="module")
def fitted(gyro_only_csv, tmp_path_factory):
    out = tmp_path_factory.mktemp("gyro-only-rec")
    argv = ["import", "csv", str(gyro_only_csv), "--map", MAP, "--rate-hz", "204.8", "--gyro-scale", str(SCALE)]
    assert main(argv + ["--rotations", "x:360,y:360,z:360", "--out", str(out)]) == 0
    return out


def test_the_import_finds_the_three_turns(fitted):
    rec = load_record(fitted / "session.json")
    assert "acc_x_g" not in rec.columns
    kinds = [s["type"] for s in rec.meta["segments"]]
    assert kinds.count("rotation") == 3 and kinds.count("static") >= 1
    rots = rec.meta["import"]["rotations"]
    assert [r["axis"] for r in rots] == ["x", "y", "z"]
    # the turns as imucal's sections hold them (27.3–33.7, 33.7–39.0, 39.0–46.0 s): each found inside its section,
    # its integral at the nominal scale within 3° of 360° × imucal's own scale factor about its axis
    cal = json.loads((IMUCAL / "example_cal.json").read_text())
    k = np.diag(cal["K_g"]) / SCALE
    for r, (lo, hi), kk, i in zip(rots, [(27.3, 33.8), (33.6, 39.4), (38.9, 46.0)], k, range(3)):
        assert lo <= r["start_s"] < r["end_s"] <= hi
        assert abs(r["integrated_deg"][i]) == pytest.approx(360 * kk, abs=3.0)


def test_gyro_only_fit_gives_imucals_gyro_calibration(fitted, capsys):
    capsys.readouterr()
    assert main(["fit", str(fitted), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["terms"] == ["D_F", "sf_error", "ia_misalignment"]  # no specific force: no g-terms
    assert any("no specific force" in n for n in res["notes"])
    ref = imucal_reference()
    for ch in "xyz":
        for c in ("D_F", "E_SF", "M_O", "M_S"):
            name = f"{c}[{ch}]"
            got = res["coefficients"][name]
            assert abs(got["value"] - ref[name]) < 3 * got["std"], (name, got, ref[name])
    # imucal's R_g rows are the unit sensing axes (its sign for counter-clockwise turns undone): their angles to
    # the body frame are the fit's misalignment angles, whatever the scale
    cal = json.loads((IMUCAL / "example_cal.json").read_text())
    rg = -np.array(cal["R_g"])
    ang = res["misalignment_angles"]
    for c, ch in enumerate("xyz"):
        i, o, s = FRAMES[c]
        for key, j in (("M_O", o), ("M_S", s)):
            want = np.arctan2(rg[c, j], rg[c, i]) / units.ARCSEC
            got = ang[f"{key}[{ch}]"]
            assert abs(got["value"] - want) < 3 * got["std"], (key, ch, got, want)
    assert res["fit"]["p_value"] > 0.01  # the rests and turns agree with the noise and the pauses' angles


def test_g_terms_need_a_specific_force(fitted, capsys):
    capsys.readouterr()
    assert main(["fit", str(fitted), "--terms", "D_F,D_I,sf_error"]) == 2
    err = capsys.readouterr().err
    assert "D_I" in err and "rest-0" in err and "no accelerometer" in err


@pytest.mark.parametrize(
    "flags, words",
    [
        (["--rate-hz", "1024", "--gyro-scale", str(SCALE)], ["--rate-hz", "too small"]),  # every turn 5× too short
        (["--rate-hz", "204.8", "--gyro-unit", "rad/s"], ["--gyro-unit", "deg/s declared as rad/s"]),
        (
            ["--rate-hz", "204.8", "--gyro-scale", str(SCALE), "--rotations", "y:360,x:360,z:360"],
            ["x:360, z:360", "--map"],
        ),
    ],
)
def test_misdeclared_gyro_only_imports_are_refused_naming_the_flag(gyro_only_csv, tmp_path, capsys, flags, words):
    src = gyro_only_csv
    if "--gyro-unit" in flags:  # the same session in deg/s, declared rad/s
        df = pd.read_csv(gyro_only_csv)
        df[["gyr_x", "gyr_y", "gyr_z"]] /= SCALE
        src = tmp_path / "session.csv"
        df.to_csv(src, index=False)
    argv = ["import", "csv", str(src), "--map", MAP, *flags]
    if "--rotations" not in flags:
        argv += ["--rotations", "x:360,y:360,z:360"]
    capsys.readouterr()
    assert main(argv + ["--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and all(w in err for w in words), err
    assert not (tmp_path / "o").exists()


def test_rotations_from_a_file_and_the_refusals_of_the_option(gyro_only_csv, tmp_path, capsys):
    f = tmp_path / "turns.csv"
    f.write_text("axis,angle_deg,angle_std_deg\nx,360,0.5\ny,360,0.5\nz,360,0.5\n")
    argv = ["import", "csv", str(gyro_only_csv), "--map", MAP, "--rate-hz", "204.8", "--gyro-scale", str(SCALE)]
    assert main(argv + ["--rotations", str(f), "--out", str(tmp_path / "a")]) == 0
    rec = load_record(tmp_path / "a" / "session.json")
    assert [s.get("angle_std_deg") for s in rec.meta["segments"] if s["type"] == "rotation"] == [0.5] * 3
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"rotations": [{"axis": "w", "angle_deg": 360}]}))
    capsys.readouterr()
    assert main(argv + ["--rotations", str(bad), "--out", str(tmp_path / "b")]) == 2
    assert "bad.json" in capsys.readouterr().err
    assert main(argv + ["--rotations", "x:abc", "--out", str(tmp_path / "b")]) == 2
    assert "--rotations" in capsys.readouterr().err
    assert main(argv + ["--out", str(tmp_path / "b")]) == 2  # no accelerometer and no rotations
    assert "--rotations" in capsys.readouterr().err
