"""The set-up of a turntable data system's log: which column holds what, in which unit, and the test's set-up (site,
table axes, mounting, mode, instrument kind, nominal scale), from a small set-up file (TOML or JSON) and flags.

A set-up file (every key optional where a flag or a default gives it)::

    name = "fog-ia-up"                          # record name (default: the log's file stem)
    kind = "fog"                                # sdf-gyro, tdf-gyro, pendulous-accel, fog, rlg
    mode = "rebalance"                          # or "servo" (then servo_axis names a table axis)
    site = {latitude_deg = 39.98, gravity_mps2 = 9.80155}
    table.axes = [{name = "spin", axis_enu = [0, 0, 1]}]
    instrument = {ia = [0, 0, 1], oa = [1, 0, 0]}   # the mounting, platform coordinates; the third axis optional
    scale = "0.02 V/(deg/s)"                    # nominal scale of the output (or {value = 0.02, unit = "V/(deg/s)"})
    clock_offset_s = 1.234                      # second log: its clock + offset = the table log's clock
    [columns]                                   # KEY = "COLUMN" or {column = …, unit = …, counts_per_rev = …}
    time = {column = "Time [ms]", unit = "ms"}
    angle_spin = {column = "Enc1", unit = "counts", counts_per_rev = 16777216}
    output = {column = "Vout [V]", unit = "V"}
    temperature = {column = "Temp [C]", unit = "C"}

Column keys: ``time`` (the table log's clock), ``gyro_time`` (the instrument's log's clock, when it has a log of its
own), ``angle_<axis>`` and/or ``rate_<axis>`` for each table axis, ``output`` (``output_x``, ``output_y`` for a TDF
gyro), ``temperature``, ``segment`` (a data system's own step number). Units: time s, ms, us, ns or ``iso`` (ISO 8601
date-times); angle deg, rad, arcsec or counts (with ``counts_per_rev``); table rate deg/s, rad/s, deg/h or rpm;
output mA, A, uA (torquer current), V, mV (volts at a nominal scale), pulses (counts per interval, at a pulse weight),
deg/h, deg/s, rad/s (a rate, gyros) or g, m/s^2 (an accelerometer); temperature C, K or F (the unit tables and the
nominal scale: :mod:`gyrojax.data.tableunits`). Every error names the file and the key, or the flag.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyrojax.data.tableunits import (
    ANGLE_UNITS,
    OUTPUT_UNITS,
    RATE_UNITS,
    TEMPERATURE_UNITS,
    TIME_UNITS,
    scale_in_base,
)
from gyrojax.errors import RecordError
from gyrojax.kinds import ACCEL, INSTRUMENT_KINDS, TDF
from gyrojax.protocol import is_finite_number

SETUP_KEYS = (
    "name",
    "kind",
    "mode",
    "servo_axis",
    "id",
    "notes",
    "site",
    "table",
    "instrument",
    "scale",
    "clock_offset_s",
    "columns",
    "keep_transitions",
)
COLUMN_FIXED = ("time", "gyro_time", "output", "output_x", "output_y", "temperature", "segment")
COLUMN_SPEC_KEYS = ("column", "unit", "counts_per_rev")
MOUNT_KEYS = {"sdf-gyro": ("ia", "oa", "sa"), "fog": ("ia", "oa", "sa"), "rlg": ("ia", "oa", "sa")}
MOUNT_KEYS.update({TDF: ("x", "y", "z"), ACCEL: ("ia", "pa", "oa")})


@dataclass
class Column:
    """One mapped column: its name in the log, its unit (s, deg, deg/s, mA, V, °C … as the log writes them) and
    (encoder angles) the counts per revolution."""

    column: str
    unit: str | None = None
    counts_per_rev: float | None = None


@dataclass
class TableSetup:
    """A validated set-up (module doc); ``where[key]`` says where each value came from (file and key, or flag)."""

    name: str | None = None
    kind: str = "sdf-gyro"
    mode: str = "rebalance"
    servo_axis: str | None = None
    instrument_id: str | None = None
    notes: str = ""
    latitude_deg: float | None = None
    gravity_mps2: float | None = None
    axes: list = field(default_factory=list)  # [(name, (E, N, U))]
    mounting: dict = field(default_factory=dict)  # {"ia": (3,), …}
    scale: tuple | None = None  # (value, unit text)
    clock_offset_s: float = 0.0
    columns: dict = field(default_factory=dict)  # key -> Column
    keep_transitions: bool = False
    where: dict = field(default_factory=dict)


def _err(where: str, msg: str) -> RecordError:
    return RecordError(f"{where}: {msg}")


def _sub(where: str, suffix: str) -> str:
    """``where`` of a sub-key: ``FILE: key 'a'`` and ``.b`` → ``FILE: key 'a.b'`` (a flag: ``--axes[0]``)."""
    return where[:-1] + suffix + "'" if where.endswith("'") else where + suffix


def read_setup_file(path) -> dict:
    """A set-up file as a dict: TOML (``.toml``) or JSON (``.json``); :class:`RecordError` naming the file."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as e:
        raise _err(str(p), f"cannot read the set-up file ({e.strerror or e})") from None
    suffix = p.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise _err(str(p), "a set-up file is TOML (.toml) or JSON (.json)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise _err(str(p), f"is not UTF-8 (byte {e.start}); save it as UTF-8") from None
    try:
        if suffix == ".json":
            d = json.loads(text)
        else:
            import tomllib

            d = tomllib.loads(text)
    except ValueError as e:
        raise _err(str(p), f"is not valid {suffix[1:].upper()}: {e}") from None
    if not isinstance(d, dict):
        raise _err(str(p), "the top level must be a table (TOML) or an object (JSON)")
    return d


def _vector(v, where: str) -> np.ndarray:
    """A unit 3-vector (normalised from any non-zero one given as three numbers)."""
    if not isinstance(v, (list, tuple)) or len(v) != 3 or not all(is_finite_number(x) for x in v):
        raise _err(where, f"must be three numbers (a direction), got {v!r}")
    a = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(a))
    if n == 0:
        raise _err(where, "is the zero vector; give a direction")
    if abs(n - 1.0) > 1e-6:
        raise _err(where, f"is not a unit vector (norm {n:.9g}); conventions §5 axes are unit vectors")
    return a


