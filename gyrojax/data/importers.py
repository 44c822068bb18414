"""Importers: IMU calibration sessions in the formats people already have, into ``imu-triad`` records
(:mod:`gyrojax.data.triad`).

* :func:`import_imucal` — imucal's Ferraris sessions (mad-lab-fau/imucal): a table with columns
  ``acc_x, acc_y, acc_z, gyr_x, gyr_y, gyr_z`` and either a ``part`` column naming the sections (``x_p``, ``x_a``, …,
  ``x_rot``, …: imucal's annotated sessions) or imucal's section list (:func:`read_sections`).
* :func:`import_imutk` — imu_tk's ASCII files (one sample per line: time, then three values), accelerometer and
  gyroscope apart; rests by the variance detector of :mod:`gyrojax.data.segments`, the moves between them as
  gravity-to-gravity segments.
* :func:`import_csv` — any delimited log, with a column mapping; its clock a time column (s, ms, µs) or a sample
  counter with its rate.

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
    numeric_columns,
    read_table,
    time_column,
    time_from_counter,
)
from gyrojax.data.record import Record
from gyrojax.data.segments import MIN_REST_S
from gyrojax.data.triad import CHANNELS, TRIAD_KIND, validate_triad_columns, validate_triad_meta
from gyrojax.errors import RecordError

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
FORMAT = "gyrojax-record-1"


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


def triad_meta(
    name: str,
    segments: list,
    *,
    latitude_deg=None,
    gravity_mps2: float = 9.81,
    counts_per_dps=None,
    notes: str = "",
    instrument_id: str | None = None,
    extra: dict | None = None,
) -> dict:
    """The JSON of a triad record (:mod:`gyrojax.data.triad`)."""
    inst = {"kind": TRIAD_KIND, "channels": list(CHANNELS)}
    if instrument_id is not None:
        inst["id"] = instrument_id
    if counts_per_dps is not None:
        inst["gyro_counts_per_dps"] = float(counts_per_dps)
    meta = {
        "format": FORMAT,
        "name": name,
        "site": {"latitude_deg": latitude_deg, "gravity_mps2": float(gravity_mps2)},
        "instrument": inst,
        "earth_rate": True,
        "segments": segments,
        "notes": notes,
    }
    meta.update(extra or {})
    return meta


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


def _gyro_columns(gyr, gyro_unit: str, counts_per_dps, where: str, units_ok=("counts", "dps", "rad/s")) -> tuple:
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
    gravity_mps2: float = 9.81,
    delimiter: str | None = None,
    name: str | None = None,
    instrument_id: str | None = None,
) -> Record:
    """An imucal Ferraris session as one ``imu-triad`` record.

    Args:
      session: CSV path (columns ``acc_x…gyr_z``, optionally ``part`` and ``samples``) or a pandas DataFrame.
      rate_hz: sample rate, Hz (imucal's files do not carry it; None: 204.8, NilsPod's, with a note).
      sections: a section list for sessions without a ``part`` column, as :func:`read_sections` reads it (dict or
        file; imucal's ``{"x_p": {"start": 540, "end": 1271}, …}`` or ``{"x_p": [start, end], …}``; row positions
        in file order, end exclusive, as imucal's ``iloc``).
      gyro_unit: ``"counts"`` (with ``gyro_counts_per_dps``, the nominal scale), ``"dps"`` or ``"rad/s"``.
      angle_deg: the known total angle of each hand rotation (deg; its sign comes from the data).
      angle_std_deg: 1σ error of that angle (deg), for the hand's imprecision.
      latitude_deg: site latitude (deg), or None when unknown.
      gravity_mps2: local gravity, m/s² (the accelerometer faces are ±g_site/g0 in g).
      delimiter: the file's delimiter (:func:`read_table`; None: detected).

    Returns: the record (not yet saved); accelerometer calibrated by :func:`ferraris_accelerometer` (in any unit);
    ``meta["import"]`` says what was read (sections, notes).
    """
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
    gcols, gyro_counts_per_dps = _gyro_columns(gyr, gyro_unit, gyro_counts_per_dps, where)
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
    validate_triad_meta(meta, f"{meta['name']}.json")
    validate_triad_columns(meta, cols, f"{meta['name']}.csv")
    return Record(meta, {k: np.asarray(v, dtype=float) for k, v in cols.items()})


def read_imutk_ascii(path) -> np.ndarray:
    """imu_tk's ASCII format: one sample per line, ``time x y z`` (time in s, values in raw units) separated by
    blanks (its ``.mat`` text files; gzip-compressed files are read too). Returns (n, 4) floats; :class:`RecordError`
    naming the line otherwise."""
    p = Path(path)
    try:
        data = np.loadtxt(p, ndmin=2)
    except (OSError, ValueError) as e:
        raise RecordError(f"{p}: not an imu_tk ASCII file (time x y z per line): {e}") from None
    if data.shape[1] != 4 or len(data) < 2:
        raise RecordError(f"{p}: expected 4 columns (time x y z) and at least 2 lines, got shape {data.shape}")
    bad = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if bad.size:
        raise RecordError(f"{p}: line {bad[0] + 2}: time does not increase ({data[bad[0] + 1, 0]!r})")
    return data


def import_imutk(
    acc_path,
    gyro_path,
    *,
    acc_unit: str = "counts",
    gyro_unit: str = "counts",
    gyro_counts_per_dps: float | None = None,
    acc_g_per_count: float | None = None,
    acc_bias0=None,
    latitude_deg: float | None = None,
    gravity_mps2: float = 9.81,
    min_rest_s: float = MIN_REST_S,
    static_threshold: float | None = None,
    name: str | None = None,
    instrument_id: str | None = None,
) -> Record:
    """An imu_tk multi-position recording (accelerometer and gyroscope files) as one ``imu-triad`` record.

    Static poses come from :func:`gyrojax.data.segments.detect_rests` (accelerometer and gyro variance against the
    rests' own noise; ``min_rest_s`` the shortest rest, ``static_threshold`` the threshold in multiples of the
    noise variance); each pair of consecutive poses gets a ``move`` segment (the samples between them: a
    gravity-to-gravity move, its rotation known through the accelerometer directions before and after). The
    accelerometer (``acc_unit``, imu_tk's raw counts by default) is checked and calibrated as
    :func:`accelerometer_in_g` says, started from ``acc_g_per_count`` and ``acc_bias0`` when given.

    Args: gyro_unit ``"counts"`` (with ``gyro_counts_per_dps``), ``"dps"`` or ``"rad/s"``; latitude_deg (None:
    unknown); gravity_mps2 (local gravity, m/s²).
    """
    acc = read_imutk_ascii(acc_path)
    gyr = read_imutk_ascii(gyro_path)
    if len(acc) != len(gyr) or not np.allclose(acc[:, 0], gyr[:, 0], atol=1e-6):
        raise RecordError(f"{gyro_path}: its timestamps differ from {acc_path}'s; resample one onto the other first")
    notes = []
    note = jitter_note(acc[:, 0], f"{acc_path}: time")
    if note:
        notes.append(note)
    return triad_from_arrays(
        acc[:, 0] - acc[0, 0],
        acc[:, 1:],
        gyr[:, 1:],
        acc_unit=acc_unit,
        gyro_unit=gyro_unit,
        gyro_counts_per_dps=gyro_counts_per_dps,
        acc_g_per_count=acc_g_per_count,
        acc_bias0=acc_bias0,
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        min_rest_s=min_rest_s,
        static_threshold=static_threshold,
        name=name or Path(acc_path).name.split(".")[0],
        instrument_id=instrument_id,
        source=f"imu_tk files {acc_path}, {gyro_path}",
        notes=notes,
    )


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
    gravity_mps2: float = 9.81,
    min_rest_s: float = MIN_REST_S,
    static_threshold: float | None = None,
    name: str = "imu",
    instrument_id: str | None = None,
    source: str = "arrays",
    notes: list | None = None,
) -> Record:
    """A multi-position recording (times s, accelerometer (n, 3), gyro (n, 3)) as an ``imu-triad`` record: rests
    detected (:func:`gyrojax.data.segments.detect_rests`, ``min_rest_s`` and ``static_threshold`` its options), a
    gravity-to-gravity move between each pair of consecutive rests; the accelerometer in g as
    :func:`accelerometer_in_g` makes it. ``meta["import"]`` reports the rests found, the candidates dropped and why,
    and the notes (``notes``: earlier ones to keep)."""
    from gyrojax.data.segments import detect_rests

    t = np.asarray(t, dtype=float)
    acc = np.asarray(acc, dtype=float)
    gyr = np.asarray(gyr, dtype=float)
    rate_hz = (len(t) - 1) / (t[-1] - t[0])
    try:
        det = detect_rests(acc, rate_hz, gyro=gyr, threshold=static_threshold, min_rest_s=min_rest_s)
    except RecordError as e:  # the detector knows the samples, not the file: name it
        raise RecordError(f"{source}: {e}") from None
    iv = det.intervals
    if len(iv) < 9:
        raise RecordError(f"{source}: found {len(iv)} static poses; the calibration needs at least 9 ({det.summary()})")
    notes = list(notes or [])
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
    gcols, gyro_counts_per_dps = _gyro_columns(gyr, gyro_unit, gyro_counts_per_dps, source)
    cols.update(gcols)
    for j, c in enumerate(CHANNELS):
        cols[f"acc_{c}_g"] = acc_cal[:, j]
    extra = {"import": {"source": source, **det.to_json(), "accelerometer": acc_check, "notes": notes}}
    if calib is not None:
        extra["accelerometer_calibration"] = calib
    meta = triad_meta(
        name,
        segs,
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        counts_per_dps=gyro_counts_per_dps,
        instrument_id=instrument_id,
        notes=f"imported from {source} ({len(iv)} static poses, {rate_hz:.6g} Hz)",
        extra=extra,
    )
    validate_triad_meta(meta, f"{meta['name']}.json")
    validate_triad_columns(meta, cols, f"{meta['name']}.csv")
    return Record(meta, {k: np.asarray(v, dtype=float) for k, v in cols.items()})


def gyro_only_record(t, gyr, rotations, *, gyro_unit="dps", gyro_counts_per_dps=None, name="imu", **kw) -> Record:
    """A gyro-only session (times s, gyro (n, 3) in ``gyro_unit``) and its ``rotations`` as an ``imu-triad`` record
    without accelerometer (:func:`gyrojax.data.gyroonly.gyro_only_segments`; :func:`triad_meta` the other keywords)."""
    seg_kw = {k: kw.pop(k) for k in ("min_rest_s", "static_threshold", "source", "notes") if k in kw}
    gcols, k = _gyro_columns(np.asarray(gyr, dtype=float), gyro_unit, gyro_counts_per_dps, seg_kw.get("source", ""))
    dps = np.stack(list(gcols.values()), axis=1) / (k or 1.0)
    labels, segs, report = gyro_only_segments(t, dps, rotations, **seg_kw)
    meta = triad_meta(name, segs, counts_per_dps=k, notes="a gyro-only session", extra={"import": report}, **kw)
    cols = {"time_s": np.asarray(t, dtype=float), "segment": labels, **gcols}
    validate_triad_meta(meta, f"{name}.json")
    validate_triad_columns(meta, cols, f"{name}.csv")
    return Record(meta, cols)


CSV_KEYS = ("time", "time_s", "sample", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")
"""Keys of :func:`import_csv`'s column mapping: ``time`` (``time_s`` the same), ``sample`` (a sample counter), the
six sensor channels."""


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
    """Any delimited log of a multi-position recording, with a column mapping ``{"gyro_x": "gx", …, "acc_z": "az",
    "time": "t"}``: rests detected and moves between them, as :func:`triad_from_arrays` (other keyword arguments go
    there). Without ``acc_<c>`` in the mapping, a gyro-only session with its ``rotations`` (:func:`gyro_only_record`).

    The clock: ``time`` (or ``time_s``) a time column in ``time_unit`` (``s``, ``ms``, ``us``, ``ns``; default s, or
    ISO 8601 date-times when no unit is given), noted when
    it jitters; or ``sample`` a gap-free sample counter at ``rate_hz`` counts per second (used instead of a time
    column mapped beside it, whose jitter is then noted); or neither, samples at ``rate_hz``. ``delimiter``: ``,``,
    ``;``, ``tab`` or None (detected, and noted).
    """
    unknown = sorted(set(mapping) - set(CSV_KEYS))
    if unknown:
        raise RecordError(f"column mapping: unknown keys {unknown}; valid: {', '.join(CSV_KEYS)}")
    gyro_only = not any(k.startswith("acc_") for k in mapping)
    need = [k for k in CSV_KEYS[3:] if k not in mapping and not (gyro_only and k.startswith("acc_"))]
    if need:
        raise RecordError(f"column mapping: {need} missing (map every gyro_<c> and acc_<c> to a column)")
    if gyro_only and rotations is None:
        raise RecordError(
            "column mapping: no accelerometer (acc_<c>): a gyro-only session needs its rotations of known angle "
            "(--rotations x:360,y:360,z:360 or a file)"
        )
    if "time" in mapping and "time_s" in mapping:
        raise RecordError("column mapping: 'time' and 'time_s' are the same key; map one")
    time_col = mapping.get("time", mapping.get("time_s"))
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise RecordError(f"time unit (--time-unit) must be one of s, ms, us, ns, got {time_unit!r}")
    if time_unit is not None and time_col is None:
        raise RecordError("a time unit (--time-unit) was given but no time column is mapped (time=COL)")
    if time_col is not None and "sample" not in mapping and rate_hz is not None:
        raise RecordError(
            f"{path}: a time column and a rate (--rate-hz) were both given; the rate goes with a sample counter "
            "(sample=COL) or with no clock column"
        )
    notes: list[str] = []
    df = read_table(path, delimiter, notes)
    miss = [v for v in mapping.values() if v not in df.columns]
    if miss:
        raise RecordError(f"{path}: columns {miss} (from the mapping) are not in the file; it has {list(df.columns)}")
    acc = None if gyro_only else numeric_columns(df, [mapping[f"acc_{c}"] for c in CHANNELS], str(path))
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
    if "sample" in mapping:
        col = mapping["sample"]
        counter = numeric_columns(df, [col], str(path))[:, 0]
        t = time_from_counter(counter, rate_hz, f"{path}, column {col!r}", df.attrs["first_line"])
    elif t_col is not None:
        t = t_col
    elif rate_hz:
        t = np.arange(len(df)) / float(rate_hz)
    else:
        raise RecordError(f"{path}: map a time column (time=COL), a sample counter (sample=COL) or give --rate-hz")
    if gyro_only:
        kw.update(name=name or file_stem(path), source=str(path), notes=notes)
        return gyro_only_record(t - t[0], gyr, rotations, gyro_unit=gyro_unit, **kw)
    return triad_from_arrays(
        t - t[0],
        acc,
        gyr,
        gyro_unit=gyro_unit,
        acc_unit=acc_unit,
        name=name or file_stem(path),
        source=str(path),
        notes=notes,
        **kw,
    )
