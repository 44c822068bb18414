"""Importers: IMU calibration sessions in the formats people already have, into ``imu-triad`` records
(:mod:`gyrojax.data.triad`).

* :func:`import_imucal` — imucal's Ferraris sessions (mad-lab-fau/imucal): a table with columns
  ``acc_x, acc_y, acc_z, gyr_x, gyr_y, gyr_z`` and either a ``part`` column naming the sections (``x_p``, ``x_a``, …,
  ``x_rot``, …: imucal's annotated sessions) or imucal's section list (:func:`read_sections`).
* :func:`gyrojax.data.imutk.import_imutk` — imu_tk's files (its own module), through :func:`triad_from_arrays`.
* :func:`import_csv` — any delimited log (or a MATLAB file), with a column mapping; its clock a time column (s, ms,
  µs), a sample counter or a rate (given, or the logger's preamble's), every statement of it cross-checked.
* :func:`triad_from_arrays` — a calibration session (at least 9 rests and the moves between them) or a rest log
  (:mod:`gyrojax.data.restlog`), the gyro at rest checked and the clock, ranges and rests said
  (:mod:`gyrojax.data.door`).

The accelerometer is never taken as calibrated on trust (:func:`~gyrojax.data.accelcheck.accelerometer_in_g`):
calibrated by the importer (Ferraris' six faces: raw = A a + b by least squares; imu_tk's ellipsoid over the rests)
or checked against g, and written in g, so that the gyro fit sees the specific force of each pose; a calibration is
kept in the record's JSON under ``accelerometer_calibration``. Every importer reports what it read under ``import``
in the record's JSON: the rests found, the candidates dropped and why, the rests joined, the accelerometer check and
its notes.
"""

from __future__ import annotations

import json
import numbers
from pathlib import Path

import numpy as np

from gyrojax import units
from gyrojax.data.accelcheck import accelerometer_in_g
from gyrojax.data.gyroonly import gyro_only_segments
from gyrojax.data.logs import (
    TIME_UNITS,
    file_stem,
    jitter_note,
    log_clock,
    numeric_columns,
    read_table,
    time_column,
)
from gyrojax.data.record import Record
from gyrojax.data.segments import MIN_REST_S
from gyrojax.data.triad import CHANNELS, triad_meta, validate_triad_columns, validate_triad_meta
from gyrojax.errors import RecordError
from gyrojax.physics.gravity import site_gravity

FERRARIS_FACES = {
    "x_p": (0, 1.0),
    "x_a": (0, -1.0),
    "y_p": (1, 1.0),
    "y_a": (1, -1.0),
    "z_p": (2, 1.0),
    "z_a": (2, -1.0),
}
"""imucal's static sections: the sensor axis that points up (``p``) or down (``a``)."""
FERRARIS_ROTATIONS = {"x_rot": "x", "y_rot": "y", "z_rot": "z"}


