"""``gyrojax import table``: turntable data systems' logs into conventions records, checked on logs that an
independent generator wrote from the conventions alone (tests/tablelog_writer.py: plain numpy, its own kinematics,
effects and noise; no gyrojax import).

The done-when of the table door: a FOG on a single-axis rate table, its output in volts at a nominal scale on a data
system of its own (µs clock, 100 Hz), the table's encoder counts on a 50 Hz millisecond clock, a temperature column,
three mountings (IA, OA, SA up): the record gives back the scale factor, bias and misalignment it was simulated with,
within the fit's σ, and that σ is the one ordinary least squares on the generator's own inputs and noise gives; and
``diagnose`` finds the effect the generator hid (a scale-factor asymmetry).
"""

import json

import numpy as np
import pytest

from gyrojax.cli.app import main
from gyrojax.data.records import load_record, load_records

from . import tablelog_writer as tw

ARCSEC = np.pi / 180 / 3600
TRUTH = {"D_F": 2.5, "E_SF": 1500.0, "M_O": 300.0, "M_S": -200.0}
HIDDEN = {"E_A": 40.0}
SIGMA = 30.0  # deg/h per sample at 100 Hz: ARW 0.05 deg/√h
RATE_SCHEDULE = [
    ("position", [0.0], 20.0),
    ("rate", [10.0], 36.0),  # one revolution
    ("rate", [-10.0], 36.0),
    ("rate", [30.0], 24.0),  # two
    ("rate", [-30.0], 24.0),
    ("rate", [100.0], 18.0),  # five
    ("rate", [-100.0], 18.0),
    ("position", [90.0], 20.0),
]
MOUNTINGS = {  # (IA, OA) in platform coordinates, the table's axis Up
    "ia-up": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    "oa-up": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "sa-down": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
}
SETUP = """
kind = "fog"
site = {{latitude_deg = 39.98, gravity_mps2 = 9.80155}}
table.axes = [{{name = "spin", axis_enu = [0, 0, 1]}}]
instrument = {{ia = {ia}, oa = {oa}}}
scale = "0.02 V/(deg/s)"
clock_offset_s = {offset}
[columns]
time = {{column = "Time [ms]", unit = "ms"}}
gyro_time = {{column = "t_us", unit = "us"}}
angle_spin = {{column = "Enc1", unit = "counts", counts_per_rev = 16777216}}
output = {{column = "Vout [V]", unit = "V"}}
temperature = {{column = "Temp [C]", unit = "C"}}
"""


@pytest.fixture(scope="module")
def rate_table(tmp_path_factory):
    """Three runs' logs (two clocks each), their set-ups, and the records imported by the command line."""
    d = tmp_path_factory.mktemp("ratetable")
    out = d / "records"
    runs = {}
    for k, (name, (ia, oa)) in enumerate(MOUNTINGS.items()):
        offset = 1.234 + 0.5 * k  # the instrument's data system starts after the table's
        info = tw.rate_table_run(
            d, name, mounting=(ia, oa), schedule=RATE_SCHEDULE, truth={**TRUTH, **HIDDEN}, kind="fog",
            output="volts", sigma_dph=SIGMA, gyro_dt_s=0.01, clock_offset_s=offset, seed=10 + k,
        )  # fmt: skip
        setup = d / f"{name}.toml"
        setup.write_text(SETUP.format(ia=list(ia), oa=list(oa), offset=offset))
        argv = ["import", "table", info["files"]["table"], info["files"]["gyro"], "--setup", str(setup)]
        assert main(argv + ["--name", name, "--out", str(out), "--json"]) == 0
        runs[name] = info
    return out, runs


def test_the_logs_are_a_data_systems(rate_table):
    """The generator wrote what a data system writes: integer ms and µs clocks, wrapping encoder counts, volts."""
    _, runs = rate_table
    info = runs["ia-up"]
    table = np.genfromtxt(info["files"]["table"], delimiter=",", names=True)
    assert np.all(np.diff(table["Time_ms"]) == 20) and table["Enc1"].max() < 2**24
    assert np.any(np.diff(table["Enc1"]) < -(2**23))  # the encoder wraps at one revolution
    gyro = np.genfromtxt(info["files"]["gyro"], delimiter=",", names=True)
    assert np.all(np.diff(gyro["t_us"]) == 10000) and np.abs(gyro["Vout_V"]).max() < 2.1


