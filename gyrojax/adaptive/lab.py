"""The laboratory's table, as the next test may use it.

A :class:`Lab` is what a designed test must respect: the table's gimbal chain (axes in ENU at zero angles,
outermost first, conventions §3) and site, the instrument's mounting on the platform (the records'; the case may
be turned on its faces, :func:`gyrojax.inference.separation.case_turns`, when ``turn_case``), the angle limits of
each axis, the rate at which the table moves between positions and the time it needs to settle there, the hours
one test may take and the hours the whole campaign may take. A designed test is one or more runs (at most
``mountings_per_test``, each at one mounting, ``remount_s`` apart) of static positions in rebalance mode, written as a
plan (:mod:`gyrojax.data.plans`) a table controller can follow: the mounting of each run, the angles of every axis,
the dwell at each position, the time between positions.

Between two positions the table is not logged for ``settle_s`` plus the largest angle any axis turns divided by
``rate_limit_dps`` (conventions §5: a gap ends a continuous segment); that time counts in the test's table hours.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import jax.numpy as jnp
import numpy as np

from gyrojax.data import plans
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.planning.fisher import Table
from gyrojax.protocol import is_finite_number


@dataclass(frozen=True)
class Lab:
    """The table and the hours of a laboratory (module doc). Angles in deg, rates in deg/s, times in s, hours in h."""

    axes: tuple
    instrument: dict
    latitude_deg: float
    gravity_mps2: float | None = None
    angle_limits_deg: tuple = ()
    rate_limit_dps: float = 10.0
    settle_s: float = 30.0
    hours_per_test: float = 8.0
    budget_hours: float = 100.0
    positions: int = 12
    turn_case: bool = True
    mountings_per_test: int = 3
    remount_s: float = 900.0
    dt_s: float = 1.0
    scale_factor: float = 17.171

    def __post_init__(self):
        k = len(self.axes)
        if k < 1:
            raise ModelError("lab: key 'axes' must hold at least one table axis")
        for key in ("rate_limit_dps", "hours_per_test", "budget_hours", "dt_s"):
            v = getattr(self, key)
            if not (is_finite_number(v) and v > 0):
                raise ModelError(f"lab: key '{key}' must be a finite number > 0, got {v!r}")
        for key in ("settle_s", "remount_s"):
            v = getattr(self, key)
            if not (is_finite_number(v) and v >= 0):
                raise ModelError(f"lab: key '{key}' must be a finite number >= 0, got {v!r}")
        if self.mountings_per_test not in (1, 2, 3):
            raise ModelError(f"lab: key 'mountings_per_test' must be 1, 2 or 3, got {self.mountings_per_test!r}")
        if not (isinstance(self.positions, int) and self.positions >= 2):
            raise ModelError(f"lab: key 'positions' must be an integer >= 2, got {self.positions!r}")
        if self.angle_limits_deg and len(self.angle_limits_deg) != k:
            raise ModelError(
                f"lab: key 'angle_limits_deg' needs one entry per table axis ({k}), got {len(self.angle_limits_deg)}"
            )
        for i, lim in enumerate(self.angle_limits_deg):
            if lim is None:
                continue
            lo, hi = lim
            if not (is_finite_number(lo) and is_finite_number(hi) and lo < hi and hi - lo <= 360.0):
                raise ModelError(
                    f"lab: key 'angle_limits_deg[{i}]' must be (low, high) deg with low < high, got {lim!r}"
                )

    @classmethod
    def from_records(cls, records, **overrides) -> "Lab":
        """The lab of the first record: its table axes, mounting, site, sample interval and scale factor;
        ``overrides`` set any other field."""
        if not records:
            raise ModelError("lab: no records to take the table from")
        r = records[0]
        meta = r.meta
        axes = tuple((ax["name"], tuple(float(c) for c in ax["axis_enu"])) for ax in meta["table"]["axes"])
        dt = float(np.median(np.diff(r.time_s))) if r.n > 1 else 1.0
        fields = {
            "axes": axes,
            "instrument": dict(meta["instrument"]),
            "latitude_deg": float(meta["site"]["latitude_deg"]),
            "gravity_mps2": float(meta["site"]["gravity_mps2"]) if "gravity_mps2" in meta["site"] else None,
            "dt_s": dt,
            "scale_factor": float(r.scale_factor),
        }
        fields.update(overrides)
        return cls(**fields)

    @property
    def min_dwell_s(self) -> float:
        """The shortest mean dwell (s) of a designed position: the settle time, and at least the four samples
        :meth:`sample_counts` keeps — a table is not moved and settled to hold a position for less time than it took
        to settle there."""
        return max(self.settle_s, 4.0 * self.dt_s)

    @property
    def kind(self) -> str:
        """The instrument kind (conventions §5)."""
        return self.instrument["kind"]

    @property
    def triad(self) -> np.ndarray:
        """The records' instrument axes as rows, platform coordinates (SDF: IA, OA, SA)."""
        keys = {fx.TDF: ("x", "y", "z"), fx.ACCEL: ("ia", "pa", "oa")}.get(self.kind, ("ia", "oa", "sa"))
        return np.array([self.instrument[k] for k in keys], dtype=float)

    def mountings(self) -> np.ndarray:
        """The instrument triads the test may use (m, 3, 3): the records' mounting first, then (``turn_case``) the
        other 23 turns of the case by multiples of 90° about its own axes."""
        from gyrojax.inference.separation import case_turns

        turns = case_turns() if self.turn_case else np.eye(3)[None]
        return np.einsum("mij,jk->mik", turns, self.triad)

    def table(self) -> Table:
        """The Fisher core's table (:class:`gyrojax.planning.fisher.Table`) of this chain, mounting and site."""
        t = Table.of(self.axes, dict(self.instrument), self.latitude_deg)
        if self.gravity_mps2 is not None:
            t = replace(t, template=replace(t.template, gravity=jnp.asarray(self.gravity_mps2)))
        return t

    def mount(self, triad) -> dict:
        """The instrument dict (conventions §5) of the mounting ``triad`` (rows: the instrument axes)."""
        t = np.asarray(triad, dtype=float)
        if self.kind == fx.TDF:
            m = plans.tdf_mount(t[0], t[1])
        elif self.kind == fx.ACCEL:
            m = plans.accel_mount(t[0], t[1])
        else:
            m = plans.sdf_mount(t[0], t[1])
            m["kind"] = self.kind
        extra = {k: v for k, v in self.instrument.items() if k not in m}  # id, channel …: the same instrument
        return {**m, **extra}

    def limited(self) -> tuple:
        """Per axis: (low, high) deg, or None for an axis that turns freely."""
        return tuple(self.angle_limits_deg) if self.angle_limits_deg else (None,) * len(self.axes)

    def move_deg(self, a, b) -> float:
        """The largest angle (deg) any axis turns from position ``a`` to ``b`` (a free axis the shorter way)."""
        out = 0.0
        for x, y, lim in zip(a, b, self.limited()):
            d = abs(float(y) - float(x))
            out = max(out, d if lim is not None else min(d % 360.0, 360.0 - d % 360.0))
        return out

    def gap_s(self, angles_deg) -> float:
        """Time between positions (s): the settle time plus the longest move of the sequence at the rate limit."""
        moves = [self.move_deg(a, b) for a, b in zip(angles_deg[:-1], angles_deg[1:])]
        return self.settle_s + (max(moves) if moves else 0.0) / self.rate_limit_dps

    def order(self, angles_deg, dwell_s):
        """The positions reordered to shorten the moves (nearest neighbour from the first)."""
        n = len(angles_deg)
        left, path = list(range(1, n)), [0]
        while left:
            j = min(left, key=lambda i: self.move_deg(angles_deg[path[-1]], angles_deg[i]))
            path.append(j)
            left.remove(j)
        return np.asarray(angles_deg)[path], np.asarray(dwell_s)[path]

    def sample_counts(self, dwell_s) -> np.ndarray:
        """Whole samples of ``dt_s`` per position: each dwell (s) rounded, at least 4. Every designed test samples at
        the one interval, so that the fit pools their noise into one model (records of one mode and interval)."""
        return np.maximum(4, np.round(np.asarray(dwell_s, dtype=float) / self.dt_s)).astype(int)

    def plan(self, name: str, triads, angles_deg, dwell_s, description: str):
        """The designed test as a plan: one rebalance run of static positions per mounting ``triads[j]`` (rows: the
        instrument axes), ``angles_deg[j]`` (n, k) held ``dwell_s[j]`` (n,) s, reordered to shorten the moves, each
        a whole number of samples, :meth:`gap_s` apart; runs :attr:`remount_s` apart."""
        runs = []
        for j, (triad, a_deg, d_s) in enumerate(zip(triads, angles_deg, dwell_s)):
            for a in a_deg:
                for i, (x, lim) in enumerate(zip(a, self.limited())):
                    if lim is not None and not lim[0] - 1e-6 <= x <= lim[1] + 1e-6:
                        raise ModelError(f"designed angle {x:.3f} deg of axis {self.axes[i][0]!r} outside {lim}")
            ang, dwell = self.order(np.asarray(a_deg, float), np.asarray(d_s, float))
            counts, dt = self.sample_counts(dwell), self.dt_s
            segs = tuple(
                plans.Segment(tuple(round(float(x), 6) for x in a), float(c) * dt, dt, label=i)
                for i, (a, c) in enumerate(zip(ang, counts))
            )
            runs.append(
                plans.Run(
                    f"{name}-{j + 1}" if len(triads) > 1 else name,
                    tuple(self.axes),
                    self.mount(triad),
                    segs,
                    scale_factor=self.scale_factor,
                    gap_s=round(self.gap_s(ang), 3),
                )
            )
        plan = plans.Plan(
            name,
            tuple(runs),
            self.latitude_deg,
            self.gravity_mps2,
            description=description,
            reference="score tests and Fisher information of the joint fit; Hu ch. 3 (multi-position tests)",
            gap_between_runs_s=self.remount_s,
        )
        return plans.validate_plan(plan, f"designed test {name!r}")

    def to_json(self) -> dict:
        """The lab as JSON (deg, deg/s, s, h)."""
        return {
            "axes": [{"name": n, "axis_enu": list(u)} for n, u in self.axes],
            "instrument": dict(self.instrument),
            "latitude_deg": self.latitude_deg,
            "angle_limits_deg": [list(x) if x else None for x in self.limited()],
            "rate_limit_dps": self.rate_limit_dps,
            "settle_s": self.settle_s,
            "hours_per_test": self.hours_per_test,
            "budget_hours": self.budget_hours,
            "positions": self.positions,
            "turn_case": self.turn_case,
            "mountings_per_test": self.mountings_per_test,
            "remount_s": self.remount_s,
            "dt_s": self.dt_s,
        }
