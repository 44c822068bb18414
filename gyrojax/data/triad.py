"""Triad records: one MEMS IMU (three gyro channels x, y, z, optionally three accelerometers) moved by hand, with
no turntable and no angle log (the ``imu-triad`` extension of conventions §5, described in docs/conventions.md).

A triad record is ``NAME.csv`` + ``NAME.json`` like any record. Its JSON has no ``table``; instead a list of
``segments`` says what each labelled stretch of samples is:

* ``{"label": 0, "type": "static", "name": "x_p"}`` — the IMU rests; its orientation comes from the accelerometer
  (columns ``acc_<c>_g``) or, without one, from ``"up": [ux, uy, uz]`` (the body-frame direction of Up); the
  heading is unknown (``heading`` nuisance, see :mod:`gyrojax.inference.triad`). A rest of a record without
  accelerometer and without ``up`` has an unknown orientation: its Earth rate is a nuisance of unknown direction,
  and the g-sensitivities cannot be fitted from it (a gyro-only session, :mod:`gyrojax.data.gyroonly`).
* ``{"label": 6, "type": "rotation", "axis": "x", "angle_deg": 360, "angle_std_deg": 0.0}`` — a rotation of a
  known total angle about a body axis (``"x"``, ``"-y"``, or a unit vector), angle history unknown; its sign is taken
  from the data (``"direction": "from-data"``, the default) or given (``"positive"``/``"negative"``); an
  optional ``"angle_cov_deg2"`` (3×3, deg², body axes) is the uncertainty of the angle vector beyond the angle
  along the axis (:mod:`gyrojax.data.gyroonly`: where a hand's pause was cut).
* ``{"label": 9, "type": "move", "from": 3, "to": 4}`` — a gravity-to-gravity move between two static segments
  (imu_tk): the rotation is known only through the accelerometer directions before and after.

Columns: ``time_s`` and ``segment`` (integer labels; samples whose label is not listed, or −1, are transitions and
are ignored), gyro rates ``gyro_<c>_dps`` — or raw ``gyro_<c>_counts`` with ``instrument.gyro_counts_per_dps``, the
nominal scale —, optional ``acc_<c>_g`` (calibrated, in g0 = 9.80665 m/s²) and ``temperature_C``.
``site.latitude_deg`` may be ``null`` (unknown); ``earth_rate`` (default true) switches the Earth rate off.
"""

from __future__ import annotations

import numpy as np

from gyrojax import units
from gyrojax.data.record import FORMAT
from gyrojax.errors import RecordError
from gyrojax.kinds import TRIAD_KIND
from gyrojax.physics.gravity import site_gravity
from gyrojax.protocol import is_finite_number

CHANNELS = ("x", "y", "z")
SEGMENT_TYPES = ("static", "rotation", "move")
DIRECTIONS = ("from-data", "positive", "negative")


def _err(file, msg):
    return RecordError(f"{file}: {msg}")


def axis_vector(spec, where: str = "axis") -> np.ndarray:
    """A body axis from ``"x"``, ``"-y"``, ``"+z"`` or a 3-vector (normalised); :class:`RecordError` otherwise."""
    if isinstance(spec, str):
        s = spec.strip().lower()
        sign = -1.0 if s.startswith("-") else 1.0
        s = s.lstrip("+-")
        if s in CHANNELS:
            v = np.zeros(3)
            v[CHANNELS.index(s)] = sign
            return v
    elif isinstance(spec, (list, tuple)) and len(spec) == 3 and all(is_finite_number(x) for x in spec):
        v = np.asarray(spec, dtype=float)
        n = float(np.linalg.norm(v))
        if n > 0:
            return v / n
    raise RecordError(f"{where} is {spec!r}; give 'x', 'y', 'z' (optionally signed, '-x') or a non-zero 3-vector")


