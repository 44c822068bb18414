"""The record schema (conventions §5): the checks of a record's metadata (JSON) and of its columns (CSV).

Every error is a :class:`~gyrojax.errors.RecordError` naming the file and the key, or the row and the column.
"""

from __future__ import annotations

import numpy as np

from gyrojax.data.record import FORMAT, TRIAD_KEYS
from gyrojax.data.triad import is_triad, validate_triad_columns, validate_triad_meta
from gyrojax.errors import RecordError
from gyrojax.kinds import ACCEL, INSTRUMENT_KINDS, TDF
from gyrojax.protocol import is_finite_number

AXIS_TOL = 1e-6


def err(file, msg) -> RecordError:
    """The error of a record file: its path, then what is wrong."""
    return RecordError(f"{file}: {msg}")


def _unit_vector(file, key, v):
    if not isinstance(v, (list, tuple)) or len(v) != 3 or any(isinstance(x, bool) for x in v):
        raise err(file, f"key {key!r} must be a list of 3 numbers (a unit vector), got {v!r}")
    try:
        arr = np.array([float(x) for x in v])
    except (TypeError, ValueError, OverflowError):
        raise err(file, f"key {key!r} must hold 3 numbers, got {v!r}") from None
    if not np.all(np.isfinite(arr)):
        raise err(file, f"key {key!r} has a non-finite component: {v!r}")
    norm = float(np.linalg.norm(arr))
    if abs(norm - 1.0) > AXIS_TOL:
        raise err(file, f"key {key!r} is not a unit vector (norm {norm:.9g}; tolerance {AXIS_TOL})")
    return arr


def _require(file, d, key, where=""):
    if not isinstance(d, dict) or key not in d:
        raise err(file, f"missing required key {where + key!r}")
    return d[key]


def _number(file, d, key, where=""):
    v = _require(file, d, key, where)
    if not is_finite_number(v):
        raise err(file, f"key {where + key!r} must be a finite number, got {v!r}")
    return float(v)


def validate_meta(meta, file="record.json") -> dict:
    """Check a record's JSON against conventions §5; returns it unchanged (unknown keys kept)."""
    if not isinstance(meta, dict):
        raise err(file, "the top level must be a JSON object")
    fmt = _require(file, meta, "format")
    if fmt != FORMAT:
        raise err(file, f"key 'format' is {fmt!r}; this reader knows {FORMAT!r}")
    name = _require(file, meta, "name")
    if not isinstance(name, str) or not name:
        raise err(file, "key 'name' must be a non-empty string")
    if is_triad(meta):  # a hand-moved IMU: no table, segments instead (gyrojax.data.triad)
        return validate_triad_meta(meta, file)
    site = _require(file, meta, "site")
    lat = _number(file, site, "latitude_deg", "site.")
    if not -90.0 <= lat <= 90.0:
        raise err(file, f"key 'site.latitude_deg' must lie in [-90, 90], got {lat}")
    g = _number(file, site, "gravity_mps2", "site.")
    if not 9.7 <= g <= 9.9:
        raise err(file, f"key 'site.gravity_mps2' = {g} is not a gravity on the Earth's surface (9.7–9.9 m/s²)")
    table = _require(file, meta, "table")
    axes = _require(file, table, "axes", "table.")
    if not isinstance(axes, list) or not axes:
        raise err(file, "key 'table.axes' must be a non-empty list of {name, axis_enu}")
    seen = set()
    for i, ax in enumerate(axes):
        where = f"table.axes[{i}]."
        nm = _require(file, ax, "name", where)
        if not isinstance(nm, str) or not nm or "," in nm:
            raise err(file, f"key {where + 'name'!r} must be a non-empty string without commas")
        if nm in seen:
            raise err(file, f"key {where + 'name'!r}: axis name {nm!r} is used twice")
        seen.add(nm)
        _unit_vector(file, where + "axis_enu", _require(file, ax, "axis_enu", where))
    inst = _require(file, meta, "instrument")
    kind = _require(file, inst, "kind", "instrument.")
    if kind not in INSTRUMENT_KINDS:
        raise err(file, f"key 'instrument.kind' is {kind!r}; valid: {', '.join(INSTRUMENT_KINDS)}")
    keys = TRIAD_KEYS[kind]
    vecs = [_unit_vector(file, f"instrument.{k}", _require(file, inst, k, "instrument.")) for k in keys]
    for i in range(3):
        for j in range(i + 1, 3):
            d = float(vecs[i] @ vecs[j])
            if abs(d) > AXIS_TOL:
                raise err(
                    file,
                    f"keys 'instrument.{keys[i]}' and 'instrument.{keys[j]}' are not orthogonal (dot {d:.3g})",
                )
    # right-handed: first × second = third (IA × OA = SA; X × Y = Z; IA × PA = OA)
    hand = float(np.cross(vecs[0], vecs[1]) @ vecs[2])
    if hand < 0:
        raise err(
            file,
            f"key 'instrument.{keys[2]}': the triad is left-handed; "
            f"{keys[0]} × {keys[1]} must equal {keys[2]} (it equals −{keys[2]})",
        )
    mode = _require(file, meta, "mode")
    if mode not in ("rebalance", "servo"):
        raise err(file, f"key 'mode' is {mode!r}; valid: 'rebalance', 'servo'")
    sf_key = "scale_factor_g_per_mA" if kind == ACCEL else "scale_factor_deg_per_h_per_mA"
    sf = _number(file, meta, sf_key)
    if sf == 0.0:
        raise err(file, f"key {sf_key!r} must be non-zero")
    servo = meta.get("servo_axis")
    if mode == "servo":
        if servo is None:
            raise err(file, "key 'servo_axis' must name a table axis when mode is 'servo'")
        if kind == TDF:
            raise err(file, "key 'mode': servo mode is supported for sdf-gyro and pendulous-accel only")
    if servo is not None and (not isinstance(servo, str) or servo not in seen):
        raise err(file, f"key 'servo_axis' is {servo!r}; table axes are {sorted(seen)}")
    return meta


