"""Fuzzing ``gyrojax import table``: random byte mutations of a data system's log and of its set-up file, random
values at any key of the set-up, and random command lines of the door's options. The property: exit 0 with a record
that loads, or exit 2 with one line that names what is wrong (the file, a row, a column, a key or a flag); never an
internal error, never a traceback, and never a partial record (the output directory holds a whole record or
nothing)."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrojax.cli.app import main
from gyrojax.data.records import load_record

from . import tablelog_writer as tw
from .test_fuzz import EXAMPLES, FUZZ, alarm, leaf_edits, mutations

SCHEDULE = [("position", [0.0], 4.0), ("rate", [30.0], 12.0), ("rate", [-30.0], 12.0), ("position", [90.0], 4.0)]
SETUP = {
    "kind": "fog",
    "site": {"latitude_deg": 39.98, "gravity_mps2": 9.80155},
    "table": {"axes": [{"name": "spin", "axis_enu": [0, 0, 1]}]},
    "instrument": {"ia": [0, 0, 1], "oa": [1, 0, 0]},
    "scale": "0.02 V/(deg/s)",
    "clock_offset_s": 0.5,
    "columns": {
        "time": {"column": "Time [ms]", "unit": "ms"},
        "gyro_time": {"column": "t_us", "unit": "us"},
        "angle_spin": {"column": "Enc1", "unit": "counts", "counts_per_rev": 65536},
        "output": {"column": "Vout [V]", "unit": "V"},
        "temperature": "Temp [C]",
    },
}
NAMED = ("table.csv", "gyro.csv", "setup.json", "row ", "column", "key", "--", "columns", "set-up")


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz-table")
    info = tw.rate_table_run(d, "run", schedule=SCHEDULE, truth={"D_F": 1.0}, gyro_dt_s=0.02, clock_offset_s=0.5,
                             counts_per_rev=65536, table_dt_ms=40, seed=1)  # fmt: skip
    shutil.copy(info["files"]["table"], d / "table.csv")
    shutil.copy(info["files"]["gyro"], d / "gyro.csv")
    (d / "setup.json").write_text(json.dumps(SETUP))
    out = d / "ok"
    argv = ["import", "table", str(d / "table.csv"), str(d / "gyro.csv"), "--setup", str(d / "setup.json")]
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(argv + ["--out", str(out)]) == 0  # the unmutated files import
    return d


def _run(argv: list, out: Path) -> None:
    """The property of one command line (module doc)."""
    so, se = io.StringIO(), io.StringIO()
    with alarm(60), contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
        try:
            rc = main(argv)
        except SystemExit as e:  # only --help may leave through argparse
            assert e.code in (0, None), (argv, se.getvalue())
            return
    msg = se.getvalue()
    assert rc in (0, 2), (argv, rc, msg)
    if rc == 2:
        assert msg.startswith("gyrojax: error: ") and msg.count("\n") == 1, (argv, msg)
        assert any(w in msg for w in NAMED), (argv, msg)
        assert not out.exists() or not any(out.iterdir()), (argv, list(out.iterdir()))
    else:
        (rec,) = list(out.glob("*.json"))
        load_record(rec)


def _copy(logs: Path, tmp: Path) -> list:
    for f in ("table.csv", "gyro.csv", "setup.json"):
        shutil.copy(logs / f, tmp / f)
    return ["import", "table", str(tmp / "table.csv"), str(tmp / "gyro.csv"), "--setup", str(tmp / "setup.json")]


@pytest.mark.parametrize("which", ["table.csv", "gyro.csv", "setup.json"])
def test_mutated_bytes(logs, which):
    original = (logs / which).read_bytes()

    @FUZZ
    @given(mutations(original))
    def check(data):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            argv = _copy(logs, tmp)
            (tmp / which).write_bytes(data)
            _run(argv + ["--out", str(tmp / "out")], tmp / "out")

    check()


def test_random_setup_values(logs):
    @FUZZ
    @given(leaf_edits(SETUP))
    def check(edited):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            argv = _copy(logs, tmp)
            (tmp / "setup.json").write_text(json.dumps(edited))
            _run(argv + ["--out", str(tmp / "out")], tmp / "out")

    check()


OPTIONS = {
    "--kind": ["fog", "rlg", "sdf-gyro", "tdf-gyro", "pendulous-accel", "mems", ""],
    "--mode": ["rebalance", "servo", "hold"],
    "--servo-axis": ["spin", "tilt", ""],
    "--axes": ["spin=0,0,1", "spin=1,0,0;tilt=0,1,0", "spin=0,0", "=0,0,1", "spin=0,0,2", "spin=a,b,c"],
    "--mounting": ["ia=0,0,1;oa=1,0,0", "ia=1,0,0", "x=1,0,0;y=0,1,0", "ia=0,0,1;oa=0,0,1",
                   "ia=1,0,0;oa=0,1,0;sa=0,0,-1"],
    "--scale": ["0.02 V/(deg/s)", "0.02", "1 arcsec/pulse", "72000 deg/h/V", "0 V/(deg/s)", "nan V", "2 mA/g"],
    "--map": ["time=Time [ms]", "output=Temp [C]", "angle_spin=nope", "rate_spin=Enc1", "segment=Enc1", "junk",
              "gyro_time=Vout [V]", "output_x=Vout [V]"],
    "--time-unit": ["s", "ms", "us", "iso"],
    "--gyro-time-unit": ["s", "ms", "us", "iso"],
    "--angle-unit": ["deg", "rad", "counts", "arcsec"],
    "--counts-per-rev": ["65536", "0", "-1", "nan", "1e300"],
    "--rate-unit": ["deg/s", "rpm"],
    "--output-unit": ["V", "mV", "mA", "pulses", "deg/s", "g", "furlongs"],
    "--temperature-unit": ["C", "K", "F"],
    "--clock-offset": ["0", "0.5", "-1e6", "nan", "inf"],
    "--latitude": ["39.98", "91", "nan", "-90"],
    "--gravity": ["9.8", "0", "nan"],
    "--delimiter": [",", ";", "tab", "auto", "|"],
    "--name": ["r", "a,b", ""],
    "--keep-transitions": [None],
    "--rate-hz": ["100"],
    "--sections": ["x.json"],
}  # fmt: skip


def test_random_command_lines(logs):
    option = st.sampled_from(sorted(OPTIONS)).flatmap(
        lambda k: st.sampled_from(OPTIONS[k]).map(lambda v: [k] if v is None else [k, v])
    )
    inputs = st.sampled_from([["table.csv"], ["table.csv", "gyro.csv"], ["gyro.csv"], ["absent.csv"]])

    @settings(
        max_examples=EXAMPLES or 80,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow],
        derandomize=not EXAMPLES,
    )
    @given(inputs, st.booleans(), st.lists(option, max_size=4))
    def check(files, with_setup, opts):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            _copy(logs, tmp)
            argv = ["import", "table", *(str(tmp / f) for f in files)]
            argv += ["--setup", str(tmp / "setup.json")] if with_setup else []
            argv += [x for o in opts for x in o] + ["--out", str(tmp / "out")]
            _run(argv, tmp / "out")

    check()
