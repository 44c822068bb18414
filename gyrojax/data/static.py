"""Static SDF records as the rate series of the noise analysis (:mod:`gyrojax.noise.allan` works on arrays)."""

from __future__ import annotations

import numpy as np

from gyrojax.data.timebase import uniform_interval
from gyrojax.errors import RecordError
from gyrojax.noise.allan import AllanError

JITTER_TOLERANCE = 0.1
"""Largest timestamp jitter (max |Δt − mean Δt| / mean Δt within a continuous segment) taken as a uniform
sampling at the mean interval; more is refused (the Allan variance needs a constant sample interval)."""


def static_rate_segments(records, rate_tol_dps: float = 1e-9, notes: list | None = None):
    """The indicated rate (deg/h) of static SDF records, split into continuous segments; and the common τ0 (s).

    Gaps (steps over 1.5 × the median, :func:`gyrojax.data.timebase.continuous_segments`) split a record into
    segments that are pooled. Timestamp jitter within a segment up to :data:`JITTER_TOLERANCE` of the interval
    is tolerated: τ0 is then the mean interval and a sentence saying so is appended to ``notes`` (if given).
    Raises :class:`AllanError` for a non-SDF record, a moving table, larger jitter, or intervals that differ.
    """
    segs, tau0 = [], None
    for r in records:
        if r.kind != "sdf-gyro":
            raise AllanError(f"{r.name}: the noise analysis takes SDF gyro records, this one is {r.kind!r}")
        if r.mode != "rebalance":
            raise AllanError(f"{r.name}: the noise analysis needs a rebalance-mode record, this one is {r.mode!r}")
        moving = np.abs(r.rates_dps) > rate_tol_dps
        if moving.any():
            row, col = np.argwhere(moving)[0]
            raise AllanError(
                f"{r.name}: table axis {r.axis_names[col]!r} moves at row {row + 1} "
                f"({r.rates_dps[row, col]:g} deg/s); the noise analysis needs static records"
            )
        sid, y, t = r.segment_id, r.indicated, r.time_s
        # the ids count up along the record (gyrojax.data.records.continuous_segments): each piece is one run
        starts = np.concatenate([[0], np.flatnonzero(sid[1:] != sid[:-1]) + 1])
        ends = np.append(starts[1:], len(sid))
        if len(starts) > 1 and notes is not None:
            notes.append(f"{r.name}: {len(starts)} continuous pieces separated by gaps, analysed separately and pooled")
        for s, a, b in zip(sid[starts], starts, ends):
            sel = slice(a, b)
            if b - a < 4:
                continue
            try:
                d, jitter = uniform_interval(t[sel], JITTER_TOLERANCE)
            except RecordError as e:
                raise AllanError(
                    f"{r.name}: non-uniform sampling in segment {int(s)}: {e}; the Allan variance needs a constant "
                    "sample interval"
                ) from None
            if jitter > 1e-6 and notes is not None:
                notes.append(
                    f"{r.name}: timestamp jitter up to {100 * jitter:.2g} % of the interval; "
                    f"the mean interval {d:.9g} s is used"
                )
            if tau0 is None:
                tau0 = d
            elif abs(d - tau0) > max(1e-6, JITTER_TOLERANCE * 0.1) * tau0:
                raise AllanError(f"{r.name}: sample interval {d:g} s differs from {tau0:g} s of the other records")
            segs.append(np.asarray(y[sel], float))
    if not segs:
        raise AllanError("no continuous static segment with at least 4 samples in the records")
    return segs, tau0