def test_segments_positions_rate_steps_and_revolutions(rate_table):
    """Detected from the table's encoder alone: 2 positions, 6 rate steps of the scheduled rates and revolutions."""
    out, runs = rate_table
    rec = load_record(out / "ia-up.json")
    segs = rec.meta["import"]["segments"]
    pos = [s for s in segs if s["type"] == "position"]
    rates = [s for s in segs if s["type"] == "rate"]
    assert [s["angles_deg"]["spin"] for s in pos] == pytest.approx([0.0, 90.0], abs=1e-4)
    want = [r[0] for kind, r, _ in RATE_SCHEDULE if kind == "rate"]
    assert [s["rates_dps"]["spin"] for s in rates] == pytest.approx(want, rel=1e-6)
    # whole revolutions scheduled; the hold seen is shorter by the level test's windows at each end (≤ 1.2 s)
    turns = [abs(s["revolutions"]["spin"]) for s in rates]
    sched = [abs(r[0]) * d / 360 for kind, r, d in RATE_SCHEDULE if kind == "rate"]
    for got, full, r in zip(turns, sched, np.abs(want)):
        assert full - 1.2 * r / 360 <= got <= full
    # every kept sample lies in a hold of the generator's own labels, none in a transition
    labels = np.array(runs["ia-up"]["labels"])
    t_g = runs["ia-up"]["inputs"]["t"]
    idx = np.searchsorted(t_g, rec.time_s - 1e-9)
    assert np.all(np.abs(t_g[idx] - rec.time_s) < 1e-6)
    assert not np.any(labels[idx] == "transition")
    report = rec.meta["import"]
    assert report["transitions_left_out"]["samples"] > 0
    assert report["join"]["offset_s"] == pytest.approx(1.234)
    assert "interpolated linearly" in report["join"]["method"]


