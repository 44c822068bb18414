"""Fuzzing the doors rest logs come in by: random byte mutations of a real rest log (a logger's preamble, a time
column), of it as a MATLAB file and as a ROS bag, the log read in chunks, and random option values of
``gyrojax import csv|imutk|bag``. The property (the pattern of tests/test_fuzz.py): the command returns 0 or 2 —
never 1 (an internal error), never a traceback; a refusal is one line that names the file, a row and column, or
the option; an accepted log writes a record that loads, whose clock is one an IMU can run at."""

from __future__ import annotations

import contextlib
import io
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gyrojax.cli import app as cli
from gyrojax.data.logs import PLAUSIBLE_RATE_HZ
from gyrojax.data.records import load_records

from .conftest import DATA
from .test_fuzz import FUZZ, alarm, mutations

MAP = "time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"
UNITS = ["--gyro-unit", "counts", "--gyro-scale", "131", "--acc-unit", "counts", "--acc-scale", "16384"]


@pytest.fixture(scope="module")
def log_bytes() -> bytes:
    """1500 rows of the real MPU-6050 rest log with a time column in s and its logger's preamble."""
    df = pd.read_csv(DATA / "mpu6050" / "example_data_tinit_calc.csv.gz", skiprows=4).iloc[:1500]
    df.insert(0, "t", np.round(np.arange(len(df)) / 100.0, 2))
    return ("Fs,100\nLogging Type,1\n" + df.to_csv(index=False)).encode()


def run(argv) -> tuple[int, str]:
    """``gyrojax ARGV``: exit code and stderr; a traceback or an internal error fails the property."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err), alarm(60):
        try:
            rc = cli.main(argv)
        except SystemExit as e:
            rc = e.code or 0
    text = err.getvalue()
    assert rc in (0, 2), (argv, rc, text)
    assert "Traceback" not in text, (argv, text)
    return rc, text


def check_outcome(rc: int, err: str, out: Path, path: Path, names=()) -> None:
    """On a refusal, one line naming the file (or an option or column); on success, a record that loads with a
    plausible clock."""
    if rc == 2:
        msg = [ln for ln in err.splitlines() if ln.startswith("gyrojax: error: ")]
        assert len(msg) == 1, err
        named = [path.name, *names, "--", "column", "row"]
        assert any(n in msg[0] for n in named), msg[0]
        return
    (rec,) = load_records(out)
    clock = rec.meta["import"]["clock"]
    assert PLAUSIBLE_RATE_HZ[0] <= clock["rate_hz"] <= PLAUSIBLE_RATE_HZ[1]
    assert np.all(np.diff(rec.time_s) > 0)


@pytest.mark.parametrize("chunked", [False, True], ids=["whole", "in-chunks"])
def test_mutated_rest_logs(log_bytes, monkeypatch, chunked):
    if chunked:  # a log this short read as a long one is: the chunked door, its errors and its record
        import gyrojax.data.stream as stream

        monkeypatch.setattr(stream, "STREAM_SAMPLES", 100)
        monkeypatch.setattr(stream, "CHUNK_ROWS", 400)

    @FUZZ
    @given(mutations(log_bytes))
    def check(data):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "log.csv"
            path.write_bytes(data)
            rc, err = run(["import", "csv", str(path), "--map", MAP, *UNITS, "--out", f"{tmp}/o"])
            check_outcome(rc, err, Path(tmp) / "o", path, ("map", "column mapping"))

    check()


def test_mutated_matlab_and_bag_files(log_bytes, tmp_path_factory):
    from scipy import io as sio

    from .test_rest_logs import _write_bag

    d = tmp_path_factory.mktemp("fuzz-doors")
    df = pd.read_csv(io.BytesIO(log_bytes), skiprows=2)
    sio.savemat(d / "log.mat", {k: df[k].to_numpy(float)[:, None] for k in df.columns})
    t = df["t"].to_numpy()
    _write_bag(
        d / "log.bag",
        1,
        {
            "/imu": (
                t,
                df[["ax", "ay", "az"]].to_numpy() / 1670.0,
                np.radians(df[["gx", "gy", "gz"]].to_numpy() / 131.0),
            )
        },
    )
    cases = [
        ("log.mat", ["import", "csv", "{path}", "--map", MAP, *UNITS, "--out", "{out}"]),
        ("log.bag", ["import", "bag", "{path}", "--out", "{out}"]),
    ]
    for name, argv in cases:
        original = (d / name).read_bytes()
        check = _mutated_file_check(name, argv, original)
        check()


def _mutated_file_check(name: str, argv: list, original: bytes):
    """The property over mutations of ``original`` saved as ``name`` and imported by ``argv``."""

    @FUZZ
    @given(mutations(original))
    def check(data):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / name
            path.write_bytes(data)
            out = Path(tmp) / "o"
            rc, err = run([a.format(path=path, out=out) for a in argv])
            check_outcome(rc, err, out, path, ("topic", "sensor_msgs"))

    return check


_VALUES = st.sampled_from(["0", "-1", "1e-9", "nan", "inf", "1e300", "abc", "", "100", "0.1", "1e6", ",", "=", "s"])
_OPTIONS = st.sampled_from(
    [
        "--rate-hz",
        "--time-unit",
        "--acc-scale",
        "--gyro-scale",
        "--gyro-unit",
        "--acc-unit",
        "--topic",
        "--map",
        "--min-rest",
        "--static-threshold",
        "--delimiter",
        "--latitude",
        "--gravity",
    ]
)


def test_random_options_of_the_new_doors(log_bytes, tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz-options")
    (d / "log.csv").write_bytes(log_bytes)
    fmt = st.sampled_from(["csv", "bag", "imutk"])
    pairs = st.lists(st.tuples(_OPTIONS, _VALUES), max_size=3)

    @FUZZ
    @given(fmt, pairs, st.booleans())
    def check(form, opts, with_map):
        with tempfile.TemporaryDirectory() as tmp:
            inputs = [str(d / "log.csv")] * (2 if form == "imutk" else 1)
            argv = ["import", form, *inputs, *(["--map", MAP] if with_map else [])]
            for k, v in opts:
                argv += [k, v]
            rc, err = run([*argv, "--out", f"{tmp}/o"])
            if rc == 0:
                shutil.rmtree(f"{tmp}/o", ignore_errors=True)
            else:
                assert err.count("\n") == 1 and err.startswith("gyrojax: error: "), err

    check()
