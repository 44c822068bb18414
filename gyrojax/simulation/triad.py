"""Simulated hand calibrations of a MEMS gyro triad: a Ferraris session (six faces, three full turns) as an
``imu-triad`` record, from a per-channel truth, for Monte Carlo studies of :func:`gyrojax.inference.triad.fit_triad`.

The motion is the physics of a body on a level table (conventions §2): each face has the body axis ±e_i up and a
random heading ψ ~ U(0, 2π); its inertial rate is the Earth rate C_kᵀ Ω and its specific force C_kᵀ (0, 0, g).
Each rotation turns the body about its vertical axis e_i (face i_p) by Θ = angle + δ, δ ~ N(0, σ_Θ²), with a smooth
hand profile θ̇ ∝ sin(π t / T) whose samples sum to Θ, the Earth rate seen through the turning attitude. Gyro channels
indicate the triad model (:func:`gyrojax.physics.triad.triad_output`) plus white noise; accelerometers the true
specific force plus white noise (they are taken as calibrated).
"""

from __future__ import annotations

import math

import jax
import numpy as np

from gyrojax import units
from gyrojax.data.record import Record
from gyrojax.data.triad import triad_meta
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.physics.gravity import site_gravity

FACES = (("x_p", 0, 1.0), ("x_a", 0, -1.0), ("y_p", 1, 1.0), ("y_a", 1, -1.0), ("z_p", 2, 1.0), ("z_a", 2, -1.0))


def relative_turn(c0, c1) -> tuple[np.ndarray, float]:
    """The body-frame turn (unit axis, angle in rad, in [0, π]) that takes attitude ``c0`` to ``c1`` (body → L,
    3×3 each): c1 = c0 R(axis, angle); the axis is +z when the attitudes are equal."""
    v = so3.log(np.asarray(c0).T @ np.asarray(c1))
    a = float(np.linalg.norm(v))
    return (v / a if a > 0 else np.array([0.0, 0.0, 1.0])), a


def face_attitude(axis: int, sign: float, heading: float) -> np.ndarray:
    """Body→ENU attitude with body axis ``sign``·e_axis pointing Up, turned by ``heading`` (rad) about Up."""
    up = np.zeros(3)
    up[axis] = sign
    # a rotation taking the body's up-axis to ENU Up (0, 0, 1), then the heading about Up
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(up, z)
    c = float(up @ z)
    if np.linalg.norm(v) < 1e-12:
        base = np.eye(3) if c > 0 else so3.rotation([1.0, 0.0, 0.0], math.pi)
    else:
        base = so3.rotation(v / np.linalg.norm(v), math.acos(max(-1.0, min(1.0, c))))
    return so3.rotation(z, heading) @ base


def local_frame(latitude_deg: float, gravity_mps2: float | None, earth_rate: bool) -> tuple:
    """The Earth rate Ω (deg/h; zero without ``earth_rate``) and the specific force at rest (g) in the level frame L
    (ENU, conventions §2) at ``latitude_deg``, and the gravity (m/s²) they use: ``gravity_mps2``, or the site's normal
    gravity where it is None."""
    lat = math.radians(latitude_deg)
    omega_l = units.OMEGA_IE_DEG_PER_H * np.array([0.0, math.cos(lat), math.sin(lat)]) * float(earth_rate)
    gravity_mps2 = site_gravity(latitude_deg) if gravity_mps2 is None else gravity_mps2
    return omega_l, np.array([0.0, 0.0, gravity_mps2 / units.G0]), gravity_mps2


def session_record(name, segs, cols, notes, *, latitude_deg, fit_latitude, gravity_mps2, earth_rate) -> Record:
    """A simulated session's ``imu-triad`` record: the latitude (deg) written only with ``fit_latitude`` (else
    ``null``, unknown to the fit), the gravity used (m/s²), and whether the Earth rate is in the motion."""
    meta = triad_meta(
        name, segs, latitude_deg=latitude_deg if fit_latitude else None, gravity_mps2=gravity_mps2, notes=notes
    )
    meta["earth_rate"] = bool(earth_rate)
    return Record(meta, cols)


_triad_output_jit = jax.jit(tp.triad_output, static_argnums=0)


def turn_samples(c0, axis, angle_rad: float, n: int, dt: float, omega_l, f_l):
    """Body rate (deg/h) and specific force (g), (n, 3) each, of a turn by ``angle_rad`` about the body unit vector
    ``axis`` from attitude ``c0`` (body → L), with rate profile ∝ sin(π t / (n·dt)) scaled so that the samples sum
    to the angle exactly; each sample's attitude is that at the midpoint of its interval (dt in s). ``omega_l`` the
    Earth rate (deg/h) and ``f_l`` the specific force (g) in L."""
    t = (np.arange(n) + 0.5) * dt
    prof = np.sin(math.pi * t / (n * dt))
    rate = prof * angle_rad / (prof.sum() * dt)  # rad/s
    ang = np.cumsum(rate) * dt - 0.5 * rate * dt
    ck = np.asarray(c0) @ so3.rotation(axis, ang)
    w = np.einsum("kji,j->ki", ck, omega_l) + np.asarray(axis) * (rate / units.DEG_PER_H)[:, None]
    return w, np.einsum("kji,j->ki", ck, f_l)