def test_rate_table_log_gives_back_scale_bias_misalignment_within_sigma(rate_table, capsys):
    out, runs = rate_table
    capsys.readouterr()
    terms = "D_F,sf_error,ia_misalignment,sf_asymmetry"
    assert main(["fit", str(out), "--terms", terms, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["coefficients"]
    truth = {**TRUTH, **HIDDEN}
    for k, want in truth.items():
        assert abs(res[k]["value"] - want) < 3 * res[k]["std"], (k, res[k], want)
    # the σ: ordinary least squares on the generator's own inputs at the kept samples, with its noise σ
    rows = []
    for rec in load_records(out):
        info = runs[rec.name]
        t_g = info["inputs"]["t"]
        idx = np.searchsorted(t_g, rec.time_s - 1e-9)
        w = info["inputs"]["w"][idx]
        rows.append(np.column_stack([np.ones(len(idx)), 1e-6 * w[:, 0], ARCSEC * w[:, 1], ARCSEC * w[:, 2],
                                     1e-6 * np.abs(w[:, 0])]))  # fmt: skip
    x = np.concatenate(rows)
    sd = SIGMA * np.sqrt(np.diag(np.linalg.inv(x.T @ x)))
    for k, s in zip(("D_F", "E_SF", "M_O", "M_S", "E_A"), sd):
        assert res[k]["std"] == pytest.approx(s, rel=0.1), (k, res[k]["std"], s)
    # the scale error is large against its σ: the test could not pass with E_SF = 0
    assert res["E_SF"]["value"] > 100 * res["E_SF"]["std"]


def test_diagnose_finds_the_hidden_asymmetry(rate_table, capsys):
    out, _ = rate_table
    capsys.readouterr()
    assert main(["diagnose", str(out), "--terms", "D_F,sf_error,ia_misalignment", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["verdict"] == "missing-effect"
    assert d["candidates"][0]["name"] == "sf_asymmetry"


# ---- every instrument kind, the set-up given by flags -------------------------------------------------------------

POSITIONS = [("position", [a, b], 40.0) for a in (0.0, 90.0, 180.0, 270.0) for b in (0.0, 90.0, 180.0, 270.0)]
TWO_AXES = (("tilt", (1.0, 0.0, 0.0)), ("spin", (0.0, 0.0, 1.0)))
COMMON = ["--latitude", "39.98", "--gravity", "9.80155", "--time-unit", "ms", "--angle-unit", "counts"]
COMMON += ["--counts-per-rev", str(2**24)]
KINDS = {
    # name: (generator arguments, import flags, fit terms, what the fit must give back)
    "sdf-gyro": (
        dict(kind="sdf-gyro", output="current", scale_per_ma=17.171, axes=TWO_AXES, schedule=POSITIONS,
             truth={"D_F": 0.5, "D_I": 0.3, "D_O": -0.2, "D_S": 0.1}, sigma_dph=0.05,
             mounting=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), table_dt_ms=1000),
        ["--kind", "sdf-gyro", "--axes", "tilt=1,0,0;spin=0,0,1", "--mounting", "ia=1,0,0;oa=0,1,0",
         "--map", "time=Time [ms],angle_tilt=Enc1,angle_spin=Enc2,output=Itorq [mA],temperature=Temp [C]",
         "--output-unit", "mA", "--scale", "17.171 deg/h/mA"],
        "D_F,D_I,D_O,D_S",
        {"D_F": 0.5, "D_I": 0.3, "D_O": -0.2, "D_S": 0.1},
    ),
    "tdf-gyro": (
        dict(kind="tdf-gyro", output="current", scale_per_ma=20.0, axes=TWO_AXES, schedule=POSITIONS,
             truth={"DX_F": 0.5, "DX_X": 0.3, "DY_F": -0.4, "DY_Y": 0.2}, sigma_dph=0.05,
             mounting=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), table_dt_ms=1000),
        ["--kind", "tdf-gyro", "--axes", "tilt=1,0,0;spin=0,0,1", "--mounting", "x=1,0,0;y=0,1,0",
         "--map", "time=Time [ms],angle_tilt=Enc1,angle_spin=Enc2,output_x=IX [mA],output_y=IY [mA]",
         "--output-unit", "mA", "--scale", "20 deg/h/mA"],
        "DX_F,DX_X,DY_F,DY_Y",
        {"DX_F": 0.5, "DX_X": 0.3, "DY_F": -0.4, "DY_Y": 0.2},
    ),
    "pendulous-accel": (
        dict(kind="pendulous-accel", output="current", scale_per_ma=0.001, axes=TWO_AXES, schedule=POSITIONS,
             truth={"K_0": 0.002, "K_1": 1.0003, "K_2": 1e-5}, sigma_dph=1e-5,
             mounting=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), table_dt_ms=1000),
        ["--kind", "pendulous-accel", "--axes", "tilt=1,0,0;spin=0,0,1", "--mounting", "ia=1,0,0;pa=0,1,0",
         "--map", "time=Time [ms],angle_tilt=Enc1,angle_spin=Enc2,output=Iacc [mA]",
         "--output-unit", "mA", "--scale", "1000 mA/g"],
        "K_0,K_1,K_2",
        {"K_0": 0.002, "K_1": 1.0003, "K_2": 1e-5},
    ),
    "rlg": (
        dict(kind="rlg", output="pulses", schedule=RATE_SCHEDULE, truth={"D_F": 0.02, "E_SF": 5.0},
             sigma_dph=0.5, pulse_arcsec=1.0, table_dt_ms=100),
        ["--kind", "rlg", "--axes", "spin=0,0,1", "--mounting", "ia=0,0,1;oa=1,0,0",
         "--map", "time=Time [ms],angle_spin=Enc1,output=Pulses", "--output-unit", "pulses",
         "--scale", "1 arcsec/pulse"],
        "D_F,sf_error",
        {"D_F": 0.02, "E_SF": 5.0},
    ),
    "servo": (
        dict(kind="sdf-gyro", output="current", scale_per_ma=17.0, schedule=7200.0, servo=True,
             truth={"D_F": 0.5, "D_I": 0.3}, table_dt_ms=1000, mounting=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))),
        ["--kind", "sdf-gyro", "--mode", "servo", "--servo-axis", "spin", "--axes", "spin=0,0,1",
         "--mounting", "ia=0,0,1;oa=1,0,0", "--map", "time=Time [ms],angle_spin=Enc1,output=Itorq [mA]",
         "--output-unit", "mA", "--scale", "17 deg/h/mA"],
        "D_F",
        {"D_F": 0.5 + 0.3 * 9.80155 / tw.G0},  # IA up, a_I = g_site / g0 throughout: D_F + D_I a_I (Hu 3-59)
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", list(KINDS))
def test_every_kind_imports_and_fits(case, tmp_path, capsys):
    gen, flags, terms, want = KINDS[case]
    info = tw.rate_table_run(tmp_path, case, seed=3, **gen)
    out = tmp_path / "rec"
    assert main(["import", "table", info["files"]["table"], *COMMON, *flags, "--out", str(out)]) == 0
    rec = load_record(out / f"{case}.json")
    assert rec.kind == gen["kind"] and rec.mode == ("servo" if case == "servo" else "rebalance")
    capsys.readouterr()
    assert main(["fit", str(out), "--terms", terms, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["coefficients"]
    for k, v in want.items():
        assert abs(res[k]["value"] - v) < 4 * res[k]["std"] + 1e-9 * abs(v), (case, k, res[k], v)


def test_units_iso_clock_rate_column_rpm_kelvin_millivolts(tmp_path):
    """The same run written in other units imports to the same record: a table log with a rate column in rpm only
    (no angle), the instrument's clock ISO 8601 date-times, its temperature in kelvin, its output in mV."""
    info = tw.rate_table_run(tmp_path, "a", schedule=RATE_SCHEDULE, truth=TRUTH, sigma_dph=SIGMA, gyro_dt_s=0.01,
                             clock_offset_s=0.75, gyro_clock="iso", rate_column=True, seed=5)  # fmt: skip
    import pandas as pd

    tab = pd.read_csv(info["files"]["table"])
    tab["Rate [rpm]"] = tab["TableRate1 [deg/s]"] / 6.0
    tab[["Time [ms]", "Rate [rpm]"]].to_csv(tmp_path / "rpm.csv", index=False)
    g = pd.read_csv(info["files"]["gyro"])
    g["Vout [mV]"] = g["Vout [V]"] * 1000
    g["Temp [K]"] = g["Temp [C]"] + 273.15
    g[["Timestamp", "Vout [mV]", "Temp [K]"]].to_csv(tmp_path / "gyro-iso.csv", index=False)
    flags = ["--kind", "fog", "--axes", "spin=0,0,1", "--mounting", "ia=0,0,1;oa=1,0,0", "--latitude", "39.98",
             "--map", "time=Time [ms],rate_spin=Rate [rpm],gyro_time=Timestamp,output=Vout [mV],temperature=Temp [K]",
             "--time-unit", "ms", "--gyro-time-unit", "iso", "--rate-unit", "rpm", "--output-unit", "mV",
             "--temperature-unit", "K", "--scale", "20 mV/(deg/s)", "--out", str(tmp_path / "rec")]  # fmt: skip
    # the ISO clock is seconds since midnight: the table's ms clock started at 09:30:00 - 0.75 s on that day
    offset = -(9.5 * 3600) + 0.75
    argv = ["import", "table", str(tmp_path / "rpm.csv"), str(tmp_path / "gyro-iso.csv"), *flags]
    assert main(argv + ["--clock-offset", str(offset)]) == 0
    rec = load_record(tmp_path / "rec" / "rpm.json")
    t_g = info["inputs"]["t"]
    idx = np.searchsorted(t_g, rec.time_s - 1e-6)
    assert np.allclose(t_g[idx], rec.time_s, atol=1e-6)
    assert np.allclose(rec.columns["temperature_C"], info["inputs"]["temp"][idx], atol=6e-4)  # written to 1 mK
    assert np.allclose(rec.columns["rate_spin_dps"], info["rates"][idx, 0], rtol=1e-6, atol=1e-6)
    # the indicated rate: nominal scale × the output column, against the generator's noise-free model ± noise
    ind = rec.scale_factor * rec.columns["current_mA"]
    w = info["inputs"]["w"][idx]
    model = tw.sdf_rate(TRUTH, w[:, 0], w[:, 1], w[:, 2], 0, 0, 0, t_g[idx], info["inputs"]["temp"][idx], True)
    assert abs(np.mean(ind - model)) < 4 * SIGMA / np.sqrt(len(ind)) and np.std(ind - model) < 1.1 * SIGMA
    assert rec.meta["output"]["unit"] == "V" and rec.scale_factor == pytest.approx(3600 / 0.02)


# ---- bad input: exit 2, one line naming the file, row, column or key; nothing written over a good record ----------

SMALL = [("position", [0.0], 6.0), ("rate", [20.0], 18.0), ("rate", [-20.0], 18.0), ("position", [45.0], 6.0)]
SMALL_SETUP = {
    "kind": "fog",
    "site": {"latitude_deg": 39.98, "gravity_mps2": 9.80155},
    "table": {"axes": [{"name": "spin", "axis_enu": [0, 0, 1]}]},
    "instrument": {"ia": [0, 0, 1], "oa": [1, 0, 0]},
    "scale": "0.02 V/(deg/s)",
    "columns": {
        "time": {"column": "Time [ms]", "unit": "ms"},
        "angle_spin": {"column": "Enc1", "unit": "counts", "counts_per_rev": 2**24},
        "output": {"column": "Vout [V]", "unit": "V"},
        "temperature": "Temp [C]",
    },
}


@pytest.fixture()
def small(tmp_path):
    """A small one-clock FOG log, its set-up (JSON) and a good record already imported from it."""
    info = tw.rate_table_run(tmp_path, "log", schedule=SMALL, truth=TRUTH, sigma_dph=SIGMA, seed=7)
    setup = tmp_path / "setup.json"
    setup.write_text(json.dumps(SMALL_SETUP))
    out = tmp_path / "rec"
    assert main(["import", "table", info["files"]["table"], "--setup", str(setup), "--out", str(out)]) == 0
    return tmp_path, info["files"]["table"], setup, out


def _refused(capsys, argv, *words):
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("gyrojax: error:"), err
    for w in words:
        assert w in err, (w, err)
    return err


def test_radian_angles(small, tmp_path, capsys):
    d, log, setup, out = small
    import pandas as pd

    df = pd.read_csv(log)
    df["Angle [rad]"] = df["Enc1"] * 2 * np.pi / 2**24
    df.to_csv(d / "rad.csv", index=False)
    argv = ["import", "table", str(d / "rad.csv"), "--setup", str(setup), "--map", "angle_spin=Angle [rad]"]
    assert main(argv + ["--angle-unit", "rad", "--out", str(d / "rad")]) == 0
    a, b = load_record(out / "log.json"), load_record(d / "rad" / "rad.json")
    assert np.allclose(a.columns["angle_spin_deg"], b.columns["angle_spin_deg"], atol=1e-9)


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda s: s.update(colour="red"), ["setup.json", "'colour'", "unknown"]),
        (
            lambda s: s["columns"].update(output={"column": "Vout [V]", "unit": "furlongs"}),
            ["columns.output", "furlongs"],
        ),
        (lambda s: s["columns"]["angle_spin"].pop("counts_per_rev"), ["columns.angle_spin", "counts_per_rev"]),
        (
            lambda s: s["columns"].update(output={"column": "nope", "unit": "V"}),
            ["log.csv", "'nope'", "columns.output"],
        ),
        (lambda s: s.pop("scale"), ["scale", "nominal scale"]),
        (lambda s: s.update(scale="0.02 V/g"), ["scale", "V/g"]),
        (lambda s: s.update(instrument={"ia": [0, 0, 1], "oa": [0, 0.6, 0.8]}), ["instrument", "orthogonal"]),
        (lambda s: s.update(instrument={"ia": [0, 0, 1], "pa": [1, 0, 0]}), ["instrument", "pa"]),
        (lambda s: s["site"].pop("latitude_deg"), ["latitude"]),
        (lambda s: s["site"].update(gravity_mps2=98.1), ["site.gravity_mps2", "98.1"]),
        (lambda s: s.update(kind="mems"), ["kind", "mems"]),
        (lambda s: s.update(mode="servo"), ["servo"]),
        (lambda s: s.update(table={"axes": [{"name": "spin", "axis_enu": [0, 0, 2]}]}), ["table.axes[0].axis_enu"]),
        (lambda s: s["columns"].update(output_x="Vout [V]"), ["output_x"]),
        (lambda s: s["columns"].update(rate_tilt="Enc1"), ["rate_tilt", "unknown column key"]),
        (lambda s: s.update(clock_offset_s=3.0), ["clock_offset_s"]),
    ],
)
def test_bad_setups_name_the_key(small, capsys, edit, words):
    d, log, setup, out = small
    s = json.loads(setup.read_text())
    edit(s)
    setup.write_text(json.dumps(s))
    before = (out / "log.csv").read_bytes(), (out / "log.json").read_bytes()
    _refused(capsys, ["import", "table", log, "--setup", str(setup), "--out", str(out), "--force"], *words)
    assert ((out / "log.csv").read_bytes(), (out / "log.json").read_bytes()) == before