def _string(v, where: str) -> str:
    if not isinstance(v, str) or not v.strip():
        raise _err(where, f"must be a non-empty string, got {v!r}")
    return v.strip()


def _number(v, where: str, positive: bool = False) -> float:
    if not is_finite_number(v) or (positive and float(v) <= 0):
        raise _err(where, f"must be a {'positive ' if positive else ''}finite number, got {v!r}")
    return float(v)


def column_spec(v, where: str) -> Column:
    """A column entry: ``"COLUMN"`` or ``{column, unit, counts_per_rev}``."""
    if isinstance(v, str):
        return Column(_string(v, where))
    if not isinstance(v, dict):
        raise _err(where, f'must be a column name or {{column = "…", unit = "…"}}, got {v!r}')
    unknown = sorted(set(v) - set(COLUMN_SPEC_KEYS))
    if unknown:
        raise _err(_sub(where, f".{unknown[0]}"), f"unknown key; a column entry has {', '.join(COLUMN_SPEC_KEYS)}")
    if "column" not in v:
        raise _err(_sub(where, ".column"), "missing: the column's name in the log")
    unit = None if v.get("unit") is None else _string(v["unit"], _sub(where, ".unit"))
    cpr = v.get("counts_per_rev")
    cpr = None if cpr is None else _number(cpr, _sub(where, ".counts_per_rev"), positive=True)
    return Column(_string(v["column"], _sub(where, ".column")), unit, cpr)


