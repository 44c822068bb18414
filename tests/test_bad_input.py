"""Malformed input: every defect of conventions §5 (and more) raises one gyrojax error whose message names the file
and the key, or the row and the column, and says what would be valid; the command line turns each into exit
status 2 with one line on stderr.

Every bad file is made here from one valid simulated record (a 36-sample fixed-position run), by editing its CSV
text, its JSON, or its bytes. Rows are counted as a spreadsheet does: the header is row 1, the first sample row 2.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from gyrojax.cli import app as cli
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan, plan_to_json
from gyrojax.data.records import load_record, load_records, save_record
from gyrojax.data.truth import load_truth
from gyrojax.errors import GyrojaxError, ModelError, PlanError, RecordError, TruthError
from gyrojax.inference.identify import fit
from gyrojax.simulation.simulator import simulate

ROOT = Path(__file__).resolve().parents[1]
NAME = "fixed"  # the run name of plans.fixed_position


@pytest.fixture(scope="module")
def valid_dir(tmp_path_factory) -> Path:
    recs = simulate(plans.fixed_position(hours=0.01), {"coefficients": {"D_F": 0.1}})
    d = tmp_path_factory.mktemp("valid")
    save_record(recs[0], d)
    return d


def _copy(valid_dir: Path, dest: Path) -> tuple[Path, Path]:
    dest.mkdir(parents=True, exist_ok=True)
    for ext in (".csv", ".json"):
        shutil.copy(valid_dir / f"{NAME}{ext}", dest / f"{NAME}{ext}")
    return dest / f"{NAME}.csv", dest / f"{NAME}.json"


# ---- the corpus -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """A defect: ``mutate(csv_path, json_path)`` spoils the copy and returns the path to load."""

    id: str
    mutate: Callable[[Path, Path], Path]
    expect: tuple[str, ...]  # substrings the message must contain (the file, key/row/column, what is valid)
    error: type = RecordError


def csv_lines(fn):
    """Mutation editing the CSV as a list of lines (index 0 = row 1 = header)."""

    def m(c: Path, j: Path) -> Path:
        lines = c.read_text(encoding="utf-8").splitlines()
        out = fn(lines)
        c.write_text(out if isinstance(out, str) else "\n".join(out) + "\n", encoding="utf-8")
        return j

    return m


def csv_cell(row: int, column: str, value: str):
    """Mutation setting one cell (row numbered as in the messages: header = 1)."""

    def fn(lines):
        head = lines[0].split(",")
        cells = lines[row - 1].split(",")
        cells[head.index(column)] = value
        lines[row - 1] = ",".join(cells)
        return lines

    return csv_lines(fn)


def csv_header(fn):
    def edit(lines):
        lines[0] = ",".join(fn(lines[0].split(",")))
        return lines

    return csv_lines(edit)


def drop_column(column: str):
    def fn(lines):
        k = lines[0].split(",").index(column)
        return [",".join(c for i, c in enumerate(line.split(",")) if i != k) for line in lines]

    return csv_lines(fn)


def meta_edit(fn):
    """Mutation editing the record JSON as a dict."""

    def m(c: Path, j: Path) -> Path:
        meta = json.loads(j.read_text(encoding="utf-8"))
        fn(meta)
        j.write_text(json.dumps(meta), encoding="utf-8")
        return c

    return m


def raw(which: str, fn):
    """Mutation on the bytes of the CSV or JSON file."""

    def m(c: Path, j: Path) -> Path:
        p = c if which == "csv" else j
        p.write_bytes(fn(p.read_bytes()))
        return j if which == "csv" else c

    return m


def setter(*keys_and_value):
    *keys, value = keys_and_value

    def fn(meta):
        d = meta
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value

    return fn


def deleter(*keys):
    def fn(meta):
        d = meta
        for k in keys[:-1]:
            d = d[k]
        del d[keys[-1]]

    return fn


def _swap_time_current(head):
    i, k = head.index("time_s"), head.index("current_mA")
    head[i], head[k] = head[k], head[i]
    return head


def _truncate_mid_row(lines):
    return "\n".join(lines[:12]) + "\n" + lines[12][: lines[12].index(",", 4) + 1]


def _ragged(lines):
    lines[9] += ",7"
    return lines


def _servo_missing(meta):
    meta["mode"] = "servo"
    meta["servo_axis"] = None


def _servo_wrong_axis(meta):
    meta["mode"] = "servo"
    meta["servo_axis"] = "tilt"


def _non_orthogonal(meta):
    s = 1 / np.sqrt(2)
    meta["instrument"]["oa"] = [s, s, 0.0]


def _tdf_with_sdf_keys(meta):
    meta["instrument"]["kind"] = "tdf-gyro"


def _two_axes_same_name(meta):
    meta["table"]["axes"].append({"name": "base", "axis_enu": [1, 0, 0]})


def _accel_with_gyro_scale(meta):
    meta["instrument"] = {"kind": "pendulous-accel", "ia": [1, 0, 0], "pa": [0, 1, 0], "oa": [0, 0, 1]}


def _dup_json_key(c: Path, j: Path) -> Path:
    text = j.read_text(encoding="utf-8")
    j.write_text(text.replace('"mode": "rebalance"', '"mode": "rebalance", "mode": "servo"', 1), encoding="utf-8")
    return c


def _csv_is_dir(c: Path, j: Path) -> Path:
    c.unlink()
    c.mkdir()
    return j


def _json_is_dir(c: Path, j: Path) -> Path:
    j.unlink()
    j.mkdir()
    return c


def _missing(which):
    def m(c: Path, j: Path) -> Path:
        (c if which == "csv" else j).unlink()
        return j if which == "csv" else c

    return m


def _empty(which):
    def m(c: Path, j: Path) -> Path:
        (c if which == "csv" else j).write_bytes(b"")
        return j if which == "csv" else c

    return m


V = ("must", "valid", "required", "expected", "should", "save it", "need")  # words that say what is valid

CASES = [
    # --- CSV: truncation, encodings
    Case("csv-truncated-mid-row", csv_lines(_truncate_mid_row), ("fixed.csv", "row 13", "column 'rate_base_dps'")),
    Case("csv-truncated-mid-header", csv_lines(lambda ls: ls[0][:9]), ("fixed.csv", "no samples", "required")),
    Case("csv-header-only", csv_lines(lambda ls: ls[:1]), ("fixed.csv", "no samples")),
    Case("csv-empty", _empty("csv"), ("fixed.csv", "empty")),
    Case("csv-whitespace-only", raw("csv", lambda b: b"  \n\n \n"), ("fixed.csv", "empty")),
    Case("csv-utf16", raw("csv", lambda b: b.decode().encode("utf-16")), ("fixed.csv", "UTF-8", "row 1")),
    Case(
        "csv-latin1-byte", raw("csv", lambda b: b.replace(b"\n3.0,", b"\n3.0\xb0,", 1)), ("fixed.csv", "UTF-8", "row 5")
    ),
    Case("csv-nul-bytes", raw("csv", lambda b: b[:200] + b"\x00\x00" + b[200:]), ("fixed.csv",)),
    Case(
        "csv-stray-carriage-return",
        raw("csv", lambda b: b.replace(b"\n1.0,", b"\n1.0\r,", 1)),
        ("fixed.csv", "row 3", "carriage return"),
    ),
    Case("csv-header-leading-cr", raw("csv", lambda b: b"\r" + b), ("fixed.csv", "row 1")),
    # --- CSV: header problems
    Case("csv-missing-time", drop_column("time_s"), ("fixed.csv", "'time_s'", "required")),
    Case("csv-missing-angle", drop_column("angle_base_deg"), ("fixed.csv", "'angle_base_deg'", "'base'")),
    Case("csv-missing-current", drop_column("current_mA"), ("fixed.csv", "'current_mA'", "rebalance")),
    Case(
        "csv-unit-in-header",
        csv_header(lambda h: ["time_s [s]" if x == "time_s" else x for x in h]),
        ("fixed.csv", "'time_s [s]'", "'time_s'", "unit"),
    ),
    Case(
        "csv-unit-in-current",
        csv_header(lambda h: ["current_mA (mA)" if x == "current_mA" else x for x in h]),
        ("fixed.csv", "'current_mA (mA)'", "'current_mA'"),
    ),
    Case(
        "csv-duplicate-header",
        csv_header(lambda h: [("current_mA" if x == "rate_base_dps" else x) for x in h]),
        ("fixed.csv", "row 1", "'current_mA'", "twice"),
    ),
    Case(
        "csv-empty-header-name",
        csv_header(lambda h: [("" if x == "segment" else x) for x in h]),
        ("fixed.csv", "row 1", "column 4", "name"),
    ),
    Case("csv-swapped-header", csv_header(_swap_time_current), ("fixed.csv", "column 'time_s'", "increasing")),
    Case("csv-semicolons", csv_lines(lambda ls: [x.replace(",", ";") for x in ls]), ("fixed.csv", "';'", "comma")),
    Case("csv-ragged-row", csv_lines(_ragged), ("fixed.csv", "row 10", "6", "5")),
    # --- CSV: cells
    Case("csv-empty-cell", csv_cell(7, "current_mA", ""), ("fixed.csv", "row 7", "column 'current_mA'", "empty")),
    Case("csv-blank-cell", csv_cell(8, "angle_base_deg", "  "), ("fixed.csv", "row 8", "'angle_base_deg'")),
    Case("csv-nan", csv_cell(9, "current_mA", "NaN"), ("fixed.csv", "row 9", "column 'current_mA'", "finite")),
    Case("csv-nan-lower", csv_cell(10, "rate_base_dps", "nan"), ("fixed.csv", "row 10", "'rate_base_dps'", "finite")),
    Case("csv-inf", csv_cell(11, "current_mA", "inf"), ("fixed.csv", "row 11", "'current_mA'", "finite")),
    Case("csv-minus-infinity", csv_cell(12, "time_s", "-Infinity"), ("fixed.csv", "row 12", "'time_s'", "finite")),
    Case("csv-text", csv_cell(13, "current_mA", "abc"), ("fixed.csv", "row 13", "'current_mA'", "not a number")),
    Case("csv-bool", csv_cell(14, "angle_base_deg", "True"), ("fixed.csv", "row 14", "'angle_base_deg'", "number")),
    Case("csv-decimal-comma", csv_cell(15, "current_mA", '"0,5"'), ("fixed.csv", "row 15", "'current_mA'")),
    Case("csv-hex", csv_cell(16, "current_mA", "0x1F"), ("fixed.csv", "row 16", "'current_mA'", "number")),
    Case("csv-fractional-segment", csv_cell(17, "segment", "0.5"), ("fixed.csv", "row 17", "'segment'", "integer")),
    Case("csv-duplicate-time", csv_cell(7, "time_s", "4.0"), ("fixed.csv", "row 7", "'time_s'", "increasing")),
    Case("csv-decreasing-time", csv_cell(20, "time_s", "3.0"), ("fixed.csv", "row 20", "'time_s'", "increasing")),
    # --- JSON: syntax, encoding
    Case("json-truncated", raw("json", lambda b: b[: len(b) // 2]), ("fixed.json", "JSON", "line")),
    Case("json-empty", _empty("json"), ("fixed.json", "empty")),
    Case("json-utf16", raw("json", lambda b: b.decode().encode("utf-16")), ("fixed.json", "UTF-8")),
    Case("json-latin1", raw("json", lambda b: b.replace(b"simulated", b"simul\xe9", 1)), ("fixed.json", "UTF-8")),
    Case("json-top-level-list", raw("json", lambda b: b"[1, 2]"), ("fixed.json", "object")),
    Case("json-duplicate-key", _dup_json_key, ("fixed.json", "'mode'", "twice")),
    # --- JSON: keys
    Case(
        "json-unknown-format",
        meta_edit(setter("format", "gyrojax-record-9")),
        ("fixed.json", "'format'", "gyrojax-record-1"),
    ),
    Case("json-missing-format", meta_edit(deleter("format")), ("fixed.json", "'format'", "required")),
    Case("json-missing-name", meta_edit(deleter("name")), ("fixed.json", "'name'", "required")),
    Case("json-missing-site", meta_edit(deleter("site")), ("fixed.json", "'site'", "required")),
    Case(
        "json-missing-latitude",
        meta_edit(deleter("site", "latitude_deg")),
        ("fixed.json", "'site.latitude_deg'", "required"),
    ),
    Case(
        "json-latitude-range",
        meta_edit(setter("site", "latitude_deg", 95.0)),
        ("fixed.json", "'site.latitude_deg'", "[-90, 90]"),
    ),
    Case(
        "json-latitude-bool",
        meta_edit(setter("site", "latitude_deg", True)),
        ("fixed.json", "'site.latitude_deg'", "finite number"),
    ),
    Case(
        "json-latitude-string",
        meta_edit(setter("site", "latitude_deg", "39.98")),
        ("fixed.json", "'site.latitude_deg'", "number"),
    ),
    Case(
        "json-gravity-range",
        meta_edit(setter("site", "gravity_mps2", 1.0)),
        ("fixed.json", "'site.gravity_mps2'", "9.7"),
    ),
    Case(
        "json-gravity-nan",
        raw("json", lambda b: b.replace(b'"gravity_mps2": 9.8', b'"gravity_mps2": NaN, "x": 9.8')),
        ("fixed.json", "'site.gravity_mps2'", "finite"),
    ),
    Case("json-axes-empty", meta_edit(setter("table", "axes", [])), ("fixed.json", "'table.axes'", "non-empty")),
    Case(
        "json-axis-non-unit",
        meta_edit(lambda m: m["table"]["axes"][0].update(axis_enu=[0, 0, 2])),
        ("fixed.json", "'table.axes[0].axis_enu'", "unit vector"),
    ),
    Case(
        "json-axis-two-components",
        meta_edit(lambda m: m["table"]["axes"][0].update(axis_enu=[0, 1])),
        ("fixed.json", "'table.axes[0].axis_enu'", "3 numbers"),
    ),
    Case(
        "json-axis-text",
        meta_edit(lambda m: m["table"]["axes"][0].update(axis_enu=["up", 0, 0])),
        ("fixed.json", "'table.axes[0].axis_enu'", "3 numbers"),
    ),
    Case(
        "json-axis-bool",
        meta_edit(lambda m: m["table"]["axes"][0].update(axis_enu=[False, False, True])),
        ("fixed.json", "'table.axes[0].axis_enu'", "numbers"),
    ),
    Case("json-axis-duplicate-name", meta_edit(_two_axes_same_name), ("fixed.json", "'table.axes[1].name'", "twice")),
    Case(
        "json-axis-name-comma",
        meta_edit(lambda m: m["table"]["axes"][0].update(name="a,b")),
        ("fixed.json", "'table.axes[0].name'", "without commas"),
    ),
    Case(
        "json-ia-non-unit",
        meta_edit(setter("instrument", "ia", [1.001, 0, 0])),
        ("fixed.json", "'instrument.ia'", "unit vector"),
    ),
    Case(
        "json-non-orthogonal",
        meta_edit(_non_orthogonal),
        ("fixed.json", "'instrument.ia'", "'instrument.oa'", "orthogonal"),
    ),
    Case(
        "json-left-handed",
        meta_edit(setter("instrument", "sa", [0, 0, -1])),
        ("fixed.json", "'instrument.sa'", "left-handed", "must equal"),
    ),
    Case("json-missing-sa", meta_edit(deleter("instrument", "sa")), ("fixed.json", "'instrument.sa'", "required")),
    Case(
        "json-unknown-kind",
        meta_edit(setter("instrument", "kind", "ring-laser")),
        ("fixed.json", "'instrument.kind'", "sdf-gyro"),
    ),
    Case("json-tdf-with-sdf-keys", meta_edit(_tdf_with_sdf_keys), ("fixed.json", "'instrument.x'", "required")),
    Case(
        "json-accel-without-its-scale",
        meta_edit(_accel_with_gyro_scale),
        ("fixed.json", "'scale_factor_g_per_mA'", "required"),
    ),
    Case("json-unknown-mode", meta_edit(setter("mode", "open-loop")), ("fixed.json", "'mode'", "'servo'")),
    Case("json-servo-without-axis", meta_edit(_servo_missing), ("fixed.json", "'servo_axis'", "must name")),
    Case("json-servo-axis-missing", meta_edit(_servo_wrong_axis), ("fixed.json", "'servo_axis'", "'tilt'", "base")),
    Case(
        "json-missing-scale",
        meta_edit(deleter("scale_factor_deg_per_h_per_mA")),
        ("fixed.json", "'scale_factor_deg_per_h_per_mA'", "required"),
    ),
    Case(
        "json-zero-scale",
        meta_edit(setter("scale_factor_deg_per_h_per_mA", 0)),
        ("fixed.json", "'scale_factor_deg_per_h_per_mA'", "non-zero"),
    ),
    Case(
        "json-scale-bool",
        meta_edit(setter("scale_factor_deg_per_h_per_mA", True)),
        ("fixed.json", "'scale_factor_deg_per_h_per_mA'", "finite number"),
    ),
    Case(
        "json-scale-string",
        meta_edit(setter("scale_factor_deg_per_h_per_mA", "17.171")),
        ("fixed.json", "'scale_factor_deg_per_h_per_mA'", "finite number"),
    ),
    Case("json-name-empty", meta_edit(setter("name", "")), ("fixed.json", "'name'", "non-empty")),
    # --- files
    Case("missing-csv", _missing("csv"), ("fixed.csv", "no such file", "side by side")),
    Case("missing-json", _missing("json"), ("fixed.json", "no such file", "side by side")),
    Case("csv-is-a-directory", _csv_is_dir, ("fixed.csv", "directory")),
    Case("json-is-a-directory", _json_is_dir, ("fixed.json", "directory")),
]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_malformed_record(case: Case, valid_dir, tmp_path):
    c, j = _copy(valid_dir, tmp_path / "r")
    target = case.mutate(c, j)
    with pytest.raises(GyrojaxError) as info:
        load_record(target)
    assert type(info.value) is case.error, f"{type(info.value).__name__}: {info.value}"
    msg = str(info.value)
    for s in case.expect:
        assert s in msg, f"{s!r} not in message: {msg}"
    assert "\n" not in msg and len(msg) < 600, msg


def test_corpus_is_large_and_distinct():
    assert len(CASES) >= 40
    assert len({c.id for c in CASES}) == len(CASES)


# ---- what must load -----------------------------------------------------------------------------------------------


def _reference(valid_dir):
    return load_record(valid_dir / f"{NAME}.json")


@pytest.mark.parametrize(
    "mutate",
    [
        raw("csv", lambda b: b"\xef\xbb\xbf" + b),  # UTF-8 BOM
        raw("json", lambda b: b"\xef\xbb\xbf" + b),
        raw("csv", lambda b: b.replace(b"\n", b"\r\n")),  # Windows line ends
        csv_lines(lambda ls: [",".join(reversed(x.split(","))) for x in ls]),  # column order is free
        csv_lines(lambda ls: [x + ",x" if i else x + ",extra_col" for i, x in enumerate(ls)]),  # extra columns kept
        meta_edit(setter("vendor_key", {"anything": [1, 2]})),  # unknown keys kept
    ],
    ids=["csv-bom", "json-bom", "crlf", "reversed-columns", "extra-text-column", "unknown-json-key"],
)
def test_tolerated_variants_load(mutate, valid_dir, tmp_path):
    c, j = _copy(valid_dir, tmp_path / "r")
    target = mutate(c, j)
    rec = load_record(target)
    ref = _reference(valid_dir)
    for k in ref.columns:
        np.testing.assert_array_equal(rec.columns[k], ref.columns[k])


def test_either_path_or_stem_loads(valid_dir):
    for p in (valid_dir / f"{NAME}.csv", valid_dir / f"{NAME}.json", valid_dir / NAME):
        assert load_record(p).n == 36


def test_empty_directory_is_an_error(tmp_path):
    with pytest.raises(RecordError, match="no record"):
        load_records([tmp_path])


# ---- effects that need inputs the record lacks --------------------------------------------------------------------


def test_temperature_term_without_the_column(valid_dir):
    rec = _reference(valid_dir)
    with pytest.raises(ModelError) as info:
        fit([rec], ["D_F", "bias_temperature"], noise="white")
    msg = str(info.value)
    assert "fixed.csv" in msg and "'temperature_C'" in msg and "bias_temperature" in msg


def test_temperature_term_with_a_constant_column(valid_dir):
    rec = _reference(valid_dir)
    rec = rec.with_columns(temperature_C=np.full(rec.n, 25.0))
    with pytest.raises(ModelError) as info:
        fit([rec], ["D_F", "bias_temperature"], noise="white")
    msg = str(info.value)
    assert "'temperature_C'" in msg and "constant" in msg and "D_F" in msg


def test_cli_fit_temperature_absent_and_constant(valid_dir, tmp_path, capsys):
    assert cli.main(["fit", str(valid_dir / f"{NAME}.json"), "--terms", "D_F,bias_temperature"]) == 2
    err = capsys.readouterr().err
    assert "temperature_C" in err and err.count("\n") == 1
    c, j = _copy(valid_dir, tmp_path / "r")
    csv_lines(lambda ls: [x + (",25.0" if i else ",temperature_C") for i, x in enumerate(ls)])(c, j)
    assert cli.main(["fit", str(j), "--terms", "D_F,bias_temperature"]) == 2
    err = capsys.readouterr().err
    assert "constant" in err and err.count("\n") == 1


def test_unknown_term(valid_dir):
    with pytest.raises(ModelError, match="'D_XYZ'.*valid"):
        fit([_reference(valid_dir)], ["D_F", "D_XYZ"], noise="white")


# ---- plan JSON -----------------------------------------------------------------------------------------------------


def _plan_dict():
    return json.loads(plan_to_json(plans.fixed_position(hours=0.01)))


def _p(fn):
    def make():
        d = _plan_dict()
        fn(d)
        return d

    return make


def _seg(d):
    return d["runs"][0]["segments"][0]


PLAN_CASES = [
    ("plan-missing-runs", _p(lambda d: d.pop("runs")), ("'runs'", "required")),
    ("plan-missing-name", _p(lambda d: d.pop("name")), ("'name'", "required")),
    ("plan-missing-duration", _p(lambda d: _seg(d).pop("duration_s")), ("'runs[0].segments[0].duration_s'",)),
    ("plan-missing-start", _p(lambda d: _seg(d).pop("start_deg")), ("'runs[0].segments[0].start_deg'",)),
    ("plan-missing-instrument", _p(lambda d: d["runs"][0].pop("instrument")), ("'runs[0].instrument'",)),
    ("plan-wrong-format", _p(lambda d: d.update(format="plan-0")), ("'format'", "gyrojax-plan-1")),
    (
        "plan-start-length",
        _p(lambda d: _seg(d).update(start_deg=[0.0, 1.0])),
        ("'runs[0].segments[0].start_deg'", "1 value"),
    ),
    ("plan-rate-length", _p(lambda d: _seg(d).update(rate_dps=[])), ("'runs[0].segments[0].rate_dps'", "1 value")),
    (
        "plan-negative-duration",
        _p(lambda d: _seg(d).update(duration_s=-5)),
        ("'runs[0].segments[0].duration_s'", "> 0"),
    ),
    ("plan-zero-dt", _p(lambda d: _seg(d).update(dt_s=0)), ("'runs[0].segments[0].dt_s'", "> 0")),
    (
        "plan-duration-text",
        _p(lambda d: _seg(d).update(duration_s="long")),
        ("'runs[0].segments[0].duration_s'", "number"),
    ),
    (
        "plan-start-text",
        _p(lambda d: _seg(d).update(start_deg=["north"])),
        ("'runs[0].segments[0].start_deg'", "number"),
    ),
    ("plan-no-runs", _p(lambda d: d.update(runs=[])), ("'runs'", "at least one")),
    ("plan-no-segments", _p(lambda d: d["runs"][0].update(segments=[])), ("'runs[0].segments'", "at least one")),
    ("plan-axis-shape", _p(lambda d: d["runs"][0].update(axes=[["base"]])), ("'runs[0].axes[0]'", "[name,")),
    ("plan-latitude-range", _p(lambda d: d.update(latitude_deg=120)), ("'latitude_deg'", "[-90, 90]")),
    ("plan-latitude-bool", _p(lambda d: d.update(latitude_deg=True)), ("'latitude_deg'", "number")),
    ("plan-bad-mode", _p(lambda d: d["runs"][0].update(mode="free")), ("runs[0]", "'mode'", "servo")),
    ("plan-zero-scale", _p(lambda d: d["runs"][0].update(scale_factor=0)), ("runs[0]", "'scale_factor'", "non-zero")),
    ("plan-runs-not-list", _p(lambda d: d.update(runs={"a": 1})), ("'runs'", "list")),
    ("plan-too-many-samples", _p(lambda d: _seg(d).update(duration_s=1e12)), ("'runs[0].segments[0]'", "samples")),
]


@pytest.mark.parametrize("make,expect", [c[1:] for c in PLAN_CASES], ids=[c[0] for c in PLAN_CASES])
def test_malformed_plan(make, expect, tmp_path):
    p = tmp_path / "plan.json"
    p.write_text(json.dumps(make()), encoding="utf-8")
    with pytest.raises(PlanError) as info:
        load_plan(p)
    msg = str(info.value)
    assert "plan.json" in msg, msg
    for s in expect:
        assert s in msg, f"{s!r} not in message: {msg}"


@pytest.mark.parametrize(
    "content,expect",
    [(b"", "empty"), (b"{ not json", "JSON"), ("{}".encode("utf-16"), "UTF-8"), (b"[]", "object")],
    ids=["empty", "garbage", "utf16", "list"],
)
def test_unreadable_plan_file(content, expect, tmp_path):
    p = tmp_path / "plan.json"
    p.write_bytes(content)
    with pytest.raises(PlanError, match=expect) as info:
        load_plan(p)
    assert "plan.json" in str(info.value)


def test_builder_options_are_checked():
    with pytest.raises(PlanError, match="dt_s"):
        plans.build("fixed", dt_s=0)
    with pytest.raises(PlanError, match="nonsense"):
        plans.build("fixed", nonsense=1)
    with pytest.raises(PlanError, match="hours"):
        plans.build("fixed", hours="abc")


# ---- truth JSON ----------------------------------------------------------------------------------------------------

TRUTH_CASES = [
    ({"coefficients": {"D_Q": 1.0}}, ("'coefficients.D_Q'", "valid", "D_F")),
    ({"coefficients": {"D_F": "big"}}, ("'coefficients.D_F'", "finite number")),
    ({"coefficients": {"D_F": True}}, ("'coefficients.D_F'", "finite number")),
    ({"coefficients": [1, 2]}, ("'coefficients'", "object")),
    ({"setup": {"table_tilt": [1.0]}}, ("'setup.table_tilt'", "2 finite")),
    ({"setup": {"table_tilt": "level"}}, ("'setup.table_tilt'", "2 finite")),
    ({"setup": {"spin_wobble": 1.0}}, ("'setup.spin_wobble'", "valid")),
    ({"noise": {"white": "loud"}}, ("'noise.white'", "number")),
    ({"noise": {"pink": 1.0}}, ("noise", "'pink'", "valid")),
    ({"noise": [1]}, ("'noise'", "object")),
    ({"coefficients": {"D_F": 10**400}}, ("'coefficients.D_F'", "finite number")),
    ({"noise": {"white": []}}, ("'noise.white'", "number")),
    ({"coeffs": {}}, ("'coeffs'", "valid")),
    ({"coefficients": {"delta_E": 3.0}}, ("'coefficients.delta_E'", "setup")),
]


@pytest.mark.parametrize("d,expect", TRUTH_CASES, ids=[f"truth-{i}" for i in range(len(TRUTH_CASES))])
def test_malformed_truth(d, expect, tmp_path):
    p = tmp_path / "truth.json"
    p.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(TruthError) as info:
        load_truth(p)
    msg = str(info.value)
    assert "truth.json" in msg, msg
    for s in expect:
        assert s in msg, f"{s!r} not in message: {msg}"


def test_truth_file_unreadable(tmp_path):
    for content in (b"", b"{", b"\xff\xfe{\x00}\x00"):
        p = tmp_path / "truth.json"
        p.write_bytes(content)
        with pytest.raises(TruthError, match="truth.json"):
            load_truth(p)
    with pytest.raises(TruthError, match="no such file"):
        load_truth(tmp_path / "absent.json")
    with pytest.raises(TruthError, match="directory"):
        load_truth(tmp_path)


# ---- the command line: exit 2, one line on stderr, no traceback ----------------------------------------------------


def _bad_files(tmp_path: Path) -> dict[str, Path]:
    empty = tmp_path / "empty.json"
    empty.write_bytes(b"")
    garbage = tmp_path / "garbage.json"
    garbage.write_bytes(os.urandom(64) + b"\x00{")
    (tmp_path / "garbage.csv").write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(32))
    (tmp_path / "empty.csv").write_bytes(b"")
    return {"missing": tmp_path / "absent.json", "empty": empty, "garbage": garbage}


def _commands(paths: dict[str, Path]) -> list[list[str]]:
    """For each bad file, the invocations of every command that reads a file."""
    out = []
    for p in map(str, paths.values()):
        out += [
            ["fit", p],
            ["fit", p, "--terms", "D_F", "--json"],
            ["diagnose", p],
            ["simulate", p, "--out", str(Path(p).parent / "out")],
            ["simulate", "fixed", "--truth", p, "--out", str(Path(p).parent / "out2")],
        ]
    return out


def test_cli_bad_files_in_process(tmp_path, capsys):
    for argv in _commands(_bad_files(tmp_path)):
        rc = cli.main(argv)
        err = capsys.readouterr().err
        assert rc == 2, (argv, err)
        assert err.startswith("gyrojax: error: ") and err.count("\n") == 1, (argv, err)
        assert "Traceback" not in err


def test_cli_extra_commands_with_bad_files(tmp_path, capsys):
    """The other sub-commands (``noise``, ``design``, ``mc`` …) given bad files."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    known = {"plans", "simulate", "fit", "diagnose", "demo"}
    extras = [name for name in sub.choices if name not in known]
    paths = _bad_files(tmp_path)
    for name in extras:
        for p in map(str, paths.values()):
            rc = cli.main([name, p])
            err = capsys.readouterr().err
            assert rc == 2, (name, p, err)
            assert err.count("\n") == 1 and "Traceback" not in err


