"""Rest logs through the ordinary doors (``gyrojax import csv`` / ``import imutk``), checked against what nobody here
wrote: a real 449 s MPU-6050 rest log (tests/data/mpu6050, MIT) read by allantools, its logger's own preamble, and
the physics of a gyro at rest. The clock is said and cross-checked, and each unit mistake ends in a refusal or a
warning naming its flag."""

import gzip
import json

import allantools
import numpy as np
import pandas as pd
import pytest

from gyrojax.cli.app import main
from gyrojax.data.importers import import_csv
from gyrojax.data.records import load_records, save_record
from gyrojax.errors import RecordError
from gyrojax.noise.chunked import OctaveAllan

from .conftest import DATA
from .kalibr_reader import kalibr_imu_parameters

REST = DATA / "mpu6050" / "example_data_tinit_calc.csv.gz"
MAP = "gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"
COUNTS = ["--gyro-unit", "counts", "--gyro-scale", "131", "--acc-unit", "counts", "--acc-scale", "16384"]


def rest_table() -> pd.DataFrame:
    """The MPU-6050 rest log's table as its logger wrote it (four preamble lines, then ax … gz, raw counts)."""
    return pd.read_csv(REST, skiprows=4)


def write_log(path, df: pd.DataFrame, preamble: str = "") -> str:
    path.write_text(preamble + df.to_csv(index=False))
    return str(path)


def allantools_arw(counts: np.ndarray) -> float:
    """ARW (deg/√h) of raw gyro counts at the nominal 131 counts per deg/s by allantools alone: the overlapping ADEV
    (deg/h) at τ = 1 s (m = 100 at 100 Hz), on the −1/2 slope, times √(1 s)/60."""
    taus, adev, _, _ = allantools.oadev(counts / 131.0 * 3600.0, rate=100.0, data_type="freq", taus=[1.0])
    assert taus[0] == 1.0
    return float(adev[0] / 60.0)