def setup_from_dict(d: dict, where: str) -> TableSetup:
    """A :class:`TableSetup` from a set-up file's dict (``where``: the file, for error messages)."""
    s = TableSetup()
    for k in d:
        if k not in SETUP_KEYS:
            raise _err(f"{where}: key {k!r}", f"unknown; a set-up file has {', '.join(SETUP_KEYS)}")
    here = {k: f"{where}: key {k!r}" for k in SETUP_KEYS}
    if "name" in d:
        s.name = _string(d["name"], here["name"])
    if "kind" in d:
        s.kind = d["kind"]
    if "mode" in d:
        s.mode = d["mode"]
    if d.get("servo_axis") is not None:
        s.servo_axis = _string(d["servo_axis"], here["servo_axis"])
    if d.get("id") is not None:
        s.instrument_id = _string(str(d["id"]), here["id"])
    if "notes" in d:
        s.notes = str(d["notes"])
    if "site" in d:
        site = d["site"]
        if not isinstance(site, dict):
            raise _err(here["site"], "must be a table with latitude_deg and gravity_mps2")
        for k in site:
            if k not in ("latitude_deg", "gravity_mps2"):
                raise _err(f"{where}: key 'site.{k}'", "unknown; site has latitude_deg and gravity_mps2")
        if "latitude_deg" in site:
            s.latitude_deg = _number(site["latitude_deg"], f"{where}: key 'site.latitude_deg'")
            s.where["latitude_deg"] = f"{where}: key 'site.latitude_deg'"
        if "gravity_mps2" in site:
            s.gravity_mps2 = _number(site["gravity_mps2"], f"{where}: key 'site.gravity_mps2'")
            s.where["gravity_mps2"] = f"{where}: key 'site.gravity_mps2'"
    if "table" in d:
        t = d["table"]
        if not isinstance(t, dict) or set(t) != {"axes"}:
            raise _err(here["table"], "must be a table with one key, axes = [{name, axis_enu}, …]")
        s.axes = parse_axes_list(t["axes"], f"{where}: key 'table.axes'")
    if "instrument" in d:
        inst = d["instrument"]
        if not isinstance(inst, dict):
            raise _err(here["instrument"], "must be a table of instrument axes (the mounting), e.g. ia, oa")
        s.mounting = {k: v for k, v in inst.items()}
        s.where["mounting"] = f"{where}: key 'instrument'"
    if "scale" in d:
        s.scale = parse_scale(d["scale"], here["scale"])
        s.where["scale"] = here["scale"]
    if "clock_offset_s" in d:
        s.clock_offset_s = _number(d["clock_offset_s"], here["clock_offset_s"])
    if "keep_transitions" in d:
        if not isinstance(d["keep_transitions"], bool):
            raise _err(here["keep_transitions"], f"must be true or false, got {d['keep_transitions']!r}")
        s.keep_transitions = d["keep_transitions"]
    if "columns" in d:
        cols = d["columns"]
        if not isinstance(cols, dict):
            raise _err(here["columns"], "must be a table of KEY = column entries")
        for k, v in cols.items():
            s.columns[k] = column_spec(v, f"{where}: key 'columns.{k}'")
            s.where[f"columns.{k}"] = f"{where}: key 'columns.{k}'"
    for k in ("kind", "mode", "servo_axis"):
        s.where[k] = here[k]
    return s


def parse_axes_list(v, where: str) -> list:
    """Table axes, outermost first: ``[{name, axis_enu}, …]`` → [(name, unit vector)]."""
    if not isinstance(v, list) or not v:
        raise _err(where, "must be a non-empty list of {name, axis_enu}, outermost first")
    out, seen = [], set()
    for i, ax in enumerate(v):
        w = _sub(where, f"[{i}]")
        if not isinstance(ax, dict) or set(ax) != {"name", "axis_enu"}:
            raise _err(w, f"must have exactly the keys name and axis_enu, got {ax!r}")
        name = _string(ax["name"], _sub(w, ".name"))
        if not re.fullmatch(r"[A-Za-z0-9_\-]+", name):
            raise _err(_sub(w, ".name"), f"{name!r}: an axis name is letters, digits, '_' or '-' (it names columns)")
        if name in seen:
            raise _err(_sub(w, ".name"), f"axis {name!r} is named twice")
        seen.add(name)
        out.append((name, _vector(ax["axis_enu"], _sub(w, ".axis_enu"))))
    return out


def parse_axes_flag(text: str) -> list:
    """``--axes NAME=E,N,U[;NAME=E,N,U]`` (outermost first) → [(name, unit vector)]."""
    items = []
    for part in text.split(";"):
        if "=" not in part:
            raise _err(f"--axes {text!r}", "give NAME=E,N,U for each table axis, ';' between axes, outermost first")
        name, vec = part.split("=", 1)
        try:
            nums = [float(x) for x in vec.split(",")]
        except ValueError:
            raise _err(f"--axes {text!r}", f"axis {name.strip()!r}: {vec!r} is not three numbers") from None
        items.append({"name": name.strip(), "axis_enu": nums})
    return parse_axes_list(items, "--axes")