NUMERIC_COLUMNS = ("time_s", "segment", "temperature_C", "current_mA", "current_x_mA", "current_y_mA")
TRIAD_COLUMN_PREFIXES = ("gyro_", "acc_")  # triad records (gyrojax.data.triad): gyro_<c>_dps|counts, acc_<c>_g


def must_be_numeric(column: str) -> bool:
    """Columns of conventions §5 (these must hold finite numbers); any other column is extra, kept and ignored."""
    return (
        column in NUMERIC_COLUMNS
        or (column.startswith("angle_") and column.endswith("_deg"))
        or (column.startswith("rate_") and column.endswith("_dps"))
        or column.startswith(TRIAD_COLUMN_PREFIXES)
    )


def _column_hint(columns, want: str) -> str:
    """A hint when a required column seems present under another spelling (a unit in the name, other case)."""
    import re

    for c in columns:
        base = re.sub(r"\s*[\[(].*$", "", c).strip()
        if c != want and base == want:
            return (
                f"; column {c!r} looks like {want!r} with a unit: units are fixed by conventions §5, "
                f"so name it exactly {want!r}"
            )
        if c != want and c.lower() == want.lower():
            return f"; column {c!r} differs only in case: name it exactly {want!r}"
    return ""


def validate_columns(meta: dict, columns: dict[str, np.ndarray], file="record.csv") -> None:
    """Check the CSV columns against the metadata (conventions §5)."""
    if "time_s" not in columns:
        hint = _column_hint(columns, "time_s")
        raise err(file, f"missing required column 'time_s'{hint}; columns are {list(columns)}")
    if is_triad(meta):
        _check_times(columns["time_s"], file)
        return validate_triad_columns(meta, columns, file)
    _check_times(columns["time_s"], file)
    names = [a["name"] for a in meta["table"]["axes"]]
    for a in names:
        if f"angle_{a}_deg" not in columns:
            hint = [c for c in columns if c.startswith("angle_")]
            raise err(
                file,
                f"missing required column 'angle_{a}_deg' for table axis {a!r}"
                f"{_column_hint(columns, f'angle_{a}_deg')}; angle columns: {hint}",
            )
    kind = meta["instrument"]["kind"]
    if meta["mode"] == "rebalance":
        need = ("current_x_mA", "current_y_mA") if kind == TDF else ("current_mA",)
        for c in need:
            if c not in columns:
                raise err(file, f"missing required column {c!r} (rebalance mode, {kind}){_column_hint(columns, c)}")
    if "segment" in columns:
        seg = columns["segment"]
        if np.any(seg != np.round(seg)):
            i = int(np.flatnonzero(seg != np.round(seg))[0])
            raise err(file, f"row {i + 2}, column 'segment' holds {float(seg[i])}; segment labels are integers")


def _check_times(t, file) -> None:
    if len(t) > 1:
        bad = t[1:] <= t[:-1]  # a step that is not positive (same as diff <= 0 for finite times)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            what = "repeats" if t[i + 1] == t[i] else "decreases from"
            raise err(
                file,
                f"row {i + 3}, column 'time_s': time {what} the previous row's {float(t[i])} (got {float(t[i + 1])}); "
                "times must be strictly increasing",
            )
