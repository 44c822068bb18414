"""The triad fit is never silent about a misdeclared import (:mod:`gyrojax.inference.triad_checks`), and reports its
misalignments as angles (:func:`gyrojax.physics.triad.misalignment_angles`).

The cases are the issue's own, on imu_tk's real Xsens session (tests/data/imutk, BSD; 100 Hz, raw counts, a time
column), written as a CSV the way a user would and imported with ``import csv``: the time column dropped and
``--rate-hz 200`` given (E_SF −62 % instead of −24 %), the gyro in deg/s declared rad/s, gyro_x and gyro_y swapped in
``--map``, the time column in ms read as seconds. Each must end in a refusal or a warning that names the flag —
at the import or at the fit — never in exit 0 and silence."""

import json

import numpy as np
import pytest

from gyrojax import units
from gyrojax.cli.app import main
from gyrojax.inference.triad_checks import plausibility_notes
from gyrojax.physics import triad as tp

from .conftest import DATA

IMUTK = DATA / "imutk"
NOMINAL = 6258.0 * np.pi / 180.0  # imu_tk's nominal Xsens scale, counts per deg/s (109.22)
FITTED = 83.25  # the scale this unit has (the fit's, docs/mems_imu.md)
ACC = "acc_x=ax,acc_y=ay,acc_z=az"


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("xsens-csv")
    acc = np.loadtxt(IMUTK / "xsens_acc.mat.gz")
    gyr = np.loadtxt(IMUTK / "xsens_gyro.mat.gz")
    t = acc[:, 0] - acc[0, 0]

    def write(name, cols, header):
        np.savetxt(d / f"{name}.csv", np.column_stack(cols), delimiter=",", header=header, comments="", fmt="%.9g")

    write("base", [t, acc[:, 1:], gyr[:, 1:]], "t,ax,ay,az,gx,gy,gz")
    write("notime", [acc[:, 1:], gyr[:, 1:]], "ax,ay,az,gx,gy,gz")
    write("dps", [t, acc[:, 1:], (gyr[:, 1:] - 32768) / FITTED], "t,ax,ay,az,gx,gy,gz")
    write("ms", [t * 1000, acc[:, 1:], gyr[:, 1:]], "t,ax,ay,az,gx,gy,gz")
    return d