def test_cli_usage_errors(capsys):
    for argv in (
        ["plans", "extra"],
        ["fit"],
        ["nonsense"],
        ["fit", "x.json", "--bogus"],
        ["diagnose", "x.json", "--alpha", "high"],
        ["simulate", "fixed"],
        ["simulate", "no-such-plan", "--out", "x"],
    ):
        assert cli.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err, (argv, err)


@pytest.mark.parametrize(
    "argv, expect",
    [
        (["--criterion", "detect:NO_SUCH"], "NO_SUCH"),
        (["--criterion", "A:D_F=x"], "'x'"),
        (["--criterion", "detect:D_OO=big"], "'big'"),
        (["--criterion", "Q"], "criterion"),
        (["--criterion", "c:NOPE=1"], "NOPE"),
        (["--gm", "0.1"], "--gm"),
        (["--gm", "0.1,abc"], "--gm"),
        (["--gm", "-1,100"], "--gm"),
        (["--terms", "D_F,NO_SUCH"], "NO_SUCH"),
        (["--positions", "0"], "--positions"),
        (["--hours", "-1"], "--hours"),
        (["--hours", "nan"], "--hours"),
        (["--arw", "0"], "--arw"),
        (["--dt", "inf"], "--dt"),
        (["--starts", "0"], "--starts"),
        (["--adam-steps", "-3"], "--adam-steps"),
        (["--table", "three-axis"], "--table"),
        (["--positions", "many"], "--positions"),
    ],
)
def test_cli_design_bad_options(tmp_path, capsys, argv, expect):
    out = tmp_path / "plan.json"
    rc = cli.main(["design", "--out", str(out), "--adam-steps", "2", "--lbfgs-steps", "0", "--starts", "1", *argv])
    err = capsys.readouterr().err
    assert rc == 2, (argv, err)
    assert err.startswith("gyrojax: error: ") and err.count("\n") == 1 and "Traceback" not in err, (argv, err)
    assert expect in err, (argv, err)
    assert "np.float64" not in err
    assert not out.exists()