def angle_covariance(v, where: str = "angle_cov_deg2") -> np.ndarray:
    """A rotation's angle covariance (3, 3) in deg² (deg, body axes): symmetric, finite, positive semi-definite."""
    ok = isinstance(v, (list, tuple)) and len(v) == 3
    ok = ok and all(isinstance(r, (list, tuple)) and len(r) == 3 and all(is_finite_number(x) for x in r) for r in v)
    if ok:
        c = np.asarray(v, dtype=float)
        if np.allclose(c, c.T, rtol=1e-9, atol=1e-12) and np.linalg.eigvalsh(c).min() >= -1e-9 * max(c.max(), 1e-300):
            return c
    raise RecordError(f"{where} must be a symmetric positive semi-definite 3×3 matrix of deg², got {v!r}")


def validate_triad_meta(meta: dict, file="record.json") -> dict:
    """Check a triad record's JSON (module doc); returns it unchanged. Errors name the key."""
    site = meta.get("site")
    if not isinstance(site, dict):
        raise _err(file, "missing required key 'site' (latitude_deg, may be null, and gravity_mps2)")
    if "latitude_deg" not in site:
        raise _err(file, "missing required key 'site.latitude_deg' (a number, or null when the site is unknown)")
    lat = site["latitude_deg"]
    if lat is not None and (not is_finite_number(lat) or not -90 <= float(lat) <= 90):
        raise _err(file, f"key 'site.latitude_deg' must be null or lie in [-90, 90], got {lat!r}")
    g = site.get("gravity_mps2")
    if not is_finite_number(g) or not 9.7 <= float(g) <= 9.9:
        raise _err(file, f"key 'site.gravity_mps2' must be a gravity on the Earth's surface (9.7–9.9 m/s²), got {g!r}")
    inst = meta["instrument"]
    scale = inst.get("gyro_counts_per_dps")
    if scale is not None and (not is_finite_number(scale) or float(scale) == 0.0):
        raise _err(file, f"key 'instrument.gyro_counts_per_dps' must be a non-zero number, got {scale!r}")
    if not isinstance(meta.get("earth_rate", True), bool):
        raise _err(file, f"key 'earth_rate' must be true or false, got {meta.get('earth_rate')!r}")
    segs = meta.get("segments")
    if not isinstance(segs, list) or not segs:
        raise _err(file, "missing required key 'segments': a list of {label, type: static|rotation|move, …}")
    labels = set()
    for i, s in enumerate(segs):
        where = f"segments[{i}]"
        if not isinstance(s, dict):
            raise _err(file, f"key {where!r} must be an object")
        lab = s.get("label")
        if not isinstance(lab, int) or isinstance(lab, bool) or lab < 0:
            raise _err(file, f"key '{where}.label' must be a non-negative integer, got {lab!r}")
        if lab in labels:
            raise _err(file, f"key '{where}.label': label {lab} is described twice")
        labels.add(lab)
        typ = s.get("type")
        if typ not in SEGMENT_TYPES:
            raise _err(file, f"key '{where}.type' is {typ!r}; valid: {', '.join(SEGMENT_TYPES)}")
        try:
            if typ == "rotation":
                axis_vector(s.get("axis"), f"key '{where}.axis'")
                ang = s.get("angle_deg")
                if not is_finite_number(ang) or float(ang) <= 0:
                    raise _err(file, f"key '{where}.angle_deg' must be a positive number (deg), got {ang!r}")
                sd = s.get("angle_std_deg", 0.0)
                if not is_finite_number(sd) or float(sd) < 0:
                    raise _err(file, f"key '{where}.angle_std_deg' must be a number >= 0 (deg), got {sd!r}")
                if s.get("direction", "from-data") not in DIRECTIONS:
                    raise _err(file, f"key '{where}.direction' is {s.get('direction')!r}; valid: {DIRECTIONS}")
                if "angle_cov_deg2" in s:
                    angle_covariance(s["angle_cov_deg2"], f"key '{where}.angle_cov_deg2'")
            elif typ == "static" and "up" in s:
                axis_vector(s["up"], f"key '{where}.up'")
        except RecordError as e:
            if str(e).startswith(str(file)):
                raise
            raise _err(file, str(e)) from None
    for i, s in enumerate(segs):
        if s["type"] == "move":
            for k in ("from", "to"):
                other = next((x for x in segs if x.get("label") == s.get(k)), None)
                if other is None or other["type"] != "static":
                    raise _err(file, f"key 'segments[{i}].{k}' must be the label of a static segment, got {s.get(k)!r}")
    return meta


