"""What a log holds, said at the door and checked against physics before any record is written: the clock (rate,
duration, where each came from: :func:`gyrojax.data.logs.log_clock`), each channel's range, and at rest the
specific force against the local g and the gyro against the Earth rate plus a sensor's plausible bias. A unit
that makes a rest impossible is refused naming the flag."""

from __future__ import annotations

import math

import numpy as np

from gyrojax import units
from gyrojax.errors import RecordError

EARTH_RATE_DPS = units.OMEGA_IE / units.DEG
"""ω_ie in deg/s (0.004178)."""
MAX_REST_RATE_DPS = 30.0
"""Largest |ω| (deg/s) a gyro reads at rest: the Earth rate plus a MEMS zero-rate offset (±20 deg/s is the
MPU-6050's specification, the widest of common MEMS; 1–5 deg/s is typical). More is a unit or scale mistake (deg/s
declared rad/s reads 57.3× too high)."""


def channel_ranges(columns: dict) -> dict:
    """Per channel (name → array, input units): ``[min, max, mean]``."""
    return {k: [float(np.min(v)), float(np.max(v)), float(np.mean(v))] for k, v in columns.items()}


def rest_means(x: np.ndarray, intervals) -> np.ndarray:
    """The mean of ``x`` (n, 3) over each rest (start, end) of ``intervals``: (k, 3)."""
    return np.array([x[s:e].mean(axis=0) for s, e in intervals]).reshape(len(intervals), x.shape[1])


def check_rest_gyro(gyro_dps: np.ndarray, intervals, where: str, gyro_unit: str) -> dict:
    """The gyro at rest (deg/s) against the Earth rate plus a plausible bias (:data:`MAX_REST_RATE_DPS`): returns
    ``{"rest_rate_dps": [|ω̄| per rest], "earth_rate_dps": …, "limit_dps": …}``; :class:`RecordError` naming
    ``--gyro-unit`` when the median rest of a gyro in rate units reads more than the limit. Raw counts are not
    refused: their zero may be offset (unsigned counts read 32768 at zero rate), which the fit's bias takes."""
    mags = np.linalg.norm(rest_means(gyro_dps, intervals), axis=1)
    med = float(np.median(mags))
    if med > MAX_REST_RATE_DPS and gyro_unit != "counts":
        alt = "deg/s data declared rad/s read 57.3× too high: --gyro-unit dps?" if gyro_unit == "rad/s" else ""
        alt = alt or "rad/s data would read this in deg/s only if 57.3× off; is --gyro-unit right?"
        raise RecordError(
            f"{where}: the gyro reads |ω| = {med:.4g} deg/s at rest (median of {len(mags)} rests, as --gyro-unit "
            f"{gyro_unit}); a gyro at rest reads the Earth rate ({EARTH_RATE_DPS:.2g} deg/s) plus its bias, at most "
            f"~{MAX_REST_RATE_DPS:g} deg/s for any MEMS gyro: {alt}"
        )
    return {
        "rest_rate_dps": [float(x) for x in mags],
        "unit": gyro_unit,
        "earth_rate_dps": EARTH_RATE_DPS,
        "limit_dps": MAX_REST_RATE_DPS,
    }


def door_lines(report: dict) -> list[str]:
    """The lines ``gyrojax import`` prints about what it read (the ``clock``, ``ranges``, ``rest_gyro`` and
    ``rest_gravity`` of an import report, those it has)."""
    out = []
    c = report.get("clock")
    if c:
        checked = f"; agrees with {', '.join(c['checked_against'])}" if c.get("checked_against") else ""
        out.append(
            f"clock: {c['n_samples']} samples at {c['rate_hz']:.6g} Hz from {c['rate_from']}{checked}; "
            f"{_duration(c['duration_s'])}"
        )
    for name, (lo, hi, mean) in report.get("ranges", {}).items():
        out.append(f"  {name}: {lo:.6g} to {hi:.6g} (mean {mean:.6g}) {report.get('range_units', {}).get(name, '')}")
    g = report.get("rest_gyro")
    if g:
        r = np.asarray(g["rest_rate_dps"])
        why = (
            "raw counts at the nominal scale: their zero may be offset, which the fit's bias takes"
            if g.get("unit") == "counts"
            else f"Earth rate {g['earth_rate_dps']:.2g} deg/s plus the bias; a MEMS gyro reads at most "
            f"~{g['limit_dps']:g} deg/s at rest"
        )
        out.append(f"gyro at rest: |ω| {_span(r)} deg/s over {len(r)} rest(s) ({why})")
    a = report.get("rest_gravity")
    if a:
        r = np.asarray(a["rest_magnitude_g"])
        out.append(
            f"accelerometer at rest: |a| {_span(r)} g against the local g {a['local_g']:.6g} g "
            f"({100 * (float(np.median(r)) / a['local_g'] - 1):+.2f} %, median)"
        )
    return out


def _span(x) -> str:
    x = np.asarray(x, float)
    return f"{x.min():.4g}" if len(x) == 1 or math.isclose(x.min(), x.max()) else f"{x.min():.4g}–{x.max():.4g}"


def _duration(s: float) -> str:
    return f"{s:.6g} s" if s < 600 else f"{s:.6g} s ({s / 3600:.3g} h)"
