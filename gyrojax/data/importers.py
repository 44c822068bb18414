"""Importers: IMU calibration sessions in the formats people already have, into ``imu-triad`` records
(:mod:`gyrojax.data.triad`).

* :func:`import_imucal` — imucal's Ferraris sessions (mad-lab-fau/imucal): a table with columns
  ``acc_x, acc_y, acc_z, gyr_x, gyr_y, gyr_z`` and either a ``part`` column naming the sections (``x_p``, ``x_a``, …,
  ``x_rot``, …: imucal's annotated sessions) or a separate section list of sample ranges.
* :func:`import_imutk` — imu_tk's ASCII files (one sample per line: time, then three values), accelerometer and
  gyroscope apart; static poses by the variance detector of :mod:`gyrojax.data.segments`, the moves between them
  as gravity-to-gravity segments.
* :func:`import_csv` — any CSV, with a column mapping.

The accelerometer is calibrated by the importer (Ferraris' six faces: raw = A a + b by least squares; imu_tk:
an ellipsoid fit over the static poses) and written in g, so that the gyro fit sees the specific force of each pose;
the calibration is kept in the record's JSON under ``accelerometer_calibration``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gyrojax import units
from gyrojax.data.record import Record
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


def read_table(path):
    """A CSV file as a pandas DataFrame; :class:`RecordError` naming the file when it is not a readable CSV."""
    import pandas as pd

    try:
        return pd.read_csv(path)
    except (UnicodeDecodeError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
        raise RecordError(f"{path}: not a readable comma-separated table ({str(e).strip()[:120]})") from None


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


def _sections_from_list(n: int, sections: dict, where: str) -> np.ndarray:
    """Part name per row from ``{"x_p": [start, end], …}`` (sample indices, end exclusive)."""
    part = np.full(n, "", dtype=object)
    for k, v in sections.items():
        if not (isinstance(v, (list, tuple)) and len(v) == 2 and all(isinstance(i, int) for i in v)):
            raise RecordError(f"{where}: section {k!r} must be [start, end] sample indices, got {v!r}")
        s, e = v
        if not 0 <= s < e <= n:
            raise RecordError(f"{where}: section {k!r} = [{s}, {e}] lies outside the {n} samples")
        part[s:e] = k
    return part


def import_imucal(
    session,
    *,
    rate_hz: float,
    sections=None,
    gyro_unit: str = "counts",
    gyro_counts_per_dps: float | None = None,
    angle_deg: float = 360.0,
    angle_std_deg: float = 0.0,
    latitude_deg: float | None = None,
    gravity_mps2: float = 9.81,
    name: str | None = None,
    instrument_id: str | None = None,
) -> Record:
    """An imucal Ferraris session as one ``imu-triad`` record.

    Args:
      session: CSV path (columns ``acc_x…gyr_z``, optionally ``part`` and ``samples``) or a pandas DataFrame.
      rate_hz: sample rate, Hz (imucal's files do not carry it).
      sections: ``{"x_p": [start, end], …}`` (dict, or a JSON file path) for sessions without a ``part`` column.
      gyro_unit: ``"counts"`` (with ``gyro_counts_per_dps``, the nominal scale) or ``"dps"``.
      angle_deg: the known total angle of each hand rotation (deg; its sign comes from the data).
      angle_std_deg: 1σ error of that angle (deg), for the hand's imprecision.
      latitude_deg: site latitude (deg), or None when unknown.
      gravity_mps2: local gravity, m/s² (the accelerometer faces are ±g_site/g0 in g).

    Returns: the record (not yet saved); accelerometer calibrated by :func:`ferraris_accelerometer`.
    """
    import pandas as pd

    where = str(session) if not isinstance(session, pd.DataFrame) else "session"
    df = session if isinstance(session, pd.DataFrame) else read_table(session)
    acc_cols, gyr_cols = [f"acc_{c}" for c in CHANNELS], [f"gyr_{c}" for c in CHANNELS]
    miss = [c for c in acc_cols + gyr_cols if c not in df.columns]
    if miss:
        raise RecordError(f"{where}: missing columns {miss}; imucal sessions have acc_x…acc_z, gyr_x…gyr_z")
    if not rate_hz or not rate_hz > 0:
        raise RecordError(f"{where}: the sample rate (rate_hz) must be positive, got {rate_hz!r}")
    for cols in (acc_cols, gyr_cols):  # in file order, so the row named is the file's
        arr = df[cols].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(arr)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise RecordError(f"{where}: row {i + 2}, column {cols[j]!r} is not a finite number")
    if "samples" in df.columns:
        df = df.sort_values("samples", kind="stable").reset_index(drop=True)
        samples = df["samples"].to_numpy(dtype=float)
        if np.any(np.diff(samples) <= 0):
            raise RecordError(f"{where}: column 'samples' repeats a sample index")
    else:
        samples = np.arange(len(df), dtype=float)
    if sections is not None:
        if isinstance(sections, (str, Path)):
            sections = json.loads(Path(sections).read_text(encoding="utf-8"))
        part = _sections_from_list(len(df), sections, where)
    elif "part" in df.columns:
        part = df["part"].fillna("").astype(str).to_numpy(dtype=object)
    else:
        raise RecordError(f"{where}: no 'part' column and no section list (--sections); cannot tell the poses apart")
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
    if gyro_unit == "counts":
        if gyro_counts_per_dps is None:
            raise RecordError(
                f"{where}: gyro values are raw counts: give the nominal scale (gyro_counts_per_dps / --gyro-scale, "
                "the datasheet's LSB per deg/s, e.g. 16.4 at ±2000 deg/s)"
            )
        for c, j in zip(CHANNELS, range(3)):
            cols[f"gyro_{c}_counts"] = gyr[:, j]
    elif gyro_unit == "dps":
        for c, j in zip(CHANNELS, range(3)):
            cols[f"gyro_{c}_dps"] = gyr[:, j]
        gyro_counts_per_dps = None
    else:
        raise RecordError(f"gyro_unit must be 'counts' or 'dps', got {gyro_unit!r}")
    for c, j in zip(CHANNELS, range(3)):
        cols[f"acc_{c}_g"] = acc_cal[:, j]
    meta = triad_meta(
        name or (Path(where).stem if where != "session" else "imucal-session"),
        segs,
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        counts_per_dps=gyro_counts_per_dps,
        instrument_id=instrument_id,
        notes=f"imported from imucal session {where} at {rate_hz} Hz",
        extra={
            "accelerometer_calibration": {"model": "raw = A a + b, a in g", "A": a_mat.tolist(), "b": b_vec.tolist()}
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
    gyro_unit: str = "counts",
    gyro_counts_per_dps: float | None = None,
    acc_g_per_count: float | None = None,
    acc_bias0=None,
    latitude_deg: float | None = None,
    gravity_mps2: float = 9.81,
    init_s: float = 50.0,
    detector_k: float = 6.0,
    name: str | None = None,
    instrument_id: str | None = None,
) -> Record:
    """An imu_tk multi-position recording (accelerometer and gyroscope files) as one ``imu-triad`` record.

    Static poses come from :func:`gyrojax.data.segments.static_intervals` (accelerometer and gyro variance against
    the first ``init_s`` seconds of rest); each pair of consecutive poses gets a ``move`` segment (the samples
    between them: a gravity-to-gravity move, its rotation known through the accelerometer directions before and
    after). The accelerometer is calibrated by imu_tk's 9-parameter model fitted to |a| = g over the poses
    (:func:`gyrojax.data.segments.ellipsoid_accelerometer`), started from ``acc_g_per_count`` and ``acc_bias0``
    (default: the 16-bit mid-scale 32768 and |mean of the initial rest| = 1 g).

    Args: gyro_unit ``"counts"`` (with ``gyro_counts_per_dps``), ``"dps"`` or ``"rad/s"``; latitude_deg (None:
    unknown); gravity_mps2 (local gravity, m/s²).
    """
    acc = read_imutk_ascii(acc_path)
    gyr = read_imutk_ascii(gyro_path)
    if len(acc) != len(gyr) or not np.allclose(acc[:, 0], gyr[:, 0], atol=1e-6):
        raise RecordError(f"{gyro_path}: its timestamps differ from {acc_path}'s; resample one onto the other first")
    return triad_from_arrays(
        acc[:, 0] - acc[0, 0],
        acc[:, 1:],
        gyr[:, 1:],
        acc_unit="counts",
        gyro_unit=gyro_unit,
        gyro_counts_per_dps=gyro_counts_per_dps,
        acc_g_per_count=acc_g_per_count,
        acc_bias0=acc_bias0,
        latitude_deg=latitude_deg,
        gravity_mps2=gravity_mps2,
        init_s=init_s,
        detector_k=detector_k,
        name=name or Path(acc_path).name.split(".")[0],
        instrument_id=instrument_id,
        source=f"imu_tk files {acc_path}, {gyro_path}",
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
    init_s: float = 50.0,
    detector_k: float = 6.0,
    name: str = "imu",
    instrument_id: str | None = None,
    source: str = "arrays",
) -> Record:
    """A multi-position recording (times s, accelerometer (n, 3), gyro (n, 3)) as an ``imu-triad`` record: static
    poses detected, a gravity-to-gravity move between each pair of consecutive poses; an accelerometer in counts is
    calibrated by imu_tk's 9-parameter ellipsoid model (see :func:`import_imutk`)."""
    from gyrojax.data.segments import ellipsoid_accelerometer, imutk_acc_model, static_intervals

    t = np.asarray(t, dtype=float)
    acc = np.asarray(acc, dtype=float)
    gyr = np.asarray(gyr, dtype=float)
    rate_hz = (len(t) - 1) / (t[-1] - t[0])
    iv = static_intervals(acc, rate_hz, gyro=gyr, init_s=init_s, k=detector_k)
    if len(iv) < 9:
        raise RecordError(f"{source}: found {len(iv)} static poses; the calibration needs at least 9")
    g_units = gravity_mps2 / units.G0
    extra = {}
    if acc_unit == "counts":
        means = np.array([acc[s:e].mean(axis=0) for s, e in iv])
        bias0 = np.full(3, 32768.0) if acc_bias0 is None else np.asarray(acc_bias0, dtype=float)
        scale0 = acc_g_per_count or g_units / float(np.linalg.norm(means[0] - bias0))
        params = ellipsoid_accelerometer(means, g_units, scale0, bias0)
        acc_cal = imutk_acc_model(params, acc)
        extra["accelerometer_calibration"] = {
            "model": "imu_tk: a = T K (raw - b) in g; params alpha_yz, alpha_zy, alpha_zx, s_x..s_z, b_x..b_z",
            "params": params.tolist(),
        }
    elif acc_unit in ("g", "m/s^2"):
        acc_cal = acc if acc_unit == "g" else acc / units.G0
    else:
        raise RecordError(f"acc_unit must be 'g', 'm/s^2' or 'counts', got {acc_unit!r}")
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
    if gyro_unit == "counts":
        if gyro_counts_per_dps is None:
            raise RecordError(f"{source}: gyro values are raw counts: give the nominal scale (counts per deg/s)")
        for j, c in enumerate(CHANNELS):
            cols[f"gyro_{c}_counts"] = gyr[:, j]
    elif gyro_unit in ("dps", "rad/s"):
        f = 1.0 if gyro_unit == "dps" else 1.0 / units.DEG
        for j, c in enumerate(CHANNELS):
            cols[f"gyro_{c}_dps"] = gyr[:, j] * f
        gyro_counts_per_dps = None
    else:
        raise RecordError(f"gyro_unit must be 'counts', 'dps' or 'rad/s', got {gyro_unit!r}")
    for j, c in enumerate(CHANNELS):
        cols[f"acc_{c}_g"] = acc_cal[:, j]
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


CSV_KEYS = ("time_s", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")


def import_csv(
    path,
    mapping: dict,
    *,
    gyro_unit: str = "dps",
    acc_unit: str = "g",
    rate_hz: float | None = None,
    name: str | None = None,
    **kw,
) -> Record:
    """Any CSV of a multi-position recording, with a column mapping ``{"gyro_x": "gx", …, "acc_z": "az",
    "time_s": "t"}`` (``time_s`` may be omitted when ``rate_hz`` is given): static poses detected and moves between
    them, as :func:`triad_from_arrays` (other keyword arguments go there)."""

    unknown = sorted(set(mapping) - set(CSV_KEYS))
    if unknown:
        raise RecordError(f"column mapping: unknown keys {unknown}; valid: {', '.join(CSV_KEYS)}")
    need = [k for k in CSV_KEYS[1:] if k not in mapping]
    if need:
        raise RecordError(f"column mapping: {need} missing (map every gyro_<c> and acc_<c> to a column)")
    df = read_table(path)
    miss = [v for v in mapping.values() if v not in df.columns]
    if miss:
        raise RecordError(f"{path}: columns {miss} (from the mapping) are not in the file; it has {list(df.columns)}")
    if "time_s" in mapping:
        t = df[mapping["time_s"]].to_numpy(dtype=float)
    elif rate_hz:
        t = np.arange(len(df)) / float(rate_hz)
    else:
        raise RecordError(f"{path}: map a time column (time_s=COL) or give the sample rate (--rate-hz)")
    acc = df[[mapping[f"acc_{c}"] for c in CHANNELS]].to_numpy(dtype=float)
    gyr = df[[mapping[f"gyro_{c}"] for c in CHANNELS]].to_numpy(dtype=float)
    for arr, what in ((t[:, None], "time"), (acc, "acc"), (gyr, "gyro")):
        bad = ~np.isfinite(arr)
        if bad.any():
            raise RecordError(f"{path}: row {int(np.argwhere(bad)[0][0]) + 2}: a {what} value is not a finite number")
    return triad_from_arrays(
        t - t[0],
        acc,
        gyr,
        gyro_unit=gyro_unit,
        acc_unit=acc_unit,
        name=name or Path(path).stem,
        source=str(path),
        **kw,
    )