@pytest.mark.parametrize(
    "row, column, value, words",
    [
        (40, "Vout [V]", "abc", ["log.csv", "row 40", "'Vout [V]'"]),
        (12, "Enc1", "", ["log.csv", "row 12", "'Enc1'"]),
        (30, "Time [ms]", "0", ["log.csv", "row 30", "'Time [ms]'", "does not increase"]),
        (25, "Temp [C]", "inf", ["log.csv", "row 25", "'Temp [C]'"]),
    ],
)
def test_bad_cells_name_the_row_and_column(small, capsys, row, column, value, words):
    d, log, setup, out = small
    lines = open(log).read().splitlines()
    header = lines[0].split(",")
    cells = lines[row - 1].split(",")
    cells[header.index(column)] = value
    lines[row - 1] = ",".join(cells)
    (d / "log.csv").write_text("\n".join(lines) + "\n")
    _refused(capsys, ["import", "table", str(d / "log.csv"), "--setup", str(setup), "--out", str(d / "x")], *words)
    assert not (d / "x").exists()


def test_flags_and_logs_refused_with_their_name(small, capsys):
    d, log, setup, out = small
    base = ["import", "table", log, "--setup", str(setup), "--out", str(d / "y")]
    _refused(capsys, base + ["--scale", "0.02"], "--scale", "value and a unit")
    _refused(capsys, base + ["--axes", "spin=0,0"], "--axes")
    _refused(capsys, base + ["--mounting", "ia=0,0,1;oa=0,0,1"], "--mounting", "orthogonal")
    _refused(capsys, base + ["--rate-unit", "rpm"], "--rate-unit", "no mapped column")
    _refused(capsys, base + ["--rate-hz", "100"], "--rate-hz", "does not apply")
    _refused(capsys, base + ["--map", "output"], "--map")
    _refused(capsys, ["import", "csv", log, "--kind", "fog", "--out", str(d / "y")], "--kind", "import table")
    # a second log whose clock does not overlap the table's: the offset is named
    g = d / "gyro.csv"
    g.write_text("t_us,V\n" + "\n".join(f"{k * 10000},{0.001 * k}" for k in range(3000)) + "\n")
    argv = ["import", "table", log, str(g), "--setup", str(setup), "--map", "gyro_time=t_us,output=V"]
    _refused(capsys, argv + ["--gyro-time-unit", "us", "--clock-offset", "500", "--out", str(d / "y")],
             "clock_offset_s", "--clock-offset")  # fmt: skip
    _refused(capsys, ["import", "table", log, str(g), "--setup", str(setup), "--out", str(d / "y")], "gyro_time")
    assert not (d / "y").exists()
    # an existing record is not overwritten without --force
    _refused(capsys, ["import", "table", log, "--setup", str(setup), "--out", str(out)], "exists", "--force")