def sensor_columns(model, theta, ws, fs, labels, dt, gyro_noise_dps, acc_noise_g, rng, extra=None) -> dict:
    """The CSV columns of a simulated session (``time_s`` s, ``segment``, ``gyro_*_dps`` deg/s, ``acc_*_g`` g) from
    the pieces of true body rate ``ws`` (deg/h) and specific force ``fs`` (g) with their segment labels: the triad
    model's indicated rates plus white noise, the accelerometers' true specific force plus white noise; ``extra``
    (pieces like ``ws``, deg/h) is added to the indicated rates (what the model leaves out)."""
    w = np.concatenate(ws)
    f = np.concatenate(fs)
    lab = np.concatenate(labels).astype(float)
    n = len(w)
    time_s = np.arange(n) * dt
    ind = np.asarray(_triad_output_jit(model, theta, w, f, time_s / 3600.0, np.full(n, 20.0)))
    if extra is not None:
        ind = ind + np.concatenate(extra)
    gyro_dps = ind / units.SECONDS_PER_HOUR + gyro_noise_dps * rng.standard_normal((n, 3))
    acc = f + acc_noise_g * rng.standard_normal((n, 3))
    cols = {"time_s": time_s, "segment": lab}
    for j, ch in enumerate(tp.CHANNELS):
        cols[f"gyro_{ch}_dps"] = gyro_dps[:, j]
    for j, ch in enumerate(tp.CHANNELS):
        cols[f"acc_{ch}_g"] = acc[:, j]
    return cols


def simulate_ferraris(
    truth: dict,
    *,
    terms=("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment"),
    rate_hz: float = 100.0,
    static_s: float = 5.0,
    rotation_s: float = 6.0,
    gap_s: float = 1.0,
    gyro_noise_dps: float = 0.2,
    acc_noise_g: float = 0.002,
    angle_deg: float = 360.0,
    angle_std_deg: float = 0.0,
    latitude_deg: float | None = 49.6,
    gravity_mps2: float | None = None,
    fit_latitude: bool = True,
    earth_rate: bool = True,
    seed: int = 0,
) -> Record:
    """One simulated Ferraris session (module doc) as an ``imu-triad`` record, gyro columns in deg/s.

    ``truth``: per-channel coefficients ``{"D_F[x]": deg/h, "E_SF[y]": ppm, "M_O[z]": arcsec, …}`` of ``terms``.
    ``fit_latitude``: write the latitude into the record (else ``null``: unknown to the fit). ``latitude_deg`` None
    puts the site on the equator; ``gravity_mps2`` None is the site's normal gravity (conventions §2);
    ``earth_rate=False`` leaves the Earth rate out of the motion and the record.
    Samples between segments are transitions (label −1, ``gap_s`` long, not modelled).
    """
    rng = np.random.default_rng(seed)
    model = tp.channel_model(terms)
    theta = tp.channel_theta(model, truth)
    dt = 1.0 / rate_hz
    omega_l, f_l, gravity_mps2 = local_frame(latitude_deg or 0.0, gravity_mps2, earth_rate)
    ws, fs, labels, segs = [], [], [], []

    def add(w, f, label):
        ws.append(w)
        fs.append(f)
        labels.append(np.full(len(w), label))

    n_static, n_rot, n_gap = (
        int(round(static_s * rate_hz)),
        int(round(rotation_s * rate_hz)),
        int(round(gap_s * rate_hz)),
    )
    label = 0
    for name, axis, sign in FACES:
        c = face_attitude(axis, sign, rng.uniform(0, 2 * math.pi))
        add(np.tile(c.T @ omega_l, (n_static, 1)), np.tile(c.T @ f_l, (n_static, 1)), label)
        segs.append({"label": label, "type": "static", "name": name})
        add(np.tile(c.T @ omega_l, (n_gap, 1)), np.tile(c.T @ f_l, (n_gap, 1)), -1)
        label += 1
    for axis, ch in enumerate(tp.CHANNELS):
        c0 = face_attitude(axis, 1.0, rng.uniform(0, 2 * math.pi))
        e = np.zeros(3)
        e[axis] = 1.0
        total = math.radians(angle_deg + angle_std_deg * rng.standard_normal())
        add(*turn_samples(c0, e, total, n_rot, dt, omega_l, f_l), label)
        segs.append(
            {
                "label": label,
                "type": "rotation",
                "name": f"{ch}_rot",
                "axis": ch,
                "angle_deg": angle_deg,
                "angle_std_deg": angle_std_deg,
            }
        )
        add(np.tile(c0.T @ omega_l, (n_gap, 1)), np.tile(c0.T @ f_l, (n_gap, 1)), -1)
        label += 1
    cols = sensor_columns(model, theta, ws, fs, labels, dt, gyro_noise_dps, acc_noise_g, rng)
    notes = "simulated Ferraris session (gyrojax.simulation.triad)"
    where = {"latitude_deg": latitude_deg, "fit_latitude": fit_latitude, "earth_rate": earth_rate}
    return session_record(f"ferraris-sim-{seed}", segs, cols, notes, gravity_mps2=gravity_mps2, **where)