def gyro_columns(columns) -> tuple[list[str], str]:
    """The three gyro column names and their unit (``"dps"`` or ``"counts"``)."""
    for unit in ("dps", "counts"):
        names = [f"gyro_{c}_{unit}" for c in CHANNELS]
        if all(n in columns for n in names):
            return names, unit
    return [], ""


def validate_triad_columns(meta: dict, columns: dict, file="record.csv") -> None:
    """Check a triad record's columns against its JSON (module doc)."""
    names, unit = gyro_columns(columns)
    if not names:
        have = [c for c in columns if c.startswith("gyro_")]
        raise _err(
            file, f"missing gyro columns: need gyro_x_dps, gyro_y_dps, gyro_z_dps (or gyro_<c>_counts); have {have}"
        )
    if unit == "counts" and meta["instrument"].get("gyro_counts_per_dps") is None:
        raise _err(file, "gyro columns are in counts: key 'instrument.gyro_counts_per_dps' (nominal scale) is required")
    if "segment" not in columns:
        raise _err(file, "missing required column 'segment' (integer labels described by the JSON key 'segments')")
    seg = columns["segment"]
    if np.any(seg != np.round(seg)):
        i = int(np.flatnonzero(seg != np.round(seg))[0])
        raise _err(file, f"row {i + 2}, column 'segment' holds {seg[i]!r}; segment labels are integers")
    present = set(np.unique(seg).astype(int))
    for i, s in enumerate(meta["segments"]):
        if s["label"] not in present:
            raise _err(file, f"segment label {s['label']} (JSON segments[{i}]) has no sample in column 'segment'")


def is_triad(meta: dict) -> bool:
    """True when a record JSON describes an ``imu-triad`` instrument."""
    inst = meta.get("instrument") if isinstance(meta, dict) else None
    return isinstance(inst, dict) and inst.get("kind") == TRIAD_KIND


def gyro_dph(record) -> np.ndarray:
    """Indicated gyro rates, (n, 3) deg/h: the dps columns × 3600, or counts / nominal scale × 3600."""
    names, unit = gyro_columns(record.columns)
    g = np.stack([np.asarray(record.columns[n], dtype=float) for n in names], axis=1)
    if unit == "counts":
        g = g / float(record.meta["instrument"]["gyro_counts_per_dps"])
    return g * units.SECONDS_PER_HOUR


def acc_g(record) -> np.ndarray | None:
    """Accelerometer specific force, (n, 3) in g, or None when the record has none."""
    names = [f"acc_{c}_g" for c in CHANNELS]
    if not all(n in record.columns for n in names):
        return None
    return np.stack([np.asarray(record.columns[n], dtype=float) for n in names], axis=1)


def triad_meta(
    name: str,
    segments: list,
    *,
    latitude_deg=None,
    gravity_mps2: float | None = None,
    counts_per_dps=None,
    notes: str = "",
    instrument_id: str | None = None,
    extra: dict | None = None,
) -> dict:
    """The JSON of a triad record (module doc): its site (``latitude_deg`` in deg or None; ``gravity_mps2`` in m/s²,
    when not given WGS-84 normal gravity at the latitude, g0 without one), instrument (``counts_per_dps``: the gyro's
    nominal scale, counts per deg/s) and segments."""
    gravity_mps2 = site_gravity(latitude_deg) if gravity_mps2 is None else float(gravity_mps2)
    inst = {"kind": TRIAD_KIND, "channels": list(CHANNELS)}
    if instrument_id is not None:
        inst["id"] = instrument_id
    if counts_per_dps is not None:
        inst["gyro_counts_per_dps"] = float(counts_per_dps)
    meta = {
        "format": FORMAT,
        "name": name,
        "site": {"latitude_deg": latitude_deg, "gravity_mps2": gravity_mps2},
        "instrument": inst,
        "earth_rate": True,
        "segments": segments,
        "notes": notes,
    }
    meta.update(extra or {})
    return meta