CASES = {
    "rate-hz 200 for 100 Hz": ("notime", f"gyro_x=gx,gyro_y=gy,gyro_z=gz,{ACC}", ["--rate-hz", "200"], "--rate-hz"),
    "deg/s as rad/s": ("dps", f"time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,{ACC}", ["--gyro-unit", "rad/s"], "--gyro-unit"),
    "gyro x and y swapped": ("base", f"time=t,gyro_x=gy,gyro_y=gx,gyro_z=gz,{ACC}", [], "--map"),
    "time in ms as s": ("ms", f"time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,{ACC}", [], "--time-unit"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_each_mistake_ends_in_a_refusal_or_a_warning_naming_the_flag(logs, tmp_path, capsys, case):
    stem, mapping, flags, flag = CASES[case]
    scale = [] if "--gyro-unit" in flags else ["--gyro-scale", str(NOMINAL)]
    argv = ["import", "csv", str(logs / f"{stem}.csv"), "--map", mapping, "--acc-unit", "counts", *scale, *flags]
    capsys.readouterr()
    rc = main(argv + ["--out", str(tmp_path / "rec"), "--json"])
    said = capsys.readouterr()
    if rc == 2:  # refused at the door, naming the flag
        assert flag in said.err, (case, said.err)
        return
    assert rc == 0
    rc = main(["fit", str(tmp_path / "rec"), "--json"])
    said = capsys.readouterr()
    if rc == 2:
        assert said.err.count("\n") == 1 and flag in said.err, (case, said.err)
    else:  # a warning on stderr and a note in the JSON, both naming the flag
        assert rc == 0 and flag in said.err and "warning" in said.err, (case, said.err)
        assert any(flag in n for n in json.loads(said.out)["notes"])


def test_the_right_import_warns_only_about_the_nominal_scale(logs, tmp_path, capsys):
    """imu_tk's nominal Xsens scale (109.22 counts per deg/s) is 31 % above this unit's: the fit's E_SF −24 % on all
    three channels is beyond a MEMS gyro's ±20 %, and said as the common ratio it is."""
    argv = ["import", "csv", str(logs / "base.csv"), "--map", f"time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,{ACC}"]
    assert main(argv + ["--acc-unit", "counts", "--gyro-scale", str(NOMINAL), "--out", str(tmp_path / "r")]) == 0
    capsys.readouterr()
    assert main(["fit", str(tmp_path / "r"), "--json"]) == 0
    said = capsys.readouterr()
    res = json.loads(said.out)
    for ch in "xyz":
        assert res["coefficients"][f"E_SF[{ch}]"]["value"] == pytest.approx(-2.4e5, abs=6e3)
    (note,) = [n for n in res["notes"] if n.startswith("implausible")]
    assert "common ratio 0.76" in note and "--gyro-scale" in note
    # the misalignments, as angles, are within a MEMS triad's 10°: no warning about them
    assert "misalignment" not in said.err


# ---- misalignment as geometry -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def xsens_two_scales(tmp_path_factory):
    out = {}
    for scale in (NOMINAL, FITTED):
        d = tmp_path_factory.mktemp("xsens-scale")
        args = ["import", "imutk", str(IMUTK / "xsens_acc.mat.gz"), str(IMUTK / "xsens_gyro.mat.gz")]
        assert main(args + ["--gyro-scale", str(scale), "--gravity", "9.81744", "--out", str(d)]) == 0
        out[scale] = d
    return out


def test_xsens_misalignment_angles_do_not_depend_on_the_nominal_scale(xsens_two_scales, capsys):
    res = {}
    for scale, d in xsens_two_scales.items():
        capsys.readouterr()
        assert main(["fit", str(d), "--json"]) == 0
        res[scale] = json.loads(capsys.readouterr().out)
    a, b = (res[s]["misalignment_angles"] for s in (NOMINAL, FITTED))
    # the nominal-scale form differs by the scale's ratio (8311″ against about 10 904″ for M_O[y]) …
    mo = [res[s]["coefficients"]["M_O[y]"]["value"] for s in (NOMINAL, FITTED)]
    assert mo[1] / mo[0] == pytest.approx(NOMINAL / FITTED, rel=2e-3) and mo[0] == pytest.approx(8311, abs=5)
    # … the angles do not (the fit is the same up to the scale, to 1e-7)
    for k in a:
        if k == "definition":
            continue
        assert a[k]["value"] == pytest.approx(b[k]["value"], rel=1e-6, abs=1e-3), k
        assert a[k]["std"] == pytest.approx(b[k]["std"], rel=1e-5), k
    # and they are the angles of the fitted S's rows (independently: the rows normalised, by numpy)
    s = np.array(res[FITTED]["matrices"]["S"])
    for c, ch in enumerate("xyz"):
        i, o, sa = tp.FRAMES[c]
        row = s[c] / np.linalg.norm(s[c])
        assert b[f"M_O[{ch}]"]["value"] == pytest.approx(np.degrees(np.arctan2(row[o], row[i])) * 3600, abs=1e-6)
        assert b[f"psi[{ch}]"]["value"] == pytest.approx(np.degrees(np.arccos(row[i])) * 3600, rel=1e-6)


def test_misalignment_angle_sigma_against_monte_carlo():
    """The delta-method σ of the angles against the spread of the angles of coefficients drawn from the same
    covariance (numpy's multivariate normal, 20 000 draws)."""
    names = [tp.channel_name(c, ch) for ch in tp.CHANNELS for c in ("E_SF", "M_O", "M_S")]
    values = dict(zip(names, [-2.4e5, 8000.0, -1500.0, 1.2e4, -3000.0, 600.0, 3e3, 200.0, -7000.0]))
    rng = np.random.default_rng(1)
    a = rng.normal(size=(9, 9))
    sd = np.diag(np.tile([300.0, 90.0, 90.0], 3))  # ppm, arcsec, arcsec
    cov = sd @ (a @ a.T / 9) @ sd
    got = tp.misalignment_angles(values, cov, names)
    draws = rng.multivariate_normal([values[n] for n in names], cov, size=20000)
    mc = np.array([[v["value"] for v in tp.misalignment_angles(dict(zip(names, d))).values()] for d in draws[:4000]])
    for j, (k, v) in enumerate(got.items()):
        assert v["std"] == pytest.approx(mc[:, j].std(), rel=0.06), k


# ---- the notes' wording, on constructed values ------------------------------------------------------------------


def _values(s: np.ndarray) -> dict:
    """Per-channel E_SF (ppm) and M_O, M_S (arcsec) of a scale-and-misalignment matrix S (conventions §9.3)."""
    out = {}
    for c, ch in enumerate(tp.CHANNELS):
        i, o, sa = tp.FRAMES[c]
        out[f"E_SF[{ch}]"] = (s[c, i] - 1) / units.PPM
        out[f"M_O[{ch}]"] = s[c, o] / units.ARCSEC
        out[f"M_S[{ch}]"] = s[c, sa] / units.ARCSEC
    return out


@pytest.mark.parametrize(
    "s, words",
    [
        (np.eye(3) * 57.2958 * 1.01, ["180/π", "--gyro-unit"]),
        (np.eye(3) / 1000 * 1.1, ["--time-unit"]),
        (np.eye(3) * 0.38, ["common ratio 0.38", "--rate-hz", "--gyro-scale"]),
        (np.diag([0.5, 0.9, 1.2]), ["--gyro-scale", "--gyro-unit"]),
        (np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), ["body x is gyro_y", "--map"]),
        (np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]), ["-gyro_y", "--map"]),
    ],
)
def test_plausibility_notes_name_the_flag(s, words):
    notes = plausibility_notes(_values(s))
    text = " ".join(notes)
    assert notes and all(w in text for w in words), notes


def test_plausible_values_say_nothing():
    rng = np.random.default_rng(0)
    s = np.eye(3) + rng.normal(scale=0.03, size=(3, 3))  # 3 % scale, ~1.7° misalignment
    assert plausibility_notes(_values(s)) == []
