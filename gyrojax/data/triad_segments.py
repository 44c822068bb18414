"""The segments of a triad record as arrays: static poses, rotations of a known angle and gravity-to-gravity moves.

Each labelled stretch of an ``imu-triad`` record (:mod:`gyrojax.data.triad`) becomes a :class:`TriadSegment` (a static
pose: the mean indicated rate at the pose's specific force, the Earth rate of a body at rest; a rotation: the body
rate n·Θ·s(t)/∫s dt with the history's shape s(t) from the indicated rate about n) or a :class:`Move` (a
gravity-to-gravity move, known only through the Up directions before and after). The Earth rate (ω_ie = 15.04
deg/h) is split into its vertical part Ω sin φ, modelled, and its horizontal part Ω cos φ of unknown heading, a
covariance; with the latitude unknown the horizontal part is its mean square over the sphere, (2/3) Ω². The fit
that uses them is :func:`gyrojax.inference.triad.fit_triad`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gyrojax import units
from gyrojax.data.triad import acc_g, axis_vector, gyro_dph
from gyrojax.errors import ModelError


@dataclass
class TriadSegment:
    """One measurement group: a static pose or a rotation (three rows of the measurement vector, one per channel).

    ``y`` (3,) mean indicated rate, deg/h; ``w`` (n, 3) body rate (deg/h) and ``a`` (n, 3) specific force (g) of the
    model; ``t_h`` (n,) h; ``temp`` (n,) °C; ``extra`` (3, 3) covariance added to the noise (heading, angle), deg²/h²;
    ``n`` samples averaged; ``kind`` ``"static"`` or ``"rotation"``; ``name`` for reports.
    """

    kind: str
    name: str
    y: np.ndarray
    w: np.ndarray
    a: np.ndarray
    t_h: np.ndarray
    temp: np.ndarray
    n: int
    extra: np.ndarray
    record: str = ""
    info: dict = field(default_factory=dict)


@dataclass
class Move:
    """A gravity-to-gravity move (imu_tk): gyro samples ``g`` (n, 3) deg/h and specific force ``a`` (n, 3) g between
    two static poses whose Up directions in the body frame are ``u_from`` and ``u_to`` (unit vectors, from the
    accelerometer); ``dt`` s; ``var_dir`` the variance (rad², per axis) of the two directions' noise; ``t_h`` (n,) h
    and ``temp`` (n,) °C of the samples (time and temperature terms integrate along the move)."""

    name: str
    g: np.ndarray
    a: np.ndarray
    dt: float
    u_from: np.ndarray
    u_to: np.ndarray
    var_dir: float
    earth_var: float = 0.0
    t_h: np.ndarray | None = None
    temp: np.ndarray | None = None


def earth_terms(record, earth_rate: bool | None = None):
    """(vertical rate Ω sin φ in deg/h or None when unknown/off, horizontal magnitude bound in deg/h, mode text)."""
    on = record.meta.get("earth_rate", True) if earth_rate is None else earth_rate
    if not on:
        return 0.0, 0.0, "off"
    lat = record.meta["site"].get("latitude_deg")
    omega = units.OMEGA_IE_DEG_PER_H
    if lat is None:  # the site averaged over the sphere: E[cos² φ] = 2/3
        return None, omega * math.sqrt(2.0 / 3.0), "latitude unknown"
    phi = math.radians(float(lat))
    return omega * math.sin(phi), omega * math.cos(phi), f"latitude {float(lat):g} deg"


def unknown_direction_var(record, earth_rate: bool | None = None) -> float:
    """Variance (deg/h)² of each body component of the Earth rate when the body's orientation is unknown: Ω²/3
    (a vector of length Ω = 15.04 deg/h, its direction uniform on the sphere); 0 with the Earth rate off."""
    on = record.meta.get("earth_rate", True) if earth_rate is None else earth_rate
    return units.OMEGA_IE_DEG_PER_H**2 / 3.0 if on else 0.0


def label_rows(seg: np.ndarray):
    """A function giving the sample indices (ascending) of a segment label, from one stable sort of the labels
    instead of a scan of the record per segment; an absent label gives no index."""
    seg = np.asarray(seg).astype(int)
    order = np.argsort(seg, kind="stable")
    ordered = seg[order]

    def rows(label) -> np.ndarray:
        lo, hi = np.searchsorted(ordered, [label, label + 1])
        return order[lo:hi]

    return rows


def triad_segments(record, earth_rate: bool | None = None):
    """The static and rotation segments of one triad record as :class:`TriadSegment` s, the per-segment static residual
    series (deg/h, (n, 3), for the noise estimate), the Earth-rate mode (module doc) and the :class:`Move` s."""
    gyro = gyro_dph(record)
    acc = acc_g(record)
    t = np.asarray(record.time_s, dtype=float)
    temp = record.columns.get("temperature_C")
    temp = np.full(len(t), 20.0) if temp is None else np.asarray(temp, dtype=float)
    seg = np.asarray(record.columns["segment"]).astype(int)
    vertical, horizontal, mode = earth_terms(record, earth_rate)
    g_site = float(record.meta["site"]["gravity_mps2"]) / units.G0
    out, resid, moves = [], [], []
    rows = label_rows(seg)
    for spec in record.meta["segments"]:
        sel = rows(spec["label"])
        if spec["type"] == "move":
            mv = _move(record, spec, gyro, acc, t, rows, temp)
            # Up is fixed to the Earth, the gyro integrates the inertial rate: over the move the Earth turns Up by
            # Ω_h T about a horizontal axis of unknown heading, variance (Ω_h T)²/2 per component
            mv.earth_var = (horizontal * len(mv.g) * mv.dt * units.DEG_PER_H) ** 2 / 2.0
            moves.append(mv)
            continue
        if len(sel) < 2:
            raise ModelError(f"{record.name}: segment {spec['label']} has {len(sel)} sample(s); at least 2 are needed")
        name = spec.get("name", f"{spec['type']}-{spec['label']}")
        g = gyro[sel]
        a = acc[sel] if acc is not None else None
        th = t[sel] / units.SECONDS_PER_HOUR
        if spec["type"] == "static":
            if a is not None:
                a_mean = a.mean(axis=0)
                u = a_mean / np.linalg.norm(a_mean)
            elif "up" in spec:
                u = axis_vector(spec["up"])
                a_mean = u * g_site
            else:  # orientation unknown (a gyro alone): the Earth rate of unknown direction, no specific force
                u, a_mean = None, np.zeros(3)
            if u is None:
                w, extra = np.zeros((1, 3)), unknown_direction_var(record, earth_rate) * np.eye(3)
            else:
                w = np.zeros((1, 3)) if vertical is None else (vertical * u)[None, :]
                extra = 0.5 * horizontal**2 * (np.eye(3) - np.outer(u, u))
            out.append(
                TriadSegment(
                    "static",
                    name,
                    g.mean(axis=0),
                    w,
                    a_mean[None, :],
                    th.mean()[None],
                    temp[sel].mean()[None],
                    len(sel),
                    extra,
                    record.name,
                    {"up": u},
                )
            )
            resid.append(g - g.mean(axis=0))
        else:  # rotation of a known angle about a body axis, history unknown
            n_axis = axis_vector(spec["axis"])
            shape = g @ n_axis
            total = float(shape.sum())
            direction = spec.get("direction", "from-data")
            sign = {"positive": 1.0, "negative": -1.0}.get(direction, math.copysign(1.0, total))
            if direction == "from-data" and abs(total) == 0.0:
                raise ModelError(
                    f"{record.name}: rotation segment {spec['label']} shows no rotation about {spec['axis']}"
                )
            dt = (t[sel[-1]] - t[sel[0]]) / (len(sel) - 1)
            theta_deg = sign * float(spec["angle_deg"])
            # body rate (deg/h): n Θ s(t) / Σ s dt, so that Σ ω dt = n Θ (deg·h/h = deg, times 3600 s/h)
            w = np.outer(shape / total * theta_deg * units.SECONDS_PER_HOUR / dt, n_axis) * (1.0 if total else 0.0)
            if vertical is not None and a is not None:
                w = w + vertical * a / np.linalg.norm(a, axis=1, keepdims=True)
            a_rot = a if a is not None else np.tile(n_axis * sign * 0.0, (len(sel), 1))
            span = len(sel) * dt
            sd = float(spec.get("angle_std_deg", 0.0)) * units.SECONDS_PER_HOUR / span  # angle error as a mean rate
            # the horizontal Earth rate (unknown heading) turns with the body: its mean over the rotation is
            # |m| Ω_h with m = mean(exp(i φ(t))) over the angle history's shape; uniform heading ⇒ covariance
            # (Ω_h² |m|² / 2) (I − n nᵀ) (0 for a uniform full turn, up to the static value for a slow start/stop)
            phase = np.radians(theta_deg) * np.cumsum(shape) / total
            m2 = float(abs(np.mean(np.exp(1j * phase))) ** 2)
            nn = np.outer(n_axis, n_axis)
            if a is None:  # no accelerometer: the axis' tilt is unknown, the Earth rate of any direction
                var = unknown_direction_var(record, earth_rate)
                extra = sd**2 * nn + var * (nn + m2 * (np.eye(3) - nn))
            else:
                extra = sd**2 * nn + 0.5 * horizontal**2 * m2 * (np.eye(3) - nn)
            if "angle_cov_deg2" in spec:  # the angle vector's own uncertainty, deg², as a mean rate (deg/h)²
                extra = extra + np.asarray(spec["angle_cov_deg2"], dtype=float) * (units.SECONDS_PER_HOUR / span) ** 2
            out.append(
                TriadSegment(
                    "rotation",
                    name,
                    g.mean(axis=0),
                    w,
                    a_rot,
                    th,
                    temp[sel],
                    len(sel),
                    extra,
                    record.name,
                    {"angle_deg": theta_deg, "axis": n_axis.tolist(), "duration_s": span},
                )
            )
    return out, resid, mode, moves


def _move(record, spec: dict, gyro, acc, t, rows, temp) -> Move:
    """The :class:`Move` of a ``move`` segment (module doc of :mod:`gyrojax.data.triad`); ``rows`` of
    :func:`label_rows`."""
    if acc is None:
        raise ModelError(f"{record.name}: move segment {spec['label']} needs the accelerometer (acc_<c>_g columns)")

    def pose(label):
        a = acc[rows(label)]
        m = a.mean(axis=0)
        return m / np.linalg.norm(m), float(a.var(axis=0).mean()) / len(a) / float(m @ m)

    sel = rows(spec["label"])
    if len(sel) < 2:
        raise ModelError(f"{record.name}: move segment {spec['label']} has {len(sel)} sample(s)")
    u0, v0 = pose(spec["from"])
    u1, v1 = pose(spec["to"])
    # the samples of the move plus the boundary samples, so that the integration spans the whole motion
    lo, hi = max(sel[0] - 1, 0), min(sel[-1] + 2, len(t))
    dt = (t[hi - 1] - t[lo]) / max(hi - lo - 1, 1)
    name = spec.get("name", f"move-{spec['label']}")
    th = t[lo:hi] / units.SECONDS_PER_HOUR
    return Move(name, gyro[lo:hi], acc[lo:hi], float(dt), u0, u1, v0 + v1, t_h=th, temp=temp[lo:hi])
