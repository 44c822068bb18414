"""A hand calibration of a MEMS gyro triad that follows a written protocol: rests, and the turns a person makes
between them, as an ``imu-triad`` record (the session plan of ``gyrojax design --instrument imu-triad``).

A protocol's ``steps`` are plain dicts, in order (angles in deg, times in s, axes unit vectors in the body frame):

* ``{"type": "rest", "rest_s": T}`` — the box at rest (a ``static`` segment of the record);
* ``{"type": "move", "axis": n, "angle_deg": Φ, "duration_s": T}`` — a turn by Φ about the body axis n between two
  rests, fitted from the Up directions before and after (gravity to gravity, imu_tk);
* ``{"type": "turn", …}`` — the same, fitted as a rotation of a known angle Φ about a body axis (imucal's hand
  turns; the axis must be ±x, ±y or ±z);
* ``{"type": "reorient", …}`` — the same, not fitted (the record labels it −1): Ferraris' flips between faces.

The person aims at the planned attitudes and misses each by ``placement_deg`` (N(0, σ²) about each body axis): a
move or a reorientation ends at the planned attitude times that error, seen by the gyro and the accelerometer; a
known-angle turn turns by Φ + ε with ε ~ N(0, 2σ²) (the mark is placed at its start and its end), declared as the
rotation's ``angle_std_deg`` = √2 σ. Every motion has the rate profile ∝ sin(π t / T) of
:func:`gyrojax.simulation.triad.turn_samples`; the correction of a placement error is a second such turn over
the motion's last 5 %. The channels indicate the triad model plus white noise (deg/s), the accelerometers the true
specific force plus white noise (g). ``heading_deg`` None draws the session's heading uniformly (a hand session's
heading is unknown).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.data.record import Record
from gyrojax.errors import ModelError
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.simulation.triad import local_frame, sensor_columns, session_record, turn_samples

STEP_TYPES = ("rest", "move", "turn", "reorient")
AXIS_NAMES = {(1, 0, 0): "x", (-1, 0, 0): "-x", (0, 1, 0): "y", (0, -1, 0): "-y", (0, 0, 1): "z", (0, 0, -1): "-z"}


def body_axis_name(axis) -> str:
    """``"x"``, ``"-y"``, … for a body axis along ±e_i (a known-angle turn needs one; its angle in deg);
    :class:`ModelError` else."""
    key = tuple(int(round(float(x))) for x in axis)
    if key not in AXIS_NAMES or np.max(np.abs(np.asarray(axis, dtype=float) - np.asarray(key))) > 1e-9:
        raise ModelError(f"a known-angle turn is about a body axis ±x, ±y or ±z; got {list(axis)}")
    return AXIS_NAMES[key]


def check_steps(steps) -> None:
    """Refuse a protocol whose steps cannot be run: unknown types, non-positive times, a first or last step that
    is not a rest, a move not between two rests; times in s; the message names the step."""
    if not steps or steps[0].get("type") != "rest" or steps[-1].get("type") != "rest":
        raise ModelError("a protocol starts and ends with a rest")
    for i, s in enumerate(steps):
        kind = s.get("type")
        if kind not in STEP_TYPES:
            raise ModelError(f"step {i}: type {kind!r} is not one of {', '.join(STEP_TYPES)}")
        key = "rest_s" if kind == "rest" else "duration_s"
        if not (isinstance(s.get(key), (int, float)) and 0 < float(s[key]) < math.inf):
            raise ModelError(f"step {i} ({kind}): {key} must be a positive number, got {s.get(key)!r}")
        if kind == "move" and not (steps[i - 1]["type"] == "rest" and steps[i + 1]["type"] == "rest"):
            raise ModelError(f"step {i}: a move is fitted from the rests on both sides; put a rest before and after")


def simulate_session(
    steps,
    truth: dict,
    *,
    start_attitude=None,
    terms=("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment"),
    rate_hz: float = 100.0,
    gyro_noise_dps: float = 0.2,
    acc_noise_g: float = 0.002,
    placement_deg: float = 0.0,
    latitude_deg: float = 49.6,
    gravity_mps2: float | None = None,
    earth_rate: bool = True,
    fit_latitude: bool = False,
    heading_deg: float | None = None,
    seed: int = 0,
) -> Record:
    """One simulated session of a protocol (module doc) as an ``imu-triad`` record.

    ``truth`` per-channel coefficients ``{"D_F[x]": deg/h, "E_SF[y]": ppm, "M_O[z]": arcsec, …}``;
    ``start_attitude`` the first rest's body → ENU attitude (3×3, default: z up) before the heading; ``fit_latitude``
    writes the latitude into the record (else ``null``); ``gravity_mps2`` None is the site's normal gravity (conventions
    §2); ``earth_rate=False`` leaves the Earth rate out of the
    motion and the record."""
    check_steps(steps)
    rng = np.random.default_rng(seed)
    model = tp.channel_model(terms)
    theta = tp.channel_theta(model, truth)
    dt = 1.0 / rate_hz
    omega_l, f_l, gravity_mps2 = local_frame(latitude_deg, gravity_mps2, earth_rate)
    psi = math.radians(heading_deg) if heading_deg is not None else rng.uniform(0.0, 2.0 * math.pi)
    c0 = np.eye(3) if start_attitude is None else np.asarray(start_attitude, dtype=float)
    plan = so3.rotation([0.0, 0.0, 1.0], psi) @ c0  # the attitude the person aims at
    act = plan @ so3.rotation(rng.standard_normal(3), math.radians(placement_deg)) if placement_deg else plan
    sig = math.radians(placement_deg)
    ws, fs, labels, segs = [], [], [], []
    k_rest = 0
    for i, s in enumerate(steps):
        kind = s["type"]
        if kind == "rest":
            n = max(2, int(round(float(s["rest_s"]) * rate_hz)))
            lab = i
            ws.append(np.tile(act.T @ omega_l, (n, 1)))
            fs.append(np.tile(act.T @ f_l, (n, 1)))
            labels.append(np.full(n, lab))
            segs.append({"label": lab, "type": "static", "name": f"rest-{k_rest}"})
            k_rest += 1
            continue
        axis = np.asarray(s["axis"], dtype=float)
        axis = axis / np.linalg.norm(axis)
        phi = math.radians(float(s["angle_deg"]))
        n = max(4, int(round(float(s["duration_s"]) * rate_hz)))
        lab = i if kind != "reorient" else -1
        if kind == "turn":
            extra = math.sqrt(2.0) * sig * rng.standard_normal()
            w, f = turn_samples(act, axis, phi + extra, n, dt, omega_l, f_l)
            act = act @ so3.rotation(axis, phi + extra)
            plan = plan @ so3.rotation(axis, phi)
            segs.append(
                {
                    "label": lab,
                    "type": "rotation",
                    "name": f"turn-{k_rest - 1}",
                    "axis": body_axis_name(axis),
                    "angle_deg": abs(float(s["angle_deg"])),
                    "angle_std_deg": math.sqrt(2.0) * placement_deg,
                }
            )
        else:
            plan = plan @ so3.rotation(axis, phi)
            target = plan @ so3.rotation(rng.standard_normal(3), sig) if sig else plan
            err = so3.log((act @ so3.rotation(axis, phi)).T @ target)
            tail = max(n // 20, 2) if sig else 0
            w, f = turn_samples(act, axis, phi, n - tail, dt, omega_l, f_l)
            mid = act @ so3.rotation(axis, phi)
            if tail:
                e = float(np.linalg.norm(err))
                w2, f2 = turn_samples(mid, err / e if e > 0 else axis, e, tail, dt, omega_l, f_l)
                w, f = np.concatenate([w, w2]), np.concatenate([f, f2])
            act = target if sig else mid
            if kind == "move":
                k = k_rest - 1
                segs.append({"label": lab, "type": "move", "name": f"move-{k}-{k + 1}", "from": i - 1, "to": i + 1})
        ws.append(w)
        fs.append(f)
        labels.append(np.full(len(w), lab))
    cols = sensor_columns(model, theta, ws, fs, labels, dt, gyro_noise_dps, acc_noise_g, rng)
    notes = "simulated hand session of a protocol (gyrojax.simulation.triad_session)"
    where = {"latitude_deg": latitude_deg, "fit_latitude": fit_latitude, "earth_rate": earth_rate}
    return session_record(f"protocol-sim-{seed}", segs, cols, notes, gravity_mps2=gravity_mps2, **where)