def test_a_real_rest_log_imports_and_noise_gives_its_arw_within_6_percent_of_allantools(tmp_path, capsys):
    """The 449 s MPU-6050 rest log, exactly as its logger wrote it (preamble `Fs,100`, raw counts), through the
    ordinary `import csv`: one rest over the whole log, its rate read from the preamble and said. `noise` gives each
    gyro axis's ARW (the model's read-off) within 6 % of allantools' overlapping ADEV at τ = 1 s (where the curve's
    slope is −1/2: the white noise dominates every τ up to a few seconds), and a Kalibr file Kalibr's reader
    takes, at the log's 100 Hz."""
    out = tmp_path / "rec"
    assert main(["import", "csv", str(REST), "--map", MAP, *COUNTS, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "a rest log: 1 rest(s) covering 100.0% of 449.29 s" in text
    assert "clock: 44930 samples at 100 Hz from the preamble line 'Fs,100'; 449.29 s" in text
    assert "gx" not in text and "gyro_x: -478 to -392 (mean -438.18) counts" in text
    assert "accelerometer at rest: |a| 0.9179 g" in text  # 14791 counts / 16384 of the nominal scale, not calibrated
    (rec,) = load_records(out)
    assert rec.meta["segments"] == [{"label": 0, "type": "static", "name": "rest-0"}]
    kal = tmp_path / "imu.yaml"
    assert main(["noise", str(out), "--json", "--kalibr", str(kal)]) == 0
    res = json.loads(capsys.readouterr().out)
    df = rest_table()
    for c in "xyz":
        ours = res["channels"][f"gyro_{c}"]["headline"]["arw"]["model"]["value"]
        ref = allantools_arw(df[f"g{c}"].to_numpy(float))
        assert abs(ours / ref - 1.0) < 0.06, (c, ours, ref)
    assert res["warnings"] == []
    for c in "xyz":  # the accelerometer's read-offs in its units, the chosen model's own interval too
        arw = res["channels"][f"acc_{c}"]["headline"]["arw"]["model"]
        lo, hi = arw.get("ci_given_model") or arw["ci"]
        assert lo <= arw["value"] <= hi and arw["unit"] == "m/s/sqrt(h)"
    topic, rate, _, gyro = kalibr_imu_parameters(kal)
    assert rate == 100.0 and gyro[2] > 0


def test_the_chunked_allan_variance_is_allantools_oadev_at_every_octave_of_the_real_log():
    """All six channels of the real rest log, fed in chunks of random sizes: at every octave τ (m = 1 … 16384, all
    summed at every offset) the variance is allantools' oadev² to rounding, and its count of second differences
    allantools' n; summed at a step (8 exact levels), the longer octaves stay within their own sampling error."""
    data = rest_table().to_numpy(float)
    rng = np.random.default_rng(7)
    for exact in (14, 8):
        acc = OctaveAllan(0.01, channels=6, exact_levels=exact)
        i = 0
        while i < len(data):
            k = int(rng.integers(1, 5000))
            acc.feed(data[i : i + k])
            i += k
        m, avar, counts, n = acc.result()
        assert n == len(data) and list(m) == [2**k for k in range(15)]
        for j in range(6):
            taus, adev, _, ns = allantools.oadev(data[:, j], rate=100.0, data_type="freq", taus=m * 0.01)
            assert np.array_equal(taus, m * 0.01)
            full = m <= 2**exact
            assert np.allclose(avar[full, j], adev[full] ** 2, rtol=1e-9, atol=0), j
            assert np.array_equal(counts[full], ns[full])
            rel = np.abs(avar[~full, j] / adev[~full] ** 2 - 1.0)
            assert np.all(rel < 3.0 * np.sqrt(2.0 * m[~full] / counts[~full])), (j, rel)


def test_a_gyro_only_rest_log_imports_and_its_noise_needs_the_kalibr_accelerometer_pair(tmp_path, capsys):
    df = rest_table()[["gx", "gy", "gz"]]
    path = write_log(tmp_path / "gyro.csv", df, "Fs,100\n")
    gyro_map = "gyro_x=gx,gyro_y=gy,gyro_z=gz"
    argv = ["import", "csv", path, "--map", gyro_map, "--gyro-unit", "counts", "--gyro-scale", "131"]
    assert main([*argv, "--out", str(tmp_path / "o")]) == 0
    assert "a rest log: 1 rest(s)" in capsys.readouterr().out
    (rec,) = load_records(tmp_path / "o")
    assert "acc_x_g" not in rec.columns
    assert main(["noise", str(tmp_path / "o"), "--kalibr", str(tmp_path / "k.yaml")]) == 2
    assert "--kalibr-accel" in capsys.readouterr().err
    kal = ["--kalibr", str(tmp_path / "k.yaml"), "--kalibr-accel", "0.002,0.0003", "--json"]
    assert main(["noise", str(tmp_path / "o"), *kal]) == 0
    res = json.loads(capsys.readouterr().out)
    assert set(res["channels"]) == {"gyro_x", "gyro_y", "gyro_z"}


def test_apply_reads_a_rest_record(tmp_path):
    """A saved triad fit applied to the rest record: calibrated rates ω = S⁻¹(ω_ind − b − G a) at every sample,
    computed here from the fit JSON's matrices and the record's raw columns."""
    from gyrojax.inference.triad import fit_triad
    from gyrojax.simulation.triad import simulate_multiposition

    from .test_triad_accel import TRUTH

    res = fit_triad(simulate_multiposition(TRUTH, poses=10, seed=8, earth_rate=False))
    fit = res.save(tmp_path / "fit.json")
    assert main(["import", "csv", str(REST), "--map", MAP, *COUNTS, "--out", str(tmp_path / "rec")]) == 0
    assert main(["apply", str(fit), str(tmp_path / "rec"), "--out", str(tmp_path / "cal")]) == 0
    out = pd.read_csv(next((tmp_path / "cal").glob("*.calibrated.csv")))
    (rec,) = load_records(tmp_path / "rec")
    mats = json.loads(fit.read_text())["matrices"]
    s, b, g = (np.asarray(mats[k], float) for k in ("S", "b_deg_per_h", "G_deg_per_h_per_g"))
    raw = np.column_stack([rec.columns[f"gyro_{c}_counts"] for c in "xyz"]) / 131.0 * 3600.0
    acc = np.column_stack([rec.columns[f"acc_{c}_g"] for c in "xyz"])
    want = np.linalg.solve(s, (raw - b - acc @ g.T).T).T / 3600.0
    got = out[["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"]].to_numpy()
    assert len(got) == 44930 and np.allclose(got, want, rtol=1e-9, atol=1e-9)


# ---- the clock: said, cross-checked, refused when it contradicts itself or no IMU runs at it ---------------------


def test_a_stated_rate_that_contradicts_the_preamble_or_the_time_column_is_refused(tmp_path):
    df = rest_table()
    mapping = dict(kv.split("=") for kv in MAP.split(","))
    kw = dict(gyro_unit="counts", gyro_counts_per_dps=131.0, acc_unit="counts", acc_counts_per_g=16384.0)
    with pytest.raises(RecordError, match=r"--rate-hz 200 contradicts the preamble line 'Fs,100' \(100 Hz\)"):
        import_csv(REST, mapping, rate_hz=200.0, **kw)
    timed = df.assign(t_ms=10.0 * np.arange(len(df)))  # a time column in ms
    path = write_log(tmp_path / "t.csv", timed)
    with pytest.raises(RecordError, match=r"--rate-hz says 200 Hz but the time column 't_ms' \(ms\) gives 100 Hz"):
        import_csv(path, {**mapping, "time": "t_ms"}, time_unit="ms", rate_hz=200.0, **kw)
    rec = import_csv(path, {**mapping, "time": "t_ms"}, time_unit="ms", rate_hz=100.0, **kw)
    assert rec.meta["import"]["clock"]["checked_against"] == ["--rate-hz"]
    with_pre = write_log(tmp_path / "tp.csv", timed, "Fs,100\nLogging Type,1\n")
    with pytest.raises(RecordError, match=r"the time column 't_ms' \(s\) gives 0.1 Hz .*\(--time-unit ms\)"):
        import_csv(with_pre, {**mapping, "time": "t_ms"}, **kw)


def test_a_time_column_in_ms_read_as_seconds_is_refused_naming_the_time_unit(tmp_path, capsys):
    """Without a preamble to contradict it, the ms clock read as s makes a 449 s log a 12.5-hour one at 0.1 Hz:
    no IMU logs that slowly; refused, naming --time-unit (the issue's ARW 14.2 instead of 0.45 deg/√h never
    happens)."""
    path = write_log(tmp_path / "t.csv", rest_table().assign(t=10.0 * np.arange(44930)))
    argv = ["import", "csv", path, "--map", "time=t," + MAP, *COUNTS, "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "gives 0.1 Hz, 44930 samples over 449290 s (125 h)" in err and "--time-unit" in err
    assert not (tmp_path / "o").exists()
    assert main([*argv, "--time-unit", "ms"]) == 0


def test_rates_in_the_wrong_unit_are_refused_or_warned_naming_the_gyro_unit(tmp_path, capsys):
    """deg/s declared rad/s reads 57.3× too high at rest: refused at the door. rad/s declared deg/s reads a
    plausible bias, but its ARW is 57.3× too low for a MEMS gyro: `noise` warns, naming --gyro-unit and the ARW it
    would be."""
    df = rest_table()
    dps = df.assign(**{f"g{c}": df[f"g{c}"] / 131.0 for c in "xyz"})
    path = write_log(tmp_path / "dps.csv", dps, "Fs,100\n")
    argv = ["import", "csv", path, "--map", MAP, "--acc-unit", "counts", "--acc-scale", "16384"]
    assert main([*argv, "--gyro-unit", "rad/s", "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "reads |ω| = 203.6 deg/s at rest" in err and "--gyro-unit dps" in err
    rads = df.assign(**{f"g{c}": np.radians(df[f"g{c}"] / 131.0) for c in "xyz"})
    path = write_log(tmp_path / "rad.csv", rads, "Fs,100\n")
    argv = ["import", "csv", path, "--map", MAP, "--acc-unit", "counts", "--acc-scale", "16384"]
    assert main([*argv, "--gyro-unit", "dps", "--out", str(tmp_path / "b")]) == 0
    capsys.readouterr()
    assert main(["noise", str(tmp_path / "b"), "--json"]) == 0
    cap = capsys.readouterr()
    warned = json.loads(cap.out)["warnings"]
    assert len(warned) == 3 and all("--gyro-unit" in w and "rad/s declared deg/s" in w for w in warned)
    assert "gyro_x: ARW 0.0078" in warned[0] and "N would be 0.448" in warned[0]
    assert cap.err.count("gyrojax: warning:") == 3
    assert main([*argv, "--gyro-unit", "rad/s", "--out", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    assert main(["noise", str(tmp_path / "c"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []


# ---- formats: MATLAB files, imu_tk's MATLAB pair ------------------------------------------------------------------


def test_imu_tks_matlab_pair_imports_as_its_text_files(tmp_path, capsys):
    """Tedaldi et al.'s MATLAB code keeps the Xsens session as IMU0x2Dalpha.mat / IMU0x2Domega.mat: MATLAB level-5
    files of one n × 4 matrix each (variables named IMU0x2Dalpha, IMU0x2Domega), the same numbers as imu_tk's text
    files (tests/data/imutk; checked against the MATLAB code's own files, which carry no licence to vendor). Written
    here by scipy.io.savemat from those text files, they import to the same record."""
    from scipy import io

    text = [DATA / "imutk" / f"xsens_{k}.mat.gz" for k in ("acc", "gyro")]
    mats = []
    for src, var in zip(text, ("IMU0x2Dalpha", "IMU0x2Domega")):
        with gzip.open(src, "rt") as fh:
            data = np.loadtxt(fh)
        mats.append(tmp_path / f"{var}.mat")
        io.savemat(mats[-1], {var: data})
    flags = ["--gyro-scale", "109.22", "--gravity", "9.81744"]
    assert main(["import", "imutk", *map(str, text), *flags, "--name", "a", "--out", str(tmp_path / "t")]) == 0
    assert main(["import", "imutk", *map(str, mats), *flags, "--name", "a", "--out", str(tmp_path / "m")]) == 0
    (a,), (b,) = load_records(tmp_path / "t"), load_records(tmp_path / "m")
    for k in a.columns:
        assert np.array_equal(a.columns[k], b.columns[k]), k
    assert "clock: 51175 samples at" in capsys.readouterr().out


def test_a_matlab_log_of_named_vectors_imports_like_its_csv(tmp_path):
    from scipy import io

    df = rest_table()
    io.savemat(tmp_path / "log.mat", {k: df[k].to_numpy(float)[:, None] for k in df.columns} | {"fs": 100.0})
    mapping = dict(kv.split("=") for kv in MAP.split(","))
    kw = dict(gyro_unit="counts", gyro_counts_per_dps=131.0, acc_unit="counts", acc_counts_per_g=16384.0)
    a = import_csv(tmp_path / "log.mat", mapping, rate_hz=100.0, **kw)
    b = import_csv(REST, mapping, **kw)
    for k in b.columns:
        assert np.array_equal(a.columns[k], b.columns[k]), k
    save_record(a, tmp_path / "o")


# ---- records too long to hold: read in chunks, the Allan variance at octave τ accumulated over them -------------


def test_a_record_analysed_in_chunks_gives_the_octave_curve_and_model_of_the_record_held_whole(
    tmp_path, capsys, monkeypatch
):
    """The rest record read in chunks (as a record of more than 2^19 samples is) gives, per channel, the octave
    Allan deviation of the record held whole (`--taus octave`) to rounding, the same noise model and ARW; it says
    that glitches and spectral lines were not searched, and refuses --robust and other taus."""
    import gyrojax.data.stream as stream

    out = tmp_path / "rec"
    assert main(["import", "csv", str(REST), "--map", MAP, *COUNTS, "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["noise", str(out), "--json", "--taus", "octave"]) == 0
    whole = json.loads(capsys.readouterr().out)["channels"]
    monkeypatch.setattr(stream, "STREAM_SAMPLES", 1000)
    monkeypatch.setattr(stream, "CHUNK_ROWS", 7001)
    assert main(["noise", str(out), "--json"]) == 0
    chunked = json.loads(capsys.readouterr().out)["channels"]
    for ch, a in whole.items():
        b = chunked[ch]
        curve = "adev_deg_per_h" if ch.startswith("gyro") else "adev_m_per_s2"
        curve = curve if curve in a else next(k for k in a if k.startswith("adev_") and "model" not in k)
        assert np.allclose(a[curve], b[curve], rtol=1e-9, atol=0), ch
        assert a["model"]["info"]["model"] == b["model"]["info"]["model"]
        arw_a, arw_b = (x["headline"]["arw"]["model"]["value"] for x in (a, b))
        assert arw_a == pytest.approx(arw_b, rel=1e-9)
        assert "analysed in chunks" in b["notes"][0] and "not searched" in b["notes"][0]
    assert main(["noise", str(out), "--robust"]) == 2
    assert "needs every sample at once" in capsys.readouterr().err
    assert main(["noise", str(out), "--taus", "decade"]) == 2
    assert "--taus octave" in capsys.readouterr().err


# ---- logs too long to hold: imported in chunks ------------------------------------------------------------------


def test_numbers_are_written_as_pythons_own_formatting_reads_them():
    """format_column's text of each number is the number of Python's f"{x:.{d}f}" (as a float parser reads both),
    for counts, negative and positive decimals, zeros and large values, in both of its ways (a table of the texts
    of a narrow range of counts, and digits cut all at once) — except at a tie (x·10^d a half-integer to rounding,
    99.9995 at 3 decimals), which either way is within half a unit of the last decimal."""
    from gyrojax.data.longlog import format_column

    rng = np.random.default_rng(5)
    cases = [
        (np.round(rng.normal(0, 30, 5000)), 0),  # narrow counts: the table
        (np.round(rng.normal(0, 3e6, 5000)), 0),  # wide counts: the digits
        (rng.normal(0, 2.0, 5000), 6),
        (rng.normal(-5e3, 1e3, 5000), 3),
        (np.array([0.0, -0.0004, 0.0004, -1.0, 1e-9, -123456.789, 99.9995]), 3),
    ]
    for x, d in cases:
        text = format_column(x, d)
        assert len({len(r) for r in text}) == 1
        ours = np.array([float(bytes(r).decode()) for r in text])
        python = np.array([float(f"{v:.{d}f}") for v in x])
        tie = np.abs(np.abs(x * 10.0**d) % 1.0 - 0.5) < 1e-6
        assert np.array_equal(ours[~tie], python[~tie]), (d, x[ours != python][:3], ours[ours != python][:3])
        assert np.all(np.abs(ours - x) <= 0.5 * 10.0**-d * (1 + 1e-6) + 1e-12 * np.abs(x))


def _long_argv(path, out, *extra):
    m = "time=time_ms,gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"
    return ["import", "csv", str(path), "--map", m, "--time-unit", "ms", *COUNTS, *extra, "--out", str(out)]


def _timed_log(tmp_path, df, name="log.csv") -> str:
    return write_log(tmp_path / name, df.assign(time_ms=10.0 * np.arange(len(df)))[["time_ms", *df.columns]])


def test_a_long_log_read_in_chunks_writes_the_record_of_the_log_held_whole(tmp_path, capsys, monkeypatch):
    """The real rest log, read as a log of more than 2^19 rows is (in chunks, written as it is read), gives the
    record the ordinary import writes: the same columns to the decimals it says it wrote (counts exactly), one rest
    over all of it, and the same noise."""
    import gyrojax.data.stream as stream

    path = _timed_log(tmp_path, rest_table())
    assert main(_long_argv(path, tmp_path / "whole")) == 0
    capsys.readouterr()
    monkeypatch.setattr(stream, "STREAM_SAMPLES", 1000)
    monkeypatch.setattr(stream, "CHUNK_ROWS", 6007)
    assert main(_long_argv(path, tmp_path / "long")) == 0
    text = capsys.readouterr().out
    assert "read in chunks" in text and "clock: 44930 samples at 100 Hz from the time column 'time_ms' (ms)" in text
    (a,), (b,) = load_records(tmp_path / "whole"), load_records(tmp_path / "long")
    decimals = b.meta["import"]["written"]["decimals"]
    for k in a.columns:
        tol = 0.5 * 10.0 ** -decimals[k] if k in decimals else 0.0
        assert np.allclose(a.columns[k], b.columns[k], rtol=0, atol=tol * (1 + 1e-9)), k
    assert decimals["gyro_x"] == 0 and b.meta["segments"] == a.meta["segments"]


def test_a_long_log_that_moves_is_cut_into_rests_and_one_that_keeps_moving_is_refused(tmp_path, capsys, monkeypatch):
    """A bump of 2 s in the middle of the real rest log (the gyro swings by 50 deg/s): read in chunks, the bump's
    rows are labelled −1 in the record and the two still stretches are two rests, each a static segment; a log that
    turns to a new orientation every few seconds is no rest log and is refused, naming how little of it rests."""
    import gyrojax.data.stream as stream

    monkeypatch.setattr(stream, "STREAM_SAMPLES", 1000)
    df = rest_table()
    bumped = df.copy()
    bump = slice(20000, 20200)
    gx = bumped["gx"].to_numpy(float)
    gx[bump] += (50 * 131 * np.sin(np.linspace(0, np.pi, 200))).round()
    bumped["gx"] = gx
    assert main(_long_argv(_timed_log(tmp_path, bumped), tmp_path / "o")) == 0
    capsys.readouterr()
    (rec,) = load_records(tmp_path / "o")
    seg = rec.columns["segment"]
    assert [s["label"] for s in rec.meta["segments"]] == [0, 1]
    assert np.all(seg[bump] == -1) and np.all(seg[:19900] == 0) and np.all(seg[20400:] == 1)
    assert main(["noise", str(tmp_path / "o"), "--json"]) == 0  # read in chunks: two pieces per channel, pooled
    capsys.readouterr()
    turned = df.copy()
    gx = turned["gx"].to_numpy(float)
    for k in range(0, len(df), 1000):  # a new orientation every 10 s, half of each spent turning
        gx[k : k + 500] += (2000 * np.sin(np.linspace(0, np.pi, len(gx[k : k + 500])))).round()
    turned["gx"] = gx
    assert main(_long_argv(_timed_log(tmp_path, turned, "t.csv"), tmp_path / "t")) == 2
    err = capsys.readouterr().err
    assert "is read in chunks as a rest log, and this one moves" in err and "its rests cover" in err
    assert not (tmp_path / "t").exists() or not list((tmp_path / "t").iterdir())


def test_a_bad_cell_or_a_backward_time_in_a_long_log_is_named_and_nothing_is_written(tmp_path, capsys, monkeypatch):
    import gyrojax.data.stream as stream

    monkeypatch.setattr(stream, "STREAM_SAMPLES", 1000)
    monkeypatch.setattr(stream, "CHUNK_ROWS", 5000)
    lines = _timed_log(tmp_path, rest_table())
    text = open(lines).read().splitlines()
    bad = list(text)
    bad[30001] = bad[30001].replace(",", ",oops", 1)  # file line 30002: its 'ax' cell
    (tmp_path / "bad.csv").write_text("\n".join(bad) + "\n")
    assert main(_long_argv(tmp_path / "bad.csv", tmp_path / "o")) == 2
    err = capsys.readouterr().err
    assert "row 30002, column 'ax'" in err and "oops" in err
    back = list(text)
    back[12001] = "0," + back[12001].split(",", 1)[1]  # file line 12002 goes back to t = 0
    (tmp_path / "back.csv").write_text("\n".join(back) + "\n")
    assert main(_long_argv(tmp_path / "back.csv", tmp_path / "o")) == 2
    err = capsys.readouterr().err
    assert "row 12002, column 'time_ms': time does not increase" in err
    assert not (tmp_path / "o").exists() or not any(p.suffix in (".csv", ".json") for p in (tmp_path / "o").iterdir())


# ---- ROS bags of sensor_msgs/Imu, written here by the rosbags library -----------------------------------------


def _write_bag(path, version: int, topics: dict, stamps=True):
    """A ROS ``version`` bag at ``path`` written by rosbags: per topic, (times s, acc m/s², gyro rad/s) as
    sensor_msgs/Imu messages stamped with those times (or all stamped 0 when not ``stamps``), received at them."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if version == 1 else Stores.ROS2_HUMBLE)
    imu, header = store.types["sensor_msgs/msg/Imu"], store.types["std_msgs/msg/Header"]
    stamp_t, quat, vec = (
        store.types[k]
        for k in ("builtin_interfaces/msg/Time", "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Vector3")
    )
    if version == 1:
        from rosbags.rosbag1 import Writer

        writer, ser = Writer(path), store.serialize_ros1
    else:
        from rosbags.rosbag2 import Writer

        writer, ser = Writer(path, version=8), store.serialize_cdr
    with writer:
        for topic, (t, acc, gyr) in topics.items():
            conn = writer.add_connection(topic, imu.__msgtype__, typestore=store)
            for k in range(len(t)):
                ns = 1_700_000_000_000_000_000 + int(round(t[k] * 1e9))
                st = stamp_t(sec=ns // 10**9, nanosec=ns % 10**9) if stamps else stamp_t(sec=0, nanosec=0)
                extra = {"seq": k} if version == 1 else {}
                msg = imu(
                    header=header(stamp=st, frame_id="imu", **extra),
                    orientation=quat(x=0.0, y=0.0, z=0.0, w=1.0),
                    orientation_covariance=np.zeros(9),
                    angular_velocity=vec(x=gyr[k, 0], y=gyr[k, 1], z=gyr[k, 2]),
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=vec(x=acc[k, 0], y=acc[k, 1], z=acc[k, 2]),
                    linear_acceleration_covariance=np.zeros(9),
                )
                writer.write(conn, ns, ser(msg, imu.__msgtype__))


@pytest.mark.parametrize("version", [1, 2])
def test_a_ros_bag_of_the_real_rest_log_imports_as_its_csv_does(tmp_path, capsys, version):
    """The first 60 s of the real rest log, in rad/s and m/s² (sensor_msgs/Imu's units), in a ROS 1 and a ROS 2 bag
    that rosbags writes: `import bag` gives the record `import csv` gives from the same numbers (a time column in s,
    --gyro-unit rad/s, --acc-unit m/s^2), the clock said from the header stamps; two IMU topics need --topic, and
    a bag whose stamps are all zero is timed by its receive times, and says so."""
    df = rest_table().iloc[:6000]
    t = np.arange(len(df)) / 100.0
    gyr = np.radians(df[["gx", "gy", "gz"]].to_numpy(float) / 131.0)
    acc = df[["ax", "ay", "az"]].to_numpy(float) / 16384.0 * 9.80665
    bag = tmp_path / ("log.bag" if version == 1 else "log")
    _write_bag(bag, version, {"/imu0": (t, acc, gyr)})
    assert main(["import", "bag", str(bag), "--out", str(tmp_path / "b")]) == 0
    text = capsys.readouterr().out
    assert "clock: 6000 samples at 100 Hz from the header stamps of topic '/imu0'" in text
    csv = write_log(
        tmp_path / "log.csv",
        pd.DataFrame({"t": t, **dict(zip(["ax", "ay", "az"], acc.T)), **dict(zip(["gx", "gy", "gz"], gyr.T))}),
    )
    argv = ["import", "csv", csv, "--map", "time=t," + MAP, "--gyro-unit", "rad/s", "--acc-unit", "m/s^2"]
    assert main([*argv, "--name", "log", "--out", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    (a,), (b,) = load_records(tmp_path / "b"), load_records(tmp_path / "c")
    for k in b.columns:
        assert np.allclose(a.columns[k], b.columns[k], rtol=1e-12, atol=1e-12), k
    two = tmp_path / ("two.bag" if version == 1 else "two")
    _write_bag(two, version, {"/imu0": (t, acc, gyr), "/imu1": (t, acc, gyr)})
    assert main(["import", "bag", str(two), "--out", str(tmp_path / "t")]) == 2
    assert "2 sensor_msgs/Imu topics ['/imu0', '/imu1']: choose one with --topic" in capsys.readouterr().err
    assert main(["import", "bag", str(two), "--topic", "/imu1", "--out", str(tmp_path / "t")]) == 0
    capsys.readouterr()
    zero = tmp_path / ("zero.bag" if version == 1 else "zero")
    _write_bag(zero, version, {"/imu0": (t, acc, gyr)}, stamps=False)
    assert main(["import", "bag", str(zero), "--out", str(tmp_path / "z")]) == 0
    assert "from the bag's receive times of topic '/imu0' (its header stamps repeat)" in capsys.readouterr().out


def test_bad_bags_and_bag_options_are_refused_naming_what(tmp_path, capsys):
    (tmp_path / "no.bag").write_bytes(b"#ROSBAG V2.0\nnot really")
    assert main(["import", "bag", str(tmp_path / "no.bag"), "--out", str(tmp_path / "o")]) == 2
    assert "not a readable ROS 1 or ROS 2 bag" in capsys.readouterr().err
    assert main(["import", "bag", str(tmp_path / "no.bag"), "--gyro-unit", "dps", "--out", str(tmp_path / "o")]) == 2
    assert "sensor_msgs/Imu carries rad/s" in capsys.readouterr().err
    assert main(["import", "csv", str(REST), "--map", MAP, "--topic", "/imu", "--out", str(tmp_path / "o")]) == 2
    assert "--topic does not apply" in capsys.readouterr().err


def test_a_hand_session_on_a_clock_100_times_slow_is_refused_naming_the_rate(tmp_path):
    """A simulated hand session at 100 Hz (moves of 0.8–1.6 s) declared --rate-hz 1: its moves would last
    80–160 s each, which no hand takes; refused, naming --rate-hz. At its own rate it imports."""
    from .test_importers import hand_session, log_columns

    rec, _ = hand_session()
    cols = {k: v for k, v in log_columns(rec).items() if k != "t"}
    path = write_log(tmp_path / "h.csv", pd.DataFrame(cols))
    mapping = {"gyro_x": "gx", "gyro_y": "gy", "gyro_z": "gz", "acc_x": "ax", "acc_y": "ay", "acc_z": "az"}
    with pytest.raises(RecordError, match=r"its median move last 1\d\d(\.\d*)? s .*--rate-hz"):
        import_csv(path, mapping, rate_hz=1.0)
    assert import_csv(path, mapping, rate_hz=100.0).meta["import"]["rests_found"] == 36
