"""The segments of a turntable log, detected from the table's channel alone: positions (every axis still), rate
steps (every axis at a constant rate) and the transitions between them, with the revolutions turned in each step.

A sample is *level* when the mean table rate over the window before it and over the window after it agree, on every
axis, within the tolerance of the channel itself: the angle's resolution (two quanta over a window's span, an
encoder's count or the column's smallest step), six times the spread of that difference over the log (robustly,
its median absolute deviation: the rate noise of a table at speed) and 0.2 % of the rate (a rate table's ripple).
Runs of level samples that last at least ``hold_s`` are holds; a hold that turns by less than three quanta on every
axis is a position, any other a rate step. Everything else (acceleration, braking, slewing between positions) is a
transition. Time gaps (a step above 1.5 × the median step, conventions §5) end every run. In servo mode the table
turns to keep the instrument at null: each continuous stretch is one ``servo`` segment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyrojax.data.timebase import GAP_FACTOR, true_runs

HOLD_S = 2.0
"""Shortest hold (position or rate step) kept, s."""
WINDOW_S = 0.5
"""The windows over which the mean table rate is compared, s (at least 2 samples each)."""
RATE_RIPPLE = 2e-3
"""Relative ripple of a rate table's speed accepted as level (0.2 %)."""
NOISE_FACTOR = 6.0
"""Multiple of the robust spread of the rate difference accepted as noise."""


@dataclass
class TableSegment:
    """One detected segment: ``kind`` ``position``, ``rate``, ``transition`` or ``servo``; samples ``start`` to
    ``end`` (end exclusive), times ``t0``, ``t1`` s; ``rates_dps`` (k,) the mean rate of each axis over it, deg/s;
    ``angles_deg`` (k,) the mean angle (positions), deg; ``revolutions`` (k,) turns of each axis over it (signed)."""

    kind: str
    start: int
    end: int
    t0: float
    t1: float
    rates_dps: np.ndarray
    angles_deg: np.ndarray
    revolutions: np.ndarray

    def to_json(self, label: int, axes: list) -> dict:
        """The segment as the record's import report writes it."""
        d = {"label": label, "type": self.kind, "start_s": round(self.t0, 6), "end_s": round(self.t1, 6)}
        if self.kind == "position":
            d["angles_deg"] = {a: round(float(v), 6) for a, v in zip(axes, self.angles_deg)}
        elif self.kind in ("rate", "servo"):
            d["rates_dps"] = {a: float(f"{v:.9g}") for a, v in zip(axes, self.rates_dps)}
            d["revolutions"] = {a: round(float(v), 4) for a, v in zip(axes, self.revolutions)}
        return d


MAX_RESOLUTION_DEG = 1e-3
"""Coarsest angle resolution taken from a column's steps (3.6″): a table that moves in big steps between holds has no
smaller step to show its resolution, and a table's angle is read to arcseconds."""


def _quantum(x: np.ndarray) -> float:
    """The resolution of an angle column (deg): its smallest non-zero step, at most :data:`MAX_RESOLUTION_DEG`."""
    d = np.abs(np.diff(x))
    d = d[d > 1e-12 * max(float(np.max(np.abs(x))), 1.0)]  # the rounding of an unwrapped sum is no step
    return min(float(d.min()), MAX_RESOLUTION_DEG) if d.size else 0.0


