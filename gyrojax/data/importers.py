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
from gyrojax.data.records import Record
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
    df = session if isinstance(session, pd.DataFrame) else pd.read_csv(session)
    acc_cols, gyr_cols = [f"acc_{c}" for c in CHANNELS], [f"gyr_{c}" for c in CHANNELS]
    miss = [c for c in acc_cols + gyr_cols if c not in df.columns]
    if miss:
        raise RecordError(f"{where}: missing columns {miss}; imucal sessions have acc_x…acc_z, gyr_x…gyr_z")
    if not rate_hz or not rate_hz > 0:
        raise RecordError(f"{where}: the sample rate (rate_hz) must be positive, got {rate_hz!r}")
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
    for arr, cols in ((acc, acc_cols), (gyr, gyr_cols)):
        bad = ~np.isfinite(arr)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise RecordError(f"{where}: row {i + 2}, column {cols[j]!r} is not a finite number")
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