def random_attitude(rng) -> np.ndarray:
    """A rotation matrix drawn uniformly (a normalised Gaussian quaternion)."""
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def simulate_multiposition(
    truth: dict,
    *,
    poses: int = 12,
    terms=("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment"),
    rate_hz: float = 100.0,
    static_s=4.0,
    move_s=2.0,
    init_s: float = 0.0,
    gyro_noise_dps: float = 0.05,
    acc_noise_g: float = 0.001,
    latitude_deg: float = 49.6,
    gravity_mps2: float | None = None,
    earth_rate: bool = True,
    fit_latitude: bool = False,
    move_error_deg: float = 0.0,
    bias_step_dph: float = 0.0,
    seed: int = 0,
) -> Record:
    """An imu_tk-style session as an ``imu-triad`` record: ``poses`` static poses of random attitude, each joined to
    the next by a gravity-to-gravity ``move`` segment (a turn about the fixed body axis that takes one attitude to
    the next, rate profile ∝ sin(π t / T) whose samples sum to the angle). Gyro channels indicate the triad model
    plus white noise (deg/s); accelerometers the true specific force (g) plus white noise. ``earth_rate=False``
    leaves the Earth rate out of the motion and the record (for exact round trips); ``fit_latitude`` writes the
    site latitude into the record (else ``null``: unknown to the fit). What the model leaves out, as hand sessions
    have it: ``move_error_deg`` an angle error of each move (N(0, σ²) about each body axis, an indicated rate
    over the move's last 5 %, where the body has nearly stopped, so that it is δφ in the final attitude) and
    ``bias_step_dph`` a bias step at each move (a new level N(0, σ²) per channel about the truth's bias, held from
    the move through the next pose; deg/h). Times in s (``static_s`` and
    ``move_s`` one duration, or one per pose and per move), latitude in deg, ``gravity_mps2`` None the site's normal
    gravity (conventions §2)."""
    rng = np.random.default_rng(seed)
    model = tp.channel_model(terms)
    theta = tp.channel_theta(model, truth)
    dt = 1.0 / rate_hz
    omega_l, f_l, gravity_mps2 = local_frame(latitude_deg, gravity_mps2, earth_rate)
    atts = [random_attitude(rng) for _ in range(poses)]
    ws, fs, labels, segs, extra = [], [], [], [], []
    step = np.zeros(3)
    n_static = np.broadcast_to(np.round(np.asarray(static_s, dtype=float) * rate_hz).astype(int), (poses,))
    n_moves = np.broadcast_to(np.round(np.asarray(move_s, dtype=float) * rate_hz).astype(int), (max(poses - 1, 1),))
    for k, c in enumerate(atts):
        n = int(n_static[k]) + (int(round(init_s * rate_hz)) if k == 0 else 0)
        ws.append(np.tile(c.T @ omega_l, (n, 1)))
        fs.append(np.tile(c.T @ f_l, (n, 1)))
        labels.append(np.full(n, 2 * k))
        extra.append(np.tile(step, (n, 1)))
        segs.append({"label": 2 * k, "type": "static", "name": f"pose-{k}"})
        if k + 1 == poses:
            break
        axis, angle = relative_turn(c, atts[k + 1])
        w, f = turn_samples(c, axis, angle, int(n_moves[k]), dt, omega_l, f_l)
        ws.append(w)
        fs.append(f)
        labels.append(np.full(int(n_moves[k]), 2 * k + 1))
        if bias_step_dph:  # a new bias level, independent of the last, from this move on
            step = bias_step_dph * rng.standard_normal(3)
        nm = int(n_moves[k])
        burst = np.zeros((nm, 3))
        if move_error_deg:  # over the last 5 % of the move, where the body has nearly stopped: δφ in the end frame
            tail = max(nm // 20, 1)
            burst[-tail:] = move_error_deg * rng.standard_normal(3) * units.SECONDS_PER_HOUR / (tail * dt)
        extra.append(step + burst)
        segs.append({"label": 2 * k + 1, "type": "move", "name": f"move-{k}-{k + 1}", "from": 2 * k, "to": 2 * k + 2})
    cols = sensor_columns(model, theta, ws, fs, labels, dt, gyro_noise_dps, acc_noise_g, rng, extra)
    notes = "simulated multi-position session with gravity-to-gravity moves (gyrojax.simulation.triad)"
    where = {"latitude_deg": latitude_deg, "fit_latitude": fit_latitude, "earth_rate": earth_rate}
    return session_record(f"multiposition-sim-{seed}", segs, cols, notes, gravity_mps2=gravity_mps2, **where)
