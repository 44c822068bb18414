"""Rest logs: an IMU left still — one rest, a long still stretch, or a few rests between bumps — as an
``imu-triad`` record whose rests are ``static`` segments (docs/conventions.md §9.3), for ``gyrojax noise`` (per
channel), ``noise --kalibr`` and ``apply``. Not a calibration: a calibration needs at least 9 rests in
different orientations (:mod:`gyrojax.data.importers`); a log is taken as a rest log when its rests cover most of
it (:data:`REST_LOG_COVERAGE`) and, with an accelerometer, there are fewer than 9 of them, all in one orientation
(:data:`SAME_ORIENTATION_DEG`).

The accelerometer of a rest log cannot be calibrated (one orientation determines no ellipsoid): given in g or m/s²
it is kept, given in counts it needs its nominal scale (``acc_counts_per_g``, ``--acc-scale``); either way the
rest |a| is compared with the local g and said (refused beyond :data:`~gyrojax.data.accelcheck.ACC_UNIT_TOL`, a
unit mistake).
"""

from __future__ import annotations

import numpy as np

from gyrojax import units
from gyrojax.data.accelcheck import ACC_CALIBRATED_TOL, ACC_UNIT_TOL
from gyrojax.data.door import rest_means
from gyrojax.errors import RecordError

REST_LOG_COVERAGE = 0.8
"""A rest log's rests cover at least this fraction of its samples (a still log with a bump or two); a hand session
with too few rests covers less, or points its rests in different directions, and is refused."""
SAME_ORIENTATION_DEG = 5.0
"""Rests whose mean specific force points within this angle of the first rest's are one orientation (a bump
shifts a still IMU by far less; a hand session turns it by tens of degrees)."""


def is_rest_log(intervals, n: int, acc=None) -> bool:
    """Whether a log of ``n`` samples whose rests are ``intervals`` is a rest log (module doc); ``acc`` (n, 3), any
    unit, or None."""
    if not intervals or coverage(intervals, n) < REST_LOG_COVERAGE:
        return False
    if acc is None:
        return True
    if len(intervals) >= 9:
        return False
    u = rest_means(acc, intervals)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    return bool(np.all(u @ u[0] >= np.cos(np.radians(SAME_ORIENTATION_DEG))))


def coverage(intervals, n: int) -> float:
    """The fraction of ``n`` samples inside the rests ``intervals``."""
    return sum(e - s for s, e in intervals) / max(n, 1)


def rest_accelerometer(acc, intervals, acc_unit: str, g_units: float, counts_per_g, where: str):
    """The accelerometer of a rest log in g (module doc) and its check: (acc (n, 3) g, ``rest_gravity`` report,
    notes)."""
    if acc_unit not in ("g", "m/s^2", "counts"):
        raise RecordError(f"accelerometer unit (--acc-unit) must be 'g', 'm/s^2' or 'counts', got {acc_unit!r}")
    if acc_unit == "counts":
        if counts_per_g is None:
            raise RecordError(
                f"{where}: a rest log's accelerometer in counts needs its nominal scale: --acc-scale (counts per g, "
                "e.g. 16384 at ±2 g), or --acc-unit g / m/s^2; one orientation cannot calibrate it"
            )
        scale = 1.0 / float(counts_per_g)
    elif counts_per_g is not None:
        raise RecordError(f"{where}: a nominal accelerometer scale (--acc-scale) applies to counts, not to {acc_unit}")
    else:
        scale = 1.0 if acc_unit == "g" else 1.0 / units.G0
    acc_g = np.asarray(acc, dtype=float) * scale
    mags = np.linalg.norm(rest_means(acc_g, intervals), axis=1)
    err = float(np.median(mags)) / g_units - 1.0
    notes = []
    if abs(err) > ACC_UNIT_TOL:
        raise RecordError(
            f"{where}: the accelerometer reads |a| = {float(np.median(mags)):.4g} g at rest as --acc-unit {acc_unit}"
            + (f" with --acc-scale {counts_per_g:g}" if acc_unit == "counts" else "")
            + f", {100 * err:+.0f} % from the local g: is the unit (--acc-unit) or the scale (--acc-scale) right?"
        )
    if abs(err) > ACC_CALIBRATED_TOL:
        notes.append(
            f"the accelerometer reads |a| {100 * err:+.2f} % from the local g at rest (median): it is not calibrated "
            "(a rest log cannot calibrate it); its noise figures carry that scale error"
        )
    report = {"rest_magnitude_g": [float(x) for x in mags], "local_g": float(g_units), "unit": acc_unit}
    return acc_g, report, notes


def rest_segments(intervals, n: int) -> tuple[np.ndarray, list]:
    """The ``segment`` column (each rest its label 0, 1, …; −1 between them) and the JSON segments of a rest log."""
    labels = np.full(n, -1.0)
    segs = []
    for i, (s, e) in enumerate(intervals):
        labels[s:e] = i
        segs.append({"label": i, "type": "static", "name": f"rest-{i}"})
    return labels, segs