def parse_mounting_flag(text: str) -> dict:
    """``--mounting ia=0,0,1;oa=1,0,0`` → {"ia": [0, 0, 1], "oa": [1, 0, 0]} (checked with the kind later)."""
    out = {}
    for part in text.split(";"):
        if "=" not in part:
            raise _err(f"--mounting {text!r}", "give AXIS=x,y,z pairs separated by ';' (e.g. ia=0,0,1;oa=1,0,0)")
        k, vec = part.split("=", 1)
        try:
            out[k.strip()] = [float(x) for x in vec.split(",")]
        except ValueError:
            raise _err(f"--mounting {text!r}", f"{k.strip()}: {vec!r} is not three numbers") from None
    return out


def mounting_axes(kind: str, given: dict, where: str) -> dict:
    """The instrument's axes in platform coordinates (conventions §5), the third from the first two when absent;
    unit, orthogonal and right-handed (first × second = third), or an error naming the key."""
    keys = MOUNT_KEYS[kind]
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise _err(_sub(where, f".{unknown[0]}"), f"a {kind}'s axes are {', '.join(keys)}")
    missing = [k for k in keys[:2] if k not in given]
    if missing:
        raise _err(where, f"the mounting needs {keys[0]} and {keys[1]} (platform coordinates); {missing[0]} missing")
    a, b = (_vector(given[k], _sub(where, f".{k}")) for k in keys[:2])
    if abs(float(a @ b)) > 1e-6:
        raise _err(where, f"{keys[0]} and {keys[1]} are not orthogonal (dot {float(a @ b):.3g})")
    c = np.cross(a, b)
    if keys[2] in given:
        g = _vector(given[keys[2]], _sub(where, f".{keys[2]}"))
        if float(g @ c) < 1 - 1e-6:
            raise _err(
                _sub(where, f".{keys[2]}"),
                f"must be {keys[0]} × {keys[1]} = {np.round(c, 9).tolist()} (a right-handed triad), got {g.tolist()}",
            )
    return {keys[0]: a.tolist(), keys[1]: b.tolist(), keys[2]: np.round(c, 15).tolist()}


def parse_scale(v, where: str) -> tuple[float, str]:
    """A nominal scale as (value, unit text): ``"0.02 V/(deg/s)"`` or ``{value = 0.02, unit = "V/(deg/s)"}``."""
    if isinstance(v, str):
        parts = v.strip().split(None, 1)
        if len(parts) != 2:
            raise _err(where, f"{v!r}: give a value and a unit, e.g. '0.02 V/(deg/s)' or '17.17 deg/h/mA'")
        try:
            value = float(parts[0])
        except ValueError:
            raise _err(where, f"{v!r}: {parts[0]!r} is not a number") from None
        v = {"value": value, "unit": parts[1]}
    if not isinstance(v, dict) or set(v) != {"value", "unit"}:
        raise _err(where, f'must be "VALUE UNIT" or {{value, unit}}, got {v!r}')
    value = _number(v["value"], _sub(where, ".value"))
    if value == 0:
        raise _err(_sub(where, ".value"), "must be non-zero")
    return value, _string(v["unit"], _sub(where, ".unit"))


