"""Whether a gyro's angle random walk can be a gyro's at all, and which unit mistake would explain it when not.

An ARW outside :data:`ARW_ANY` belongs to no gyro (the best strategic gyros are near 1e-4 deg/√h, the worst MEMS
parts near 10); inside it but outside :data:`ARW_MEMS` it is no MEMS gyro's, which an ``imu-triad`` record (a
MEMS IMU, docs/conventions.md §9.3) is by default. A rate in the wrong unit scales N by 57.3 (rad/s against
deg/s); a clock in the wrong unit scales τ0, and N with √τ0, by √1000 per factor of 10³ (s against ms): the
message gives N as it would be after each correction that brings it into the range, and the flags."""

from __future__ import annotations

import math

ARW_ANY = (1e-4, 100.0)
"""Angle random walk of any gyro, deg/√h."""
ARW_MEMS = (0.02, 20.0)
"""Angle random walk of a MEMS gyro, deg/√h: the best tactical MEMS parts (0.02–0.05; only a rare quartz or ring
gyro goes lower) to the noisiest consumer ones (a few deg/√h; 20 leaves room)."""

_FIXES = (
    (180.0 / math.pi, "the rates are rad/s declared deg/s (--gyro-unit)"),
    (math.pi / 180.0, "the rates are deg/s declared rad/s (--gyro-unit)"),
    (math.sqrt(1e3), "the time column is in s declared ms, or --rate-hz 1000x too high (--time-unit, --rate-hz)"),
    (1.0 / math.sqrt(1e3), "the time column is in ms read as s, or --rate-hz 1000x too low (--time-unit, --rate-hz)"),
)


def arw_warning(name: str, arw: float | None, mems: bool = False) -> str | None:
    """A sentence when ``arw`` (deg/√h) of channel ``name`` lies outside :data:`ARW_ANY` (or, with ``mems``,
    :data:`ARW_MEMS`), naming the corrections that would bring it inside and their flags; None when it is
    plausible or not read."""
    if arw is None or not math.isfinite(arw) or arw <= 0:
        return None
    lo, hi = ARW_MEMS if mems else ARW_ANY
    if lo <= arw <= hi:
        return None
    what = "a MEMS gyro's" if mems else "any gyro's"
    side = "below" if arw < lo else "above"
    fixes = [f"N would be {arw * k:.3g} deg/sqrt(h) if {why}" for k, why in _FIXES if lo <= arw * k <= hi]
    tail = "; ".join(fixes) if fixes else "check --gyro-unit, --gyro-scale, --time-unit and --rate-hz"
    return f"{name}: ARW {arw:.3g} deg/sqrt(h) is {side} {what} ({lo:g} to {hi:g} deg/sqrt(h)): {tail}"
