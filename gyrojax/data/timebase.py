"""The time base of a record (conventions §5): continuous segments, the runs of samples that pass a test, the
sample interval and its jitter, the interval key that groups records sampled at one rate, and rates derived from
angles inside segments.

Pure functions of arrays: they know nothing of files or metadata.
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.errors import RecordError

GAP_FACTOR = 1.5  # a time step above 1.5 × the median step ends a continuous segment (conventions §5)


def continuous_segments(time_s: np.ndarray, segment: np.ndarray | None = None) -> np.ndarray:
    """Label continuous runs: a new one starts where ``segment`` changes or the step exceeds 1.5 × median."""
    n = len(time_s)
    if n < 2:
        return np.zeros(n, dtype=np.int64)
    dt = np.diff(time_s)
    brk = dt > GAP_FACTOR * np.median(dt)
    if segment is not None:
        brk |= segment[1:] != segment[:-1]
    out = np.empty(n, dtype=np.int64)
    out[0] = 0
    np.cumsum(brk, out=out[1:])
    return out


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) of the runs of True in ``mask`` (end exclusive)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


JITTER_TOL = 0.05
"""Largest relative deviation of a step from the mean sample interval that :func:`uniform_interval` accepts as
logger jitter (5 %): a 204.8 Hz clock written with a few digits, or a logger's 9.9–10.05 ms steps."""


def uniform_interval(time_s, tol: float = JITTER_TOL) -> tuple[float, float]:
    """The mean sample interval of ``time_s`` (s) and its jitter, the largest |step − mean| / mean (dimensionless).

    Timestamps of real loggers jitter (rounding to a few digits, a clock read by software): the samples are taken
    uniformly, the stamps are not. Raises :class:`~gyrojax.errors.RecordError` when a step departs from the mean
    by more than ``tol`` (a gap or a changed rate, not jitter) or when there are fewer than two samples.
    """
    t = np.asarray(time_s, dtype=float)
    if t.size < 2:
        raise RecordError("a sample interval needs at least two samples")
    mean = float((t[-1] - t[0]) / (t.size - 1))
    if not mean > 0:
        raise RecordError("times must increase to define a sample interval")
    dev = np.diff(t)
    dev -= mean
    np.abs(dev, out=dev)  # |step − mean|, in place (one array of n − 1 for a long record)
    jitter = float(np.max(dev)) / mean
    if jitter > tol:
        i = int(np.argmax(dev))
        dt = np.diff(t)
        raise RecordError(
            f"step {i + 1} is {dt[i]:.6g} s against a mean interval of {mean:.6g} s ({100 * jitter:.3g} % off; "
            f"logger jitter up to {100 * tol:.3g} % is accepted): a gap or a change of sample rate"
        )
    return mean, jitter


def interval_key(dt_s: float, digits: int = 3) -> float:
    """A sample interval (s) rounded to ``digits`` significant digits: the key that tells records sampled at the
    same rate apart from others, whatever the last digits of their timestamps."""
    if not dt_s > 0 or not math.isfinite(dt_s):
        return 0.0
    return float(f"{dt_s:.{digits}g}")


def derive_rate(time_s: np.ndarray, angle_deg: np.ndarray, segment_id: np.ndarray) -> np.ndarray:
    """Angle rate (deg/s) by second-order differences, inside each continuous segment only."""
    rate = np.zeros_like(angle_deg, dtype=float)
    starts = np.flatnonzero(np.diff(segment_id, prepend=-1))
    ends = np.append(starts[1:], len(time_s))
    for s, e in zip(starts, ends):
        if e - s >= 2:
            rate[s:e] = np.gradient(angle_deg[s:e], time_s[s:e])
    return rate