def _pieces(t: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) of the continuous stretches of ``t`` (steps up to 1.5 × the median step)."""
    if len(t) < 2:
        return [(0, len(t))]
    dt = np.diff(t)
    brk = np.flatnonzero(dt > GAP_FACTOR * np.median(dt)) + 1
    edges = np.concatenate([[0], brk, [len(t)]])
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


def _window_rates(t, angles, rates, h):
    """Mean rate (n, k) deg/s over the window of ``h`` samples before and after each sample: from the angles (their
    difference over the window) where there are angles, else the rate column averaged."""
    n = len(t)
    lo = np.clip(np.arange(n) - h, 0, n - 1)
    hi = np.clip(np.arange(n) + h, 0, n - 1)
    span = np.maximum(t[hi] - t[lo], 1e-300)[:, None]
    if angles is not None:
        before = (angles - angles[lo]) / np.maximum(t - t[lo], 1e-300)[:, None]
        after = (angles[hi] - angles) / np.maximum(t[hi] - t, 1e-300)[:, None]
        mean = (angles[hi] - angles[lo]) / span
    else:
        c = np.concatenate([np.zeros((1, rates.shape[1])), np.cumsum(rates, axis=0)])
        idx = np.arange(n)
        before = (c[idx + 1] - c[lo]) / np.maximum(idx + 1 - lo, 1)[:, None]
        after = (c[hi + 1] - c[idx]) / np.maximum(hi + 1 - idx, 1)[:, None]
        mean = (c[hi + 1] - c[lo]) / np.maximum(hi + 1 - lo, 1)[:, None]
    edge = (np.arange(n) - h < 0) | (np.arange(n) + h > n - 1)
    before[np.arange(n) - h < 0] = after[np.arange(n) - h < 0]
    after[np.arange(n) + h > n - 1] = before[np.arange(n) + h > n - 1]
    return before, after, mean, edge


def level_samples(t, angles, rates, window_s: float = WINDOW_S, resolution=None) -> tuple[np.ndarray, np.ndarray]:
    """(level mask (n,), tolerance (k,) deg/s) of one continuous stretch (module doc); ``resolution`` (k,) deg the
    angle readout's (an encoder's 360°/counts), else estimated (:func:`_quantum`)."""
    n = len(t)
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    h = max(2, int(round(window_s / dt)))
    before, after, mean, _ = _window_rates(t, angles, rates, h)
    diff = after - before
    k = diff.shape[1]
    tol = np.zeros(k)
    for j in range(k):
        q = 0.0 if angles is None else (_quantum(angles[:, j]) if resolution is None else float(resolution[j]))
        mad = 1.4826 * float(np.median(np.abs(diff[:, j] - np.median(diff[:, j])))) if n else 0.0
        tol[j] = max(2.0 * 2.0 * q / (h * dt), NOISE_FACTOR * mad, 1e-9)
    ok = np.abs(diff) <= tol + RATE_RIPPLE * np.abs(mean)
    return np.all(ok, axis=1), tol


def detect_table_segments(
    t: np.ndarray,
    angles: np.ndarray | None,
    rates: np.ndarray | None,
    *,
    hold_s: float = HOLD_S,
    window_s: float = WINDOW_S,
    servo: bool = False,
    resolution=None,
) -> list[TableSegment]:
    """Positions, rate steps and transitions of a table log (module doc), in time order, covering every sample.

    Args: ``t`` (n,) s increasing; ``angles`` (n, k) deg, unwrapped, or None; ``rates`` (n, k) deg/s or None (at
    least one of the two); ``hold_s`` the shortest hold; ``window_s`` the windows of the level test; ``servo``: each
    continuous stretch is one servo segment; ``resolution`` (k,) deg: the angle readout's, when known.
    """
    t = np.asarray(t, dtype=float)
    out = []
    for s0, e0 in _pieces(t):
        ts = t[s0:e0]
        ang = None if angles is None else angles[s0:e0]
        rts = None if rates is None else rates[s0:e0]
        if servo or e0 - s0 < 5:
            kind = "servo" if servo else "transition"
            out.append(_segment(kind, s0, e0, t, angles, rates))
            continue
        level, _ = level_samples(ts, ang, rts, window_s, resolution)
        holds = [(s, e) for s, e in true_runs(level) if ts[e - 1] - ts[s] >= hold_s]
        pos = s0
        for s, e in holds:
            if s0 + s > pos:
                out.append(_segment("transition", pos, s0 + s, t, angles, rates))
            out.append(_segment("hold", s0 + s, s0 + e, t, angles, rates, resolution))
            pos = s0 + e
        if pos < e0:
            out.append(_segment("transition", pos, e0, t, angles, rates))
    return out


def _segment(kind, s, e, t, angles, rates, resolution=None) -> TableSegment:
    """A :class:`TableSegment` over samples s…e; a ``hold`` becomes a position or a rate step."""
    span = t[e - 1] - t[s] if e - s > 1 else 0.0
    if angles is not None:
        turn = angles[e - 1] - angles[s]
        mean_rate = turn / span if span > 0 else np.zeros(angles.shape[1])
        mean_angle = angles[s:e].mean(axis=0)
    else:
        mean_rate = rates[s:e].mean(axis=0)
        turn = mean_rate * span
        mean_angle = np.full(rates.shape[1], np.nan)
    if kind == "hold":
        q = None
        if angles is not None:
            q = [_quantum(angles[:, j]) for j in range(angles.shape[1])] if resolution is None else resolution
            q = np.asarray(q, dtype=float)
        still = np.abs(turn) <= (3.0 * q if q is not None else 0.0) + 1e-9
        if angles is None:  # a rate column alone: still when the mean rate is within the noise of zero
            sd = rates[s:e].std(axis=0) / np.sqrt(max(e - s, 1))
            still = np.abs(mean_rate) <= 5.0 * sd + 1e-6
        kind = "position" if np.all(still) else "rate"
    return TableSegment(kind, s, e, float(t[s]), float(t[e - 1]), mean_rate, mean_angle, turn / 360.0)


def describe(segments: list[TableSegment], axes: list) -> str:
    """One line: the positions (their angles, deg), the rate steps (their rates, deg/s, and revolutions) and the
    transitions."""
    pos = [s for s in segments if s.kind == "position"]
    rate = [s for s in segments if s.kind == "rate"]
    servo = [s for s in segments if s.kind == "servo"]
    trans = [s for s in segments if s.kind == "transition"]
    parts = []
    if pos:
        angles = sorted({tuple(np.round(s.angles_deg, 3)) for s in pos})
        shown = ", ".join("(" + ", ".join(f"{a:g}" for a in ang) + ")" for ang in angles[:8])
        parts.append(f"{len(pos)} positions at {shown}{' …' if len(angles) > 8 else ''} deg ({', '.join(axes)})")
    if rate:
        rates = [s.rates_dps[np.argmax(np.abs(s.rates_dps))] for s in rate]
        revs = [s.revolutions[np.argmax(np.abs(s.rates_dps))] for s in rate]
        shown = ", ".join(f"{r:+.4g}" for r in rates[:10]) + (" …" if len(rates) > 10 else "")
        parts.append(
            f"{len(rate)} rate steps at {shown} deg/s ({sum(abs(v) for v in revs):.4g} revolutions in all, "
            f"{min(abs(v) for v in revs):.3g}–{max(abs(v) for v in revs):.3g} per step)"
        )
    if servo:
        revs = sum(float(np.max(np.abs(s.revolutions))) for s in servo)
        parts.append(f"{len(servo)} servo stretch(es), {revs:.3g} revolutions")
    if trans:
        parts.append(f"{len(trans)} transitions")
    return "; ".join(parts) if parts else "no segment"