def apply_flags(s: TableSetup, flags: dict) -> TableSetup:
    """``s`` with the command line's values laid over the set-up file's: ``flags`` maps a flag (``--kind``) to its
    value (None: not given). ``--map KEY=COL,…`` replaces column names and keeps a unit the file gave; the unit
    flags set the unit of every column of their kind."""
    f = {k: v for k, v in flags.items() if v is not None}
    for flag, attr in (("--name", "name"), ("--kind", "kind"), ("--mode", "mode"), ("--servo-axis", "servo_axis")):
        if flag in f:
            setattr(s, attr, f[flag])
            s.where[attr] = flag
    if "--id" in f:
        s.instrument_id = f["--id"]
    if "--latitude" in f:
        s.latitude_deg, s.where["latitude_deg"] = float(f["--latitude"]), "--latitude"
    if "--gravity" in f:
        s.gravity_mps2, s.where["gravity_mps2"] = float(f["--gravity"]), "--gravity"
    if "--axes" in f:
        s.axes = parse_axes_flag(f["--axes"])
    if "--mounting" in f:
        s.mounting, s.where["mounting"] = parse_mounting_flag(f["--mounting"]), "--mounting"
    if "--scale" in f:
        s.scale, s.where["scale"] = parse_scale(f["--scale"], "--scale"), "--scale"
    if "--clock-offset" in f:
        s.clock_offset_s = float(f["--clock-offset"])
    if f.get("--keep-transitions"):
        s.keep_transitions = True
    if "--map" in f:
        for key, col in f["--map"].items():
            old = s.columns.get(key)
            s.columns[key] = Column(col, old.unit if old else None, old.counts_per_rev if old else None)
            s.where[f"columns.{key}"] = f"--map {key}={col}"
    units_by_flag = (
        ("--time-unit", lambda k: k == "time", "unit"),
        ("--gyro-time-unit", lambda k: k == "gyro_time", "unit"),
        ("--angle-unit", lambda k: k.startswith("angle_"), "unit"),
        ("--counts-per-rev", lambda k: k.startswith("angle_"), "counts_per_rev"),
        ("--rate-unit", lambda k: k.startswith("rate_"), "unit"),
        ("--output-unit", lambda k: k.startswith("output"), "unit"),
        ("--temperature-unit", lambda k: k == "temperature", "unit"),
    )
    for flag, applies, attr in units_by_flag:
        if flag in f:
            hit = [k for k in s.columns if applies(k)]
            if not hit:
                raise _err(flag, "no mapped column takes it (map the column with --map or in the set-up file)")
            for k in hit:
                setattr(s.columns[k], attr, f[flag])
                if flag == "--angle-unit" and f[flag] != "counts" and "--counts-per-rev" not in f:
                    s.columns[k].counts_per_rev = None  # the file's encoder resolution went with its unit
                s.where[f"columns.{k}"] = f"{s.where.get(f'columns.{k}', k)} with {flag}"
    return s


KEY_OR_FLAG = {
    "kind": "set-up key 'kind' (--kind)",
    "mode": "set-up key 'mode' (--mode)",
    "servo_axis": "set-up key 'servo_axis' (--servo-axis)",
    "latitude_deg": "set-up key 'site.latitude_deg' (--latitude)",
    "gravity_mps2": "set-up key 'site.gravity_mps2' (--gravity)",
    "axes": "set-up key 'table.axes' (--axes)",
    "mounting": "set-up key 'instrument' (--mounting)",
    "scale": "set-up key 'scale' (--scale)",
    "columns": "set-up key 'columns' (--map)",
    "clock_offset_s": "set-up key 'clock_offset_s' (--clock-offset)",
}
"""How an error names a set-up value that no file or flag gave (the key, and the flag that gives it too)."""


def check_setup(s: TableSetup) -> TableSetup:
    """The set-up as a whole: kind, mode, site, axes, mounting and the columns each needs (errors name the key or
    the flag, as ``s.where`` records it)."""
    w = {**KEY_OR_FLAG, **s.where}
    if s.kind not in INSTRUMENT_KINDS:
        raise _err(w["kind"], f"is {s.kind!r}; valid: {', '.join(INSTRUMENT_KINDS)}")
    if s.mode not in ("rebalance", "servo"):
        raise _err(w["mode"], f"is {s.mode!r}; valid: rebalance, servo")
    if s.latitude_deg is None:
        raise _err(w["latitude_deg"], "missing: the site latitude, deg")
    if not -90 <= s.latitude_deg <= 90:
        raise _err(w["latitude_deg"], f"must lie in [-90, 90] deg, got {s.latitude_deg}")
    if s.gravity_mps2 is not None and not 9.7 <= s.gravity_mps2 <= 9.9:
        raise _err(w["gravity_mps2"], f"{s.gravity_mps2} is not a gravity on the Earth (9.7–9.9 m/s²)")
    if not s.axes:
        raise _err(w["axes"], "missing: the table axes, [{name, axis_enu}] or NAME=E,N,U, outermost first")
    names = [a for a, _ in s.axes]
    if s.mode == "servo":
        if s.kind not in ("sdf-gyro", ACCEL):
            raise _err(w["mode"], f"servo mode is for sdf-gyro and pendulous-accel, not {s.kind}")
        if s.servo_axis is None:
            raise _err(w["servo_axis"], f"servo mode needs servo_axis, one of {names}")
    if s.servo_axis is not None and s.servo_axis not in names:
        raise _err(w["servo_axis"], f"is {s.servo_axis!r}; the table axes are {names}")
    s.mounting = mounting_axes(s.kind, s.mounting, w["mounting"])
    keys = set(COLUMN_FIXED) | {f"angle_{a}" for a in names} | {f"rate_{a}" for a in names}
    for k in s.columns:
        if k not in keys:
            raise _err(
                w.get(f"columns.{k}", f"column key {k!r}"),
                f"unknown column key {k!r}; valid: {', '.join(sorted(keys))}",
            )
    if "time" not in s.columns:
        raise _err(w["columns"], "missing the time column: columns.time (--map time=COL)")
    for a in names:
        if f"angle_{a}" not in s.columns and f"rate_{a}" not in s.columns:
            raise _err(w["columns"], f"table axis {a!r} needs angle_{a} or rate_{a} (its angle or its rate column)")
    outs = ("output_x", "output_y") if s.kind == TDF else ("output",)
    wrong = [k for k in ("output", "output_x", "output_y") if k in s.columns and k not in outs]
    if wrong:
        raise _err(w.get(f"columns.{wrong[0]}", wrong[0]), f"a {s.kind} maps {' and '.join(outs)}, not {wrong[0]}")
    if s.mode == "rebalance":
        for k in outs:
            if k not in s.columns:
                raise _err(w["columns"], f"a {s.kind} in rebalance mode needs its output column {k} (--map {k}=COL)")
    for k, c in s.columns.items():
        check_unit(k, c, s, w.get(f"columns.{k}", f"column {k}"))
    if "gyro_time" not in s.columns and s.clock_offset_s != 0.0:
        raise _err(w["clock_offset_s"], "applies to a second log (columns.gyro_time); this log has one clock")
    return s