def ferraris_accelerometer(means: dict, g: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Accelerometer calibration raw = A a + b (A 3×3 in raw units per g, b raw) by least squares over the six
    Ferraris faces (Ferraris et al. 1995), each face's specific force taken as ±``g`` along its axis (g units).

    ``means``: face name → mean raw accelerometer reading (3,). 18 equations, 12 unknowns.
    """
    missing = [f for f in FERRARIS_FACES if f not in means]
    if missing:
        raise RecordError(f"the accelerometer calibration needs the six faces; missing {missing}")
    rows, rhs = [], []
    for f, (axis, sign) in FERRARIS_FACES.items():
        a = np.zeros(3)
        a[axis] = sign * g
        rows.append(np.concatenate([a, [1.0]]))
        rhs.append(np.asarray(means[f], dtype=float))
    sol, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
    return sol[:3].T, sol[3]


def _section_bounds(name, v, where: str) -> tuple[int, int]:
    """(start, end) of one section entry: ``[start, end]`` or imucal's ``{"start": s, "end": e}``."""
    if isinstance(v, dict) and set(v) == {"start", "end"}:
        v = [v["start"], v["end"]]
    ok = isinstance(v, (list, tuple)) and len(v) == 2
    ok = ok and all(isinstance(i, numbers.Real) and not isinstance(i, bool) and float(i).is_integer() for i in v)
    if not ok:
        raise RecordError(
            f'{where}: section {name!r} must be [start, end] or {{"start": s, "end": e}} sample indices, got {v!r}'
        )
    return int(v[0]), int(v[1])


def read_sections(sections, where: str = "sections") -> dict:
    """A section list as ``{name: (start, end)}`` (row positions, end exclusive, as imucal's ``iloc``) from a dict or
    a file: JSON ``{"x_p": [start, end], …}``, imucal's ``{"x_p": {"start": s, "end": e}, …}`` (its section list
    saved with ``to_json(orient="index")``), pandas' default ``{"start": {"x_p": s, …}, "end": {…}}``, or imucal's
    CSV (``section_list.to_csv``: an index column of names, then ``start``, ``end``)."""
    if isinstance(sections, (str, Path)):
        where = str(sections)
        p = Path(sections)
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise RecordError(f"{where}: cannot read the section list ({e})") from None
        if p.suffix.lower() == ".csv":
            import io

            import pandas as pd

            try:
                df = pd.read_csv(io.StringIO(text), index_col=0)
            except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
                raise RecordError(f"{where}: not a readable section list ({str(e).strip()[:120]})") from None
            if list(df.columns) != ["start", "end"]:
                raise RecordError(f"{where}: a CSV section list has columns name, start, end; got {list(df.columns)}")
            sections = {str(k): [r["start"], r["end"]] for k, r in df.iterrows()}
        else:
            try:
                sections = json.loads(text)
            except json.JSONDecodeError as e:
                raise RecordError(f"{where}: not valid JSON ({e})") from None
    if not isinstance(sections, dict) or not sections:
        raise RecordError(f'{where}: a section list is an object {{"x_p": {{"start": s, "end": e}}, …}}')
    if set(sections) == {"start", "end"} and all(isinstance(v, dict) for v in sections.values()):
        names = list(sections["start"])
        if set(names) != set(sections["end"]):
            raise RecordError(f"{where}: 'start' and 'end' name different sections")
        sections = {k: [sections["start"][k], sections["end"][k]] for k in names}
    return {k: _section_bounds(k, v, where) for k, v in sections.items()}


def _sections_to_parts(n: int, sections: dict, where: str, session: str) -> np.ndarray:
    """Part name per row from ``{name: (start, end)}``; sections must lie inside the rows and not overlap."""
    part = np.full(n, "", dtype=object)
    for k, (s, e) in sorted(sections.items(), key=lambda kv: kv[1]):
        if not 0 <= s < e <= n:
            raise RecordError(f"{where}: section {k!r} = [{s}, {e}] lies outside the {n} samples of {session}")
        clash = sorted(set(part[s:e]) - {""})
        if clash:
            raise RecordError(f"{where}: section {k!r} = [{s}, {e}] overlaps section {clash[0]!r}")
        part[s:e] = k
    return part


def gyro_record_columns(gyr, gyro_unit: str, counts_per_dps, where: str, units_ok=("counts", "dps", "rad/s")) -> tuple:
    """The record's gyro columns from (n, 3) values in ``gyro_unit`` and the nominal scale kept (counts only)."""
    if gyro_unit not in units_ok:
        raise RecordError(f"gyro unit (--gyro-unit) must be one of {', '.join(units_ok)}, got {gyro_unit!r}")
    if gyro_unit == "counts":
        if counts_per_dps is None:
            raise RecordError(
                f"{where}: gyro values are raw counts: give the nominal scale (gyro_counts_per_dps / --gyro-scale, "
                "the datasheet's LSB per deg/s, e.g. 16.4 at ±2000 deg/s)"
            )
        return {f"gyro_{c}_counts": gyr[:, j] for j, c in enumerate(CHANNELS)}, counts_per_dps
    if counts_per_dps is not None:
        raise RecordError(
            f"{where}: a nominal scale (--gyro-scale) applies to raw counts, not to gyro unit {gyro_unit}"
        )
    f = 1.0 if gyro_unit == "dps" else 1.0 / units.DEG
    return {f"gyro_{c}_dps": gyr[:, j] * f for j, c in enumerate(CHANNELS)}, None


def import_imucal(
    session,
    *,
    rate_hz: float | None = None,
    sections=None,
    gyro_unit: str = "counts",
    gyro_counts_per_dps: float | None = None,
    angle_deg: float = 360.0,
    angle_std_deg: float = 0.0,
    latitude_deg: float | None = None,
    gravity_mps2: float | None = None,
    delimiter: str | None = None,
    name: str | None = None,
    instrument_id: str | None = None,
) -> Record:
    """An imucal Ferraris session as one ``imu-triad`` record.

    Args:
      session: CSV path (columns ``acc_x…gyr_z``, optionally ``part`` and ``samples``) or a pandas DataFrame.
      rate_hz: sample rate, Hz (imucal's files do not carry it; None: 204.8, NilsPod's, with a note).
      sections: a section list for sessions without a ``part`` column, as :func:`read_sections` reads it (dict or
        file).
      gyro_unit: ``"counts"`` (with ``gyro_counts_per_dps``, the nominal scale), ``"dps"`` or ``"rad/s"``.
      angle_deg: the known total angle of each hand rotation (deg; its sign comes from the data).
      angle_std_deg: 1σ error of that angle (deg), for the hand's imprecision.
      latitude_deg: site latitude (deg), or None when unknown.
      gravity_mps2: local gravity, m/s² (the accelerometer faces are ±g_site/g0 in g).
      delimiter: the file's delimiter (:func:`read_table`; None: detected).

    Returns: the record (not yet saved); accelerometer calibrated by :func:`ferraris_accelerometer` (in any unit);
    ``meta["import"]`` says what was read (sections, notes).
    """
    gravity_mps2 = site_gravity(latitude_deg) if gravity_mps2 is None else float(gravity_mps2)
    import pandas as pd

    notes: list[str] = []
    where = str(session) if not isinstance(session, pd.DataFrame) else "session"
    df = session if isinstance(session, pd.DataFrame) else read_table(session, delimiter, notes)
    acc_cols, gyr_cols = [f"acc_{c}" for c in CHANNELS], [f"gyr_{c}" for c in CHANNELS]
    miss = [c for c in acc_cols + gyr_cols if c not in df.columns]
    if miss:
        raise RecordError(f"{where}: missing columns {miss}; imucal sessions have acc_x…acc_z, gyr_x…gyr_z")
    if rate_hz is None:
        rate_hz = 204.8
        notes.append("sample rate 204.8 Hz assumed (imucal files do not carry it; --rate-hz to give it)")
    if not rate_hz or not rate_hz > 0:
        raise RecordError(f"{where}: the sample rate (rate_hz) must be positive, got {rate_hz!r}")
    for cols in (acc_cols, gyr_cols):  # in file order, so the row named is the file's
        numeric_columns(df, cols, where)
    if sections is not None:
        if "part" in df.columns:
            raise RecordError(f"{where}: has a 'part' column and a section list (--sections) was given; give one")
        spans = read_sections(sections)
        swhere = str(sections) if isinstance(sections, (str, Path)) else "sections"
        df = df.assign(part=_sections_to_parts(len(df), spans, swhere, where))  # imucal's iloc: rows in file order
        source = f"section list ({len(spans)} sections)"
    elif "part" in df.columns:
        source = "'part' column"
    else:
        raise RecordError(f"{where}: no 'part' column and no section list (--sections); cannot tell the poses apart")
    if "samples" in df.columns:
        df = df.sort_values("samples", kind="stable").reset_index(drop=True)
        samples = df["samples"].to_numpy(dtype=float)
        if np.any(np.diff(samples) <= 0):
            raise RecordError(f"{where}: column 'samples' repeats a sample index")
    else:
        samples = np.arange(len(df), dtype=float)
    part = df["part"].fillna("").astype(str).to_numpy(dtype=object)
    known = list(FERRARIS_FACES) + list(FERRARIS_ROTATIONS)
    unknown = sorted(set(part) - set(known) - {""})
    if unknown:
        raise RecordError(f"{where}: unknown section names {unknown}; imucal's are {known}")
    acc = df[acc_cols].to_numpy(dtype=float)
    gyr = df[gyr_cols].to_numpy(dtype=float)
    g_units = gravity_mps2 / units.G0
    means = {f: acc[part == f].mean(axis=0) for f in FERRARIS_FACES if np.any(part == f)}
    a_mat, b_vec = ferraris_accelerometer(means, g_units)
    acc_cal = np.linalg.solve(a_mat, (acc - b_vec).T).T
    labels = np.full(len(df), -1.0)
    segs = []
    for i, k in enumerate(known):
        sel = part == k
        if not sel.any():
            raise RecordError(f"{where}: section {k!r} is missing; a Ferraris session has {known}")
        labels[sel] = i
        if k in FERRARIS_FACES:
            segs.append({"label": i, "type": "static", "name": k})
        else:
            segs.append(
                {
                    "label": i,
                    "type": "rotation",
                    "name": k,
                    "axis": FERRARIS_ROTATIONS[k],
                    "angle_deg": float(angle_deg),
                    "angle_std_deg": float(angle_std_deg),
                    "direction": "from-data",
                }
            )
    cols = {"time_s": samples / float(rate_hz), "segment": labels}
    gcols, gyro_counts_per_dps = gyro_record_columns(gyr, gyro_unit, gyro_counts_per_dps, where)
    cols.update(gcols)
    for c, j in zip(CHANNELS, range(3)):
        cols[f"acc_{c}_g"] = acc_cal[:, j]
    face_err = [abs(np.linalg.norm(acc_cal[part == f].mean(axis=0)) / g_units - 1.0) for f in FERRARIS_FACES]
    report = {
        "source": where,
        "sections": source,
        "rests_found": len(FERRARIS_FACES),
        "rotations": len(FERRARIS_ROTATIONS),
        "dropped": [],
        "joined": [],
        "accelerometer": {
            "unit": "raw",
            "calibrated_here": True,
            "max_rest_magnitude_error": float(max(face_err)),
        },
        "notes": notes,
    }
    meta = triad_meta(
        name or (file_stem(where) if where != "session" else "imucal-session"),
        segs,
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        counts_per_dps=gyro_counts_per_dps,
        instrument_id=instrument_id,
        notes=f"imported from imucal session {where} at {rate_hz} Hz",
        extra={
            "accelerometer_calibration": {"model": "raw = A a + b, a in g", "A": a_mat.tolist(), "b": b_vec.tolist()},
            "import": report,
        },
    )
    return _checked_record(meta, cols)


def triad_from_arrays(
    t,
    acc,
    gyr,
    *,
    acc_unit: str = "g",
    gyro_unit: str = "dps",
    gyro_counts_per_dps: float | None = None,
    acc_g_per_count: float | None = None,
    acc_bias0=None,
    latitude_deg: float | None = None,
    gravity_mps2: float | None = None,
    min_rest_s: float = MIN_REST_S,
    static_threshold: float | None = None,
    name: str = "imu",
    instrument_id: str | None = None,
    source: str = "arrays",
    notes: list | None = None,
    acc_counts_per_g: float | None = None,
    clock: dict | None = None,
) -> Record:
    """A recording (times s, accelerometer (n, 3) or None, gyro (n, 3)) as an ``imu-triad`` record: rests detected
    (:func:`gyrojax.data.segments.detect_rests`, ``min_rest_s`` and ``static_threshold`` its options).

    At least 9 rests, an accelerometer, and moves between the rests: a calibration session, a gravity-to-gravity
    move between each pair of consecutive rests, the accelerometer in g as :func:`accelerometer_in_g` makes it.
    Fewer rests covering most of the log, or no accelerometer: a rest log (:mod:`gyrojax.data.restlog`), each rest a
    static segment (the accelerometer in counts then needs ``acc_counts_per_g``). Either way the gyro at rest is
    checked (:func:`gyrojax.data.door.check_rest_gyro`) and ``meta["import"]`` reports the clock (``clock``, from
    :func:`gyrojax.data.logs.log_clock`), the channels' ranges, the rests found, the candidates dropped and why,
    and the notes (``notes``: earlier ones to keep)."""
    gravity_mps2 = site_gravity(latitude_deg) if gravity_mps2 is None else float(gravity_mps2)
    from gyrojax.data import restlog
    from gyrojax.data.door import channel_ranges, check_rest_gyro
    from gyrojax.data.segments import detect_rests

    t = np.asarray(t, dtype=float)
    acc = None if acc is None else np.asarray(acc, dtype=float)
    gyr = np.asarray(gyr, dtype=float)
    rate_hz = (len(t) - 1) / (t[-1] - t[0])
    try:
        det = detect_rests(acc, rate_hz, gyro=gyr, threshold=static_threshold, min_rest_s=min_rest_s)
    except RecordError as e:  # the detector knows the samples, not the file: name it
        raise RecordError(f"{source}: {e}") from None
    iv = det.intervals
    gcols, gyro_counts_per_dps = gyro_record_columns(gyr, gyro_unit, gyro_counts_per_dps, source)
    dps = np.column_stack(list(gcols.values())) / (gyro_counts_per_dps or 1.0)
    door = {"clock": clock} if clock else {}
    door["ranges"] = channel_ranges({f"gyro_{c}": gyr[:, j] for j, c in enumerate(CHANNELS)})
    door["range_units"] = {f"gyro_{c}": gyro_unit for c in CHANNELS}
    if acc is not None:
        door["ranges"].update(channel_ranges({f"acc_{c}": acc[:, j] for j, c in enumerate(CHANNELS)}))
        door["range_units"].update({f"acc_{c}": acc_unit for c in CHANNELS})
    if iv:
        door["rest_gyro"] = check_rest_gyro(dps, iv, source, gyro_unit)
    notes = list(notes or [])
    meta_kw = dict(
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        counts_per_dps=gyro_counts_per_dps,
        instrument_id=instrument_id,
    )
    if restlog.is_rest_log(iv, len(t), acc):
        acc_g, rest_g, acc_notes = (None, None, [])
        if acc is not None:
            g_units = gravity_mps2 / units.G0
            acc_g, rest_g, acc_notes = restlog.rest_accelerometer(acc, iv, acc_unit, g_units, acc_counts_per_g, source)
            door["rest_gravity"] = rest_g
        labels, segs = restlog.rest_segments(iv, len(t))
        cols = {"time_s": t, "segment": labels, **gcols}
        if acc_g is not None:
            cols.update({f"acc_{c}_g": acc_g[:, j] for j, c in enumerate(CHANNELS)})
        covered = restlog.coverage(iv, len(t))
        what = f"a rest log: {len(iv)} rest(s) covering {covered:.1%} of {t[-1]:.6g} s"
        report = {"source": source, "kind": "rest log", **door, **det.to_json(), "notes": notes + acc_notes}
        notes = f"imported from {source}: {what} ({rate_hz:.6g} Hz)"
        return _checked_record(triad_meta(name, segs, notes=notes, extra={"import": report}, **meta_kw), cols)
    if acc is None or not iv:
        found = "no rest found" if not iv else f"its rests cover {restlog.coverage(iv, len(t)):.0%}"
        raise RecordError(
            f"{source}: {found} of a gyro-only log: a rest log must be still for most of its length; a gyro-only "
            f"session of turns needs its rotations of known angle (--rotations x:360,y:360,z:360) ({det.summary()})"
        )
    if len(iv) < 9:
        raise RecordError(
            f"{source}: found {len(iv)} static poses; the calibration needs at least 9 (a rest log would be one "
            f"orientation, its rests covering {restlog.REST_LOG_COVERAGE:.0%} of it: these cover "
            f"{restlog.coverage(iv, len(t)):.0%}) ({det.summary()})"
        )
    _hand_clock(t, iv, source)
    acc_cal, calib, acc_notes, acc_check = accelerometer_in_g(
        acc,
        iv,
        acc_unit,
        gravity_mps2 / units.G0,
        acc_g_per_count=acc_g_per_count,
        acc_bias0=acc_bias0,
        where=source,
    )
    notes += acc_notes
    labels = np.full(len(t), -1.0)
    segs = []
    for i, (s, e) in enumerate(iv):
        labels[s:e] = 2 * i
        segs.append({"label": 2 * i, "type": "static", "name": f"pose-{i}"})
        if i + 1 < len(iv):
            s2 = iv[i + 1][0]
            labels[e:s2] = 2 * i + 1
            segs.append(
                {"label": 2 * i + 1, "type": "move", "name": f"move-{i}-{i + 1}", "from": 2 * i, "to": 2 * i + 2}
            )
    cols = {"time_s": t, "segment": labels}
    cols.update(gcols)
    for j, c in enumerate(CHANNELS):
        cols[f"acc_{c}_g"] = acc_cal[:, j]
    extra = {"import": {"source": source, **door, **det.to_json(), "accelerometer": acc_check, "notes": notes}}
    if calib is not None:
        extra["accelerometer_calibration"] = calib
    notes = f"imported from {source} ({len(iv)} static poses, {rate_hz:.6g} Hz)"
    return _checked_record(triad_meta(name, segs, notes=notes, extra=extra, **meta_kw), cols)


def _checked_record(meta: dict, cols: dict) -> Record:
    """The record of an importer, its JSON and columns checked as :func:`gyrojax.data.records.load_record` would."""
    validate_triad_meta(meta, f"{meta['name']}.json")
    validate_triad_columns(meta, cols, f"{meta['name']}.csv")
    return Record(meta, {k: np.asarray(v, dtype=float) for k, v in cols.items()})


MAX_HAND_REST_S = 3600.0
"""Longest rest of a hand calibration session, s (poses are held for seconds to minutes)."""
MAX_HAND_MOVE_S = 60.0
"""Longest median move between two rests of a hand session, s (a hand turns the IMU in a few seconds)."""


def _hand_clock(t, intervals, source: str) -> None:
    """Refuse a hand session whose clock makes a rest last hours or its moves a minute each (the median move): a
    wrong time unit or rate, naming the flags."""
    rests = [t[e - 1] - t[s] for s, e in intervals]
    moves = [t[s2] - t[e - 1] for (_, e), (s2, _) in zip(intervals, intervals[1:])]
    said = [("its longest rest", max(rests), MAX_HAND_REST_S)]
    said += [("its median move", float(np.median(moves)), MAX_HAND_MOVE_S)] if moves else []
    for what, d, limit in said:
        if d > limit:
            raise RecordError(
                f"{source}: a hand session of {len(intervals)} rests whose clock makes {what} last {d:.6g} s "
                f"(a hand keeps it under {limit:g} s): is the clock right (--time-unit, --rate-hz)?"
            )


def gyro_only_record(t, gyr, rotations, *, gyro_unit="dps", gyro_counts_per_dps=None, name="imu", **kw) -> Record:
    """A gyro-only session (times s, gyro (n, 3) in ``gyro_unit``) and its ``rotations`` as an ``imu-triad`` record
    without accelerometer (:func:`gyrojax.data.gyroonly.gyro_only_segments`; :func:`triad_meta` the other keywords)."""
    seg_kw = {k: kw.pop(k) for k in ("min_rest_s", "static_threshold", "source", "notes") if k in kw}
    source = seg_kw.get("source", "")
    gcols, k = gyro_record_columns(np.asarray(gyr, dtype=float), gyro_unit, gyro_counts_per_dps, source)
    dps = np.stack(list(gcols.values()), axis=1) / (k or 1.0)
    labels, segs, report = gyro_only_segments(t, dps, rotations, **seg_kw)
    meta = triad_meta(name, segs, counts_per_dps=k, notes="a gyro-only session", extra={"import": report}, **kw)
    return _checked_record(meta, {"time_s": np.asarray(t, dtype=float), "segment": labels, **gcols})


CSV_KEYS = ("time", "time_s", "sample", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")
"""Keys of :func:`import_csv`'s column mapping: ``time`` (``time_s`` the same), ``sample`` (a sample counter), the
six sensor channels."""


def check_mapping(mapping: dict, time_unit: str | None) -> tuple[str | None, list]:
    """The column mapping of :func:`import_csv` checked (keys, the gyro's three, the accelerometer's three or none,
    one time key, a time unit — s, ms, us or ns — only with a time column): (the time column or None, the
    accelerometer keys)."""
    unknown = sorted(set(mapping) - set(CSV_KEYS))
    if unknown:
        raise RecordError(f"column mapping: unknown keys {unknown}; valid: {', '.join(CSV_KEYS)}")
    need = [k for k in CSV_KEYS[3:6] if k not in mapping]
    acc_keys = [k for k in CSV_KEYS[6:] if k in mapping]
    if need:
        raise RecordError(f"column mapping: {need} missing (map every gyro_<c> to a column, acc_<c> too if any)")
    if acc_keys and len(acc_keys) != 3:
        missing = [k for k in CSV_KEYS[6:] if k not in mapping]
        raise RecordError(f"column mapping: {missing} missing (map all three acc_<c>, or none for a gyro-only log)")
    if "time" in mapping and "time_s" in mapping:
        raise RecordError("column mapping: 'time' and 'time_s' are the same key; map one")
    time_col = mapping.get("time", mapping.get("time_s"))
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise RecordError(f"time unit (--time-unit) must be one of s, ms, us, ns, got {time_unit!r}")
    if time_unit is not None and time_col is None:
        raise RecordError("a time unit (--time-unit) was given but no time column is mapped (time=COL)")
    return time_col, acc_keys


def import_csv(
    path,
    mapping: dict,
    *,
    gyro_unit: str = "dps",
    acc_unit: str = "g",
    rate_hz: float | None = None,
    time_unit: str | None = None,
    delimiter: str | None = None,
    name: str | None = None,
    rotations=None,
    **kw,
) -> Record:
    """Any delimited log — a multi-position session, a rest log, or a gyro-only session — with a column mapping
    ``{"gyro_x": "gx", …, "acc_z": "az", "time": "t"}``: rests detected, as :func:`triad_from_arrays` (other keyword
    arguments go there). Without ``acc_<c>`` in the mapping and with ``rotations``, a gyro-only session of turns of
    known angle (:func:`gyro_only_record`); without either, a rest log.

    The clock (:func:`gyrojax.data.logs.log_clock`): ``time`` (or ``time_s``) a time column in ``time_unit`` (``s``,
    ``ms``, ``us``, ``ns``; default s, or ISO 8601 date-times when no unit is given), noted when it jitters; or
    ``sample`` a gap-free sample counter at ``rate_hz`` counts per second (used instead of a time column mapped beside
    it, whose jitter is then noted); or neither, samples at ``rate_hz``. A rate in the logger's preamble (``Fs,100``)
    serves where ``rate_hz`` would; every rate stated is checked against the others and refused when they
    contradict. ``delimiter``: ``,``, ``;``, ``tab`` or None (detected, and noted).
    """
    time_col, acc_keys = check_mapping(mapping, time_unit)
    gyro_only = not acc_keys
    if gyro_only and kw.get("acc_counts_per_g") is not None:
        raise RecordError("an accelerometer scale (--acc-scale) was given but no accelerometer is mapped (acc_<c>=COL)")
    if rotations is not None and not gyro_only:
        raise RecordError(
            "rotations (--rotations) describe a gyro-only session; this mapping has an accelerometer (acc_<c>), whose "
            "rests give the attitudes: drop --rotations, or the acc_<c> keys"
        )
    notes: list[str] = []
    df = read_table(path, delimiter, notes)
    miss = [v for v in mapping.values() if v not in df.columns]
    if miss:
        raise RecordError(f"{path}: columns {miss} (from the mapping) are not in the file; it has {list(df.columns)}")
    acc = numeric_columns(df, [mapping[f"acc_{c}"] for c in CHANNELS], str(path)) if acc_keys else None
    gyr = numeric_columns(df, [mapping[f"gyro_{c}"] for c in CHANNELS], str(path))
    t_col = None
    if time_col is not None:
        t_col, how = time_column(df, time_col, time_unit, str(path))
        if how:
            notes.append(how)
        if "sample" not in mapping:
            bad = np.flatnonzero(np.diff(t_col) <= 0)
            if bad.size:
                raise RecordError(
                    f"{path}: row {bad[0] + df.attrs['first_line'] + 1}, column {time_col!r}: time does not increase "
                    f"({float(t_col[bad[0] + 1])!r}); "
                    "a receive time? map the log's sample counter instead (sample=COL with --rate-hz)"
                )
        note = jitter_note(t_col, f"time column {time_col!r}")
        if note and "sample" in mapping:
            note = note.split("; the fit")[0] + f"; the sample counter {mapping['sample']!r} is used instead"
        if note:
            notes.append(note)
    counter = None
    if "sample" in mapping:
        col = mapping["sample"]
        counter = (numeric_columns(df, [col], str(path))[:, 0], col, df.attrs["first_line"])
    clock_kw = dict(rate_hz=rate_hz, preamble=df.attrs.get("preamble", ()), counter=counter)
    if counter is None and t_col is not None:
        clock_kw.update(times=t_col, time_source=f"the time column {time_col!r} ({time_unit or 's'})")
    t, clock = log_clock(len(df), str(path), **clock_kw)
    if gyro_only and rotations is not None:
        kw.pop("acc_counts_per_g", None)
        kw.update(name=name or file_stem(path), source=str(path), notes=notes)
        return gyro_only_record(t - t[0], gyr, rotations, gyro_unit=gyro_unit, **kw)
    return triad_from_arrays(
        t,
        acc,
        gyr,
        gyro_unit=gyro_unit,
        acc_unit=acc_unit,
        name=name or file_stem(path),
        source=str(path),
        notes=notes,
        clock=clock,
        **kw,
    )