def test_cli_design_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "plan.json"
    out.write_text("precious")
    rc = cli.main(["design", "--out", str(out), "--positions", "6", "--terms", "D_F,D_I"])
    assert rc == 2 and "--force" in capsys.readouterr().err
    assert out.read_text() == "precious"


@pytest.mark.parametrize(
    "argv, expect",
    [
        (["mc", "STUDY", "--out", "OUT", "--draws", "0"], "--draws"),
        (["mc", "STUDY", "--out", "OUT", "--draws", "many"], "--draws"),
        (["mc", "MISSING", "--out", "OUT"], "MISSING"),
        (["mc", "STUDY", "--out", "OUT", "--start", "-1"], "--start"),
        (["mc", "STUDY", "--out", "OUT", "--coordinator", "nohost"], "--coordinator"),
        (["mc", "STUDY", "--out", "OUT", "--num-processes", "two"], "--num-processes"),
        (["mc", "STUDY", "--out", "OUT", "--process-id", "1", "--num-processes", "1"], "--process-id"),
        (["mc-merge", "MISSING", "--out", "OUT"], "MISSING"),
        (["noise", "MISSING"], "MISSING"),
        (["noise", "REC", "--plot", "EXISTING"], "--force"),
        (["noise", "REC", "--bogus"], "--bogus"),
    ],
)
def test_cli_mc_and_noise_bad_options(valid_dir, tmp_path, capsys, argv, expect):
    study = tmp_path / "study.json"
    study.write_text(json.dumps({"plan": "eight-position", "terms": ["D_F"], "priors": {"D_F": 0.1}, "draws": 2}))
    existing = tmp_path / "existing.png"
    existing.write_bytes(b"png")
    subst = {
        "STUDY": str(study),
        "OUT": str(tmp_path / "out"),
        "MISSING": str(tmp_path / "missing.json"),
        "REC": str(valid_dir / f"{NAME}.json"),
        "EXISTING": str(existing),
    }
    rc = cli.main([subst.get(a, a) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2, (argv, err)
    assert err.count("\n") == 1 and "Traceback" not in err, (argv, err)
    assert expect.replace("MISSING", "missing.json") in err, (argv, err)
    assert existing.read_bytes() == b"png"


def test_cli_diagnose_alpha_out_of_range(valid_dir, capsys):
    assert cli.main(["diagnose", str(valid_dir / f"{NAME}.json"), "--alpha", "1.5"]) == 2
    assert "alpha" in capsys.readouterr().err


def _noisy_copy(valid_dir, dest) -> Path:
    rec = _reference(valid_dir)
    noise = np.random.default_rng(1).standard_normal(rec.n) * 1e-3
    save_record(rec.with_columns(current_mA=rec.columns["current_mA"] + noise), dest)
    return dest / f"{NAME}.json"


def test_cli_save_onto_a_directory(valid_dir, tmp_path, capsys):
    (tmp_path / "d.json").mkdir()
    rec = _noisy_copy(valid_dir, tmp_path / "noisy")
    rc = cli.main(["fit", str(rec), "--terms", "D_F", "--save", str(tmp_path / "d.json"), "--force"])
    err = capsys.readouterr().err
    assert rc == 2 and "d.json" in err and err.count("\n") == 1


def _run_cli(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT), JAX_PLATFORMS="cpu")
    env.pop("GYROJAX_DEBUG", None)
    return subprocess.run(
        [sys.executable, "-m", "gyrojax", *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=120
    )


def test_cli_subprocess_exit_codes(tmp_path):
    paths = _bad_files(tmp_path)
    for argv in (["fit", str(paths["missing"])], ["simulate", str(paths["garbage"]), "--out", str(tmp_path / "o")]):
        p = _run_cli(*argv)
        assert p.returncode == 2, (argv, p.stderr)
        assert p.stderr.startswith("gyrojax: error: ") and p.stderr.count("\n") == 1, (argv, p.stderr)
        assert "Traceback" not in p.stderr


# ---- import: bad logs and section lists name the file, row, column or option --------------------------------------

_LOG_HEAD = "t,cnt,gx,gy,gz,ax,ay,az"


def _log(tmp_path, rows, head=_LOG_HEAD, sep=",", name="log.csv") -> Path:
    p = tmp_path / name
    p.write_text("\n".join([head.replace(",", sep)] + [sep.join(r) for r in rows]) + "\n", encoding="utf-8")
    return p


def _rows(n=30, t=lambda i: f"{i / 100:.2f}", cnt=lambda i: str(i)):
    return [[t(i), cnt(i), "0.1", "0.2", "0.3", "0.0", "0.0", "1.0"] for i in range(n)]


_MAP = "gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"


@pytest.mark.parametrize(
    "make, extra, expect",
    [
        (
            lambda d: _log(d, _rows(cnt=lambda i: str(i + (i >= 12)))),
            ["--map", _MAP + ",sample=cnt", "--rate-hz", "100"],
            ("log.csv", "column 'cnt'", "row 14", "gap"),
        ),
        (
            lambda d: _log(d, _rows(cnt=lambda i: f"{i}.5")),
            ["--map", _MAP + ",sample=cnt", "--rate-hz", "100"],
            ("column 'cnt'", "row 2", "not an integer"),
        ),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",sample=cnt"], ("--rate-hz",)),
        (
            lambda d: _log(d, _rows(t=lambda i: f"{(i if i != 7 else 5) / 100:.2f}")),
            ["--map", _MAP + ",time=t"],
            ("log.csv", "row 9", "column 't'", "does not increase"),
        ),
        (  # decimal commas beside decimal points: not read as numbers, and the hint says why
            lambda d: _log(
                d, [[c.replace(".", ",") if k == 2 else c for k, c in enumerate(r)] for r in _rows()], sep=";"
            ),
            ["--map", _MAP + ",time=t"],
            ("log.csv", "row 2", "column", "decimal comma"),
        ),
        (  # decimal commas alone are read; a log too short for the static detector is refused naming the file
            lambda d: _log(d, [[c.replace(".", ",") for c in r] for r in _rows()], sep=";"),
            ["--map", _MAP + ",time=t"],
            ("log.csv", "static detector needs at least two windows"),
        ),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",time=t", "--delimiter", "|"], ("delimiter", "'|'")),
        (
            lambda d: _log(d, _rows(), sep=";"),
            ["--map", _MAP + ",time=t", "--delimiter", ","],
            ("log.csv", "not in the file"),
        ),
        (  # a rate beside a time column is checked against it: 200 Hz said, 100 Hz in the column
            lambda d: _log(d, _rows()),
            ["--map", _MAP + ",time=t", "--rate-hz", "200"],
            ("log.csv", "--rate-hz says 200 Hz", "time column 't' (s) gives 100 Hz"),
        ),
        (lambda d: _log(d, _rows()), ["--map", _MAP, "--time-unit", "ms"], ("--time-unit", "no time column")),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",time=t,time_s=t"], ("'time' and 'time_s'",)),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",time"], ("--map", "KEY=COLUMN")),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",time=t", "--min-rest", "-1"], ("--min-rest",)),
        (lambda d: _log(d, _rows()), ["--map", _MAP + ",time=t", "--static-threshold", "0.5"], ("--static-threshold",)),
        (lambda d: _log(d, ["a;b,c", "1;2", "3"], head="x,y"), ["--map", _MAP + ",time=t"], ("log.csv", "--delimiter")),
    ],
)
def test_cli_import_csv_bad_logs(tmp_path, capsys, make, extra, expect):
    path = make(tmp_path)
    rc = cli.main(["import", "csv", str(path), "--gyro-unit", "dps", *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    for e in expect:
        assert e in err, (e, err)


_IMUCAL = Path(__file__).resolve().parent / "data" / "imucal" / "annotated_session.csv"


@pytest.mark.parametrize(
    "sections, expect",
    [
        ('{"x_p": {"start": 0, "end": 100}, "x_a": {"start": 50, "end": 200}}', ("s.json", "overlaps", "'x_p'")),
        ('{"x_p": {"start": 0, "stop": 100}}', ("s.json", "'x_p'", "start")),
        ('{"x_p": [0, 1e9]}', ("s.json", "'x_p'", "outside")),
        ('{"x_p": [0.5, 10]}', ("s.json", "'x_p'", "sample indices")),
        ('{"start": {"x_p": 0}, "end": {"x_a": 9}}', ("s.json", "different sections")),
        ("[1, 2]", ("s.json", "section list")),
        ("{nope", ("s.json", "not valid JSON")),
    ],
)
def test_cli_import_imucal_bad_section_lists(tmp_path, capsys, sections, expect):
    session = tmp_path / "session.csv"
    lines = _IMUCAL.read_text().splitlines()
    session.write_text("\n".join(ln.split(",", 1)[1] for ln in lines) + "\n")  # without 'part'
    (tmp_path / "s.json").write_text(sections)
    argv = ["import", "imucal", str(session), "--sections", str(tmp_path / "s.json"), "--gyro-scale", "16.4"]
    rc = cli.main(argv + ["--rate-hz", "204.8", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    for e in expect:
        assert e in err, (e, err)


def test_cli_import_imucal_part_column_and_section_list_is_refused(tmp_path, capsys):
    (tmp_path / "s.json").write_text('{"x_p": [0, 10]}')
    argv = ["import", "imucal", str(_IMUCAL), "--sections", str(tmp_path / "s.json"), "--gyro-scale", "16.4"]
    assert cli.main(argv + ["--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "'part' column" in err and "--sections" in err and err.count("\n") == 1, err