def check_unit(key: str, c: Column, s: TableSetup, where: str) -> None:
    """A column's unit, defaulted where there is one, checked against its key and the instrument kind."""
    if key in ("time", "gyro_time"):
        c.unit = c.unit or "s"
        if c.unit not in TIME_UNITS:
            raise _err(where, f"time unit {c.unit!r}; valid: {', '.join(TIME_UNITS)}")
    elif key.startswith("angle_"):
        c.unit = c.unit or "deg"
        if c.unit not in ANGLE_UNITS:
            raise _err(where, f"angle unit {c.unit!r}; valid: {', '.join(ANGLE_UNITS)}")
        if c.unit == "counts" and c.counts_per_rev is None:
            raise _err(where, "encoder counts need counts_per_rev (--counts-per-rev): counts in one revolution")
        if c.unit != "counts" and c.counts_per_rev is not None:
            raise _err(where, f"counts_per_rev applies to angles in counts, not in {c.unit}")
    elif key.startswith("rate_"):
        c.unit = c.unit or "deg/s"
        if c.unit not in RATE_UNITS:
            raise _err(where, f"table rate unit {c.unit!r}; valid: {', '.join(RATE_UNITS)}")
    elif key.startswith("output"):
        if c.unit is None:
            raise _err(where, f"the output's unit is needed (--output-unit): one of {', '.join(OUTPUT_UNITS)}")
        if c.unit not in OUTPUT_UNITS:
            raise _err(where, f"output unit {c.unit!r}; valid: {', '.join(OUTPUT_UNITS)}")
        quantity = OUTPUT_UNITS[c.unit][0]
        allowed = {"acceleration", "current", "voltage", "pulses"} if s.kind == ACCEL else {"rate", "voltage", "pulses"}
        if s.kind in ("sdf-gyro", TDF):
            allowed = allowed | {"current"}
        if s.mode == "servo":
            allowed = {"current"}  # the commanded torquer current
        if quantity not in allowed:
            raise _err(
                where, f"a {s.kind} in {s.mode} mode has no {quantity} output ({c.unit}); valid: {sorted(allowed)}"
            )
        scale_where = s.where.get("scale", KEY_OR_FLAG["scale"])
        if quantity in ("rate", "acceleration"):
            if s.scale is not None:
                raise _err(scale_where, f"the output is already a {quantity} ({c.unit}); no scale")
        elif s.scale is None:
            raise _err(scale_where, f"missing: an output in {c.unit} needs its nominal scale ('VALUE UNIT')")
        else:
            scale_in_base(s.scale, c.unit, s.kind, scale_where)  # a unit that does not fit the output: named now
    elif key == "temperature":
        c.unit = c.unit or "C"
        if c.unit not in TEMPERATURE_UNITS:
            raise _err(where, f"temperature unit {c.unit!r}; valid: {', '.join(TEMPERATURE_UNITS)}")
    elif c.unit is not None:  # segment
        raise _err(where, f"a {key} column has no unit")
