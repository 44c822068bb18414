"""An independent writer of ``imu-triad`` hand sessions for tests: plain numpy + scipy, written from conventions §1–§4,
§6 and §9.3 alone, sharing no code with gyrojax (no kinematics, effects, noise, simulator or record writer of the
package), so that the triad diagnosis is judged on sessions its own simulator did not make.

**Motion** (imu_tk-style, §9.3 ``move`` segments). ``poses`` rests at attitudes drawn uniformly on SO(3) (C_k: body
→ L, ENU; heading random, so the horizontal Earth rate is unknown to a fit). Between rests k and k + 1 the body turns
about the fixed body axis n by φ, C_{k+1} = C_k exp([n×] φ) (scipy's rotation vector of C_kᵀ C_{k+1}); the rate
relative to L is n φ̇(t), φ̇ sampled as sin(π j/(N + 1)) (j = 1 … N, zero at the rests on either side) and taken
piecewise linear between samples, scaled so that its integral (the trapezoid of the samples) is φ exactly. The
gyros sense the inertial rate ω = n φ̇ + C(t)ᵀ Ω (§2: Ω = ω_ie (0, cos φ_lat, sin φ_lat)), the accelerometers the
specific force a = C(t)ᵀ (0, 0, g_site)/g0 (§2, §1; the hand's own acceleration ignored as §3 ignores lever arms).
The first 0.2 s of every rest after a move are transition samples (label −1, ignored by the fit: §9.3).

**Gyro model** (§9.3 matrix form, channels as SDF gyros with (IA, OA, SA) = (x, y, z), (y, z, x), (z, x, y)):
ω_ind = S ω + G a + b + d(t) + white, S row c: 1 + E_SF at IA(c), M_O (rad) at OA(c), M_S (rad) at SA(c); G row c:
D_I, D_O, D_S likewise; b = D_F. Every rate in deg/h, a in g.

**Drift between poses** d(t), per channel, independent between channels (what a hand session does to a MEMS bias):

* ``"scatter"``: a new level N(0, σ²) from each move on, independent of the last — the per-pose bias scatter that
  gyrojax's triad fit assumes (``pose_bias_scatter``, §9.3);
* ``"steps"``: a step N(0, σ²) at each move that persists (a shock at handling): the level at rest k is the sum of
  k steps, a random walk in the pose index, Cov(b_k, b_l) = σ² min(k, l);
* ``"rrw"``: a rate random walk K (deg/h/√h) through the whole session (§6 ``random_walk``), Cov(b(s), b(t)) = K²
  min(s, t) (s, t in h from the session's start);
* ``trend``: D_T · time_s/3600 per channel (§6 ``bias_trend``).

**Power-ups** (:func:`power_ups`): two records of one ``instrument.id`` on one clock (§5: records of a campaign
share it), the second's bias higher by ``step`` (deg/h per channel): §9.3's ``bias_turn_on[<channel>]``
(``D_F_step_1``, the bias of record 2 less that of record 1).

Each generator returns its records in memory (:class:`SessionRecord`; :func:`write` puts them in files, and
:func:`hand_session`, :func:`power_ups` do both) and the truth: every coefficient as ``<coefficient>[<channel>]``
(report units, §6/§9.3), the drift's kind and size, the realised drift level at each rest (deg/h,
``drift_at_rest``) and the noise.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

G0 = 9.80665  # §1
WIE_DPH = 7.2921150e-5 * 180 / np.pi * 3600  # §1: the Earth rate, deg/h
ARCSEC = np.pi / 180 / 3600
CHANNELS = ("x", "y", "z")
AXES = {"x": (0, 1, 2), "y": (1, 2, 0), "z": (2, 0, 1)}  # §9.3: (IA, OA, SA) of each channel
LATITUDE_DEG, GRAVITY = 47.4, 9.8077

BASE = {  # a MEMS triad of tactical-to-consumer size (report units of §6)
    "D_F[x]": 420.0,
    "D_F[y]": -310.0,
    "D_F[z]": 150.0,
    "D_I[x]": 30.0,
    "D_O[x]": -20.0,
    "D_S[x]": 12.0,
    "D_I[y]": -25.0,
    "D_O[y]": 18.0,
    "D_S[y]": 40.0,
    "D_I[z]": 10.0,
    "D_O[z]": -35.0,
    "D_S[z]": 22.0,
    "E_SF[x]": 3000.0,
    "E_SF[y]": -2000.0,
    "E_SF[z]": 1500.0,
    "M_O[x]": 900.0,
    "M_S[x]": -1400.0,
    "M_O[y]": 600.0,
    "M_S[y]": 1100.0,
    "M_O[z]": -800.0,
    "M_S[z]": 500.0,
}
MODEL = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")
"""The linear triad model the sessions are fitted with (every coefficient of :data:`BASE`)."""


def matrices(truth: dict):
    """(S, G, b) of §9.3's matrix form from ``<coefficient>[<channel>]`` values (deg/h, deg/h/g, ppm, arcsec)."""
    s, g, b = np.eye(3), np.zeros((3, 3)), np.zeros(3)
    for r, c in enumerate(CHANNELS):
        i, o, sa = AXES[c]
        k = lambda name, c=c: truth.get(f"{name}[{c}]", 0.0)  # noqa: E731
        s[r, i] += k("E_SF") * 1e-6
        s[r, o] += k("M_O") * ARCSEC
        s[r, sa] += k("M_S") * ARCSEC
        g[r, i], g[r, o], g[r, sa] = k("D_I"), k("D_O"), k("D_S")
        b[r] = k("D_F")
    return s, g, b


def _move(c0, c1, n, dt, omega_l, f_l):
    """Body rates (deg/h, inertial) and specific force (g) of N samples of the fixed-axis turn from C0 to C1."""
    rv = Rotation.from_matrix(c0.T @ c1).as_rotvec()
    phi = float(np.linalg.norm(rv))
    axis = rv / phi if phi > 0 else np.array([0.0, 0.0, 1.0])
    prof = np.sin(np.pi * np.arange(1, n + 1) / (n + 1))
    rate = prof * phi / (prof.sum() * dt)  # rad/s; trapezoid with zero ends = the sum: ∫ = φ exactly
    padded = np.concatenate([[0.0], rate])
    angle = np.cumsum(0.5 * (padded[1:] + padded[:-1]) * dt)  # φ(t_j), the piecewise-linear rate integrated
    att = Rotation.from_matrix(c0) * Rotation.from_rotvec(np.outer(angle, axis))  # C(t_j) = C0 exp([n×] φ_j)
    mats = att.as_matrix()
    w = np.outer(rate, axis) * (180 / np.pi * 3600) + np.einsum("nji,j->ni", mats, omega_l)
    return w, np.einsum("nji,j->ni", mats, f_l)


def session_columns(
    rng,
    truth: dict,
    *,
    poses: int,
    rest_s: float,
    move_s: float,
    rate_hz: float,
    drift: str | None,
    drift_size: float,
    gyro_noise_dps: float,
    acc_noise_g: float,
    latitude_deg: float,
    t0: float,
    transition_s: float = 0.2,
):
    """The columns, segment list and drift levels of one session (module doc); ``truth`` may hold ``D_T[c]``."""
    dt = 1.0 / rate_hz
    lat = np.radians(latitude_deg)
    omega_l = WIE_DPH * np.array([0.0, np.cos(lat), np.sin(lat)])
    f_l = np.array([0.0, 0.0, GRAVITY / G0])
    atts = Rotation.random(poses, random_state=rng).as_matrix()
    n_rest, n_move, n_tr = round(rest_s * rate_hz), round(move_s * rate_hz), round(transition_s * rate_hz)
    ws, fs, labels, blocks, segments = [], [], [], [], []
    # the "steps" or "scatter" drift level (deg/h) of the current pose; a walk starts at 0 (D_F holds the start)
    level = drift_size * rng.standard_normal(3) if drift == "scatter" else np.zeros(3)
    for k in range(poses):
        if k:
            w, f = _move(atts[k - 1], atts[k], n_move, dt, omega_l, f_l)
            if drift == "steps":
                level = level + drift_size * rng.standard_normal(3)
            elif drift == "scatter":
                level = drift_size * rng.standard_normal(3)
            ws.append(w)
            fs.append(f)
            labels.append(np.full(n_move, 1000 + k))
            blocks.append(np.tile(level, (n_move, 1)))
            segments.append({"label": 1000 + k, "type": "move", "name": f"turn-{k}", "from": 10 + k - 1, "to": 10 + k})
        n = n_rest + (n_tr if k else 0)
        ws.append(np.tile(atts[k].T @ omega_l, (n, 1)))
        fs.append(np.tile(atts[k].T @ f_l, (n, 1)))
        lab = np.full(n, 10 + k)
        lab[: n - n_rest] = -1
        labels.append(lab)
        blocks.append(np.tile(level, (n, 1)))
        segments.append({"label": 10 + k, "type": "static", "name": f"rest-{k}"})
    w, f, lab, d = (np.concatenate(x) for x in (ws, fs, labels, blocks))
    t = t0 + dt * np.arange(len(lab))
    if drift == "rrw":  # K (deg/h/√h): increments N(0, K² dt_h), the walk 0 at the first sample
        d = np.zeros((len(t), 3))
        d[1:] = np.cumsum(drift_size * np.sqrt(dt / 3600.0) * rng.standard_normal((len(t) - 1, 3)), axis=0)
    s, g, b = matrices(truth)
    trend = np.array([truth.get(f"D_T[{c}]", 0.0) for c in CHANNELS])
    gyro = w @ s.T + f @ g.T + b + d + np.outer(t / 3600.0, trend)
    gyro += gyro_noise_dps * 3600.0 * rng.standard_normal(gyro.shape)
    acc = f + acc_noise_g * rng.standard_normal(f.shape)
    cols = {"time_s": t, "segment": lab}
    cols |= {f"gyro_{c}_dps": gyro[:, i] / 3600.0 for i, c in enumerate(CHANNELS)}
    cols |= {f"acc_{c}_g": acc[:, i] for i, c in enumerate(CHANNELS)}
    rests = [s_["label"] for s_ in segments if s_["type"] == "static"]
    at_rest = np.array([d[lab == r].mean(axis=0) for r in rests])
    return cols, segments, at_rest, atts


@dataclass
class SessionRecord:
    """One record in memory: its JSON (``meta``) and columns (name → array), as §5 and §9.3 write them."""

    meta: dict
    columns: dict


def record(name, cols, segments, *, instrument_id, latitude_deg) -> SessionRecord:
    """The record of §9.3 (JSON and columns) of one session."""
    meta = {
        "format": "gyrojax-record-1",
        "name": name,
        "site": {"latitude_deg": latitude_deg, "gravity_mps2": GRAVITY},
        "instrument": {"kind": "imu-triad", "channels": list(CHANNELS), "id": instrument_id},
        "earth_rate": True,
        "segments": segments,
        "writer": "tests/independent_triad_writer.py",
    }
    return SessionRecord(meta, cols)


def write(folder, records) -> list:
    """``NAME.csv`` + ``NAME.json`` of each record in ``folder``; returns the JSON paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    keys = ["time_s", "segment"] + [f"gyro_{c}_dps" for c in CHANNELS] + [f"acc_{c}_g" for c in CHANNELS]
    paths = []
    for rec in records:
        name, cols = rec.meta["name"], rec.columns
        lines = [",".join(keys)]
        for row in zip(*(cols[k] for k in keys)):
            lines.append(f"{row[0]:.5f},{int(row[1])}," + ",".join(f"{v:.10e}" for v in row[2:]))
        (folder / f"{name}.csv").write_text("\n".join(lines) + "\n")
        (folder / f"{name}.json").write_text(json.dumps(rec.meta))
        paths.append(folder / f"{name}.json")
    return paths


def hand_session_records(
    seed: int,
    *,
    poses: int = 40,
    rest_s: float = 4.0,
    move_s: float = 2.0,
    rate_hz: float = 100.0,
    drift: str | None = "steps",
    drift_size: float = 20.0,
    trend: dict | None = None,
    gyro_noise_dps: float = 0.05,
    acc_noise_g: float = 0.001,
    latitude_deg: float = LATITUDE_DEG,
):
    """One hand session (module doc): ``drift`` ``"steps"``, ``"rrw"``, ``"scatter"`` or None, of size
    ``drift_size`` (deg/h per move; deg/h/√h for ``"rrw"``), ``trend`` {channel: D_T deg/h/h}. Returns
    ([SessionRecord], truth)."""
    rng = np.random.default_rng(seed)
    truth = dict(BASE) | {f"D_T[{c}]": v for c, v in (trend or {}).items()}
    cols, segs, at_rest, atts = session_columns(
        rng,
        truth,
        poses=poses,
        rest_s=rest_s,
        move_s=move_s,
        rate_hz=rate_hz,
        drift=drift,
        drift_size=drift_size,
        gyro_noise_dps=gyro_noise_dps,
        acc_noise_g=acc_noise_g,
        latitude_deg=latitude_deg,
        t0=7.5,
    )
    rec = record(f"hand-{drift or 'white'}-{seed}", cols, segs, instrument_id="IMU-43", latitude_deg=latitude_deg)
    return [rec], {
        "coefficients": truth,
        "drift": drift,
        "drift_size": drift_size,
        "drift_at_rest": at_rest,
        "gyro_noise_dps": gyro_noise_dps,
        "rate_hz": rate_hz,
        "latitude_deg": latitude_deg,
        "attitudes": atts,
    }


def hand_session(folder, seed: int, **kw):
    """:func:`hand_session_records` written to ``folder``: (JSON path, truth)."""
    recs, truth = hand_session_records(seed, **kw)
    return write(folder, recs)[0], truth


def power_up_records(
    seed: int,
    *,
    step: dict | None = None,
    poses: int = 20,
    gap_s: float = 900.0,
    scatter_dph: float = 10.0,
    rest_s: float = 4.0,
    move_s: float = 2.0,
    rate_hz: float = 100.0,
    gyro_noise_dps: float = 0.05,
    acc_noise_g: float = 0.001,
    latitude_deg: float = LATITUDE_DEG,
    drift: str = "scatter",
):
    """Two power-ups of one IMU (module doc): two records of ``instrument.id`` "IMU-43" on one clock, ``gap_s`` apart,
    each a hand session with per-pose bias scatter ``scatter_dph`` (deg/h; with ``drift`` "steps" or "rrw" a walk of
    that size instead, each power-up's from its own turn-on bias); the second's bias higher by ``step``
    {channel: deg/h}. Returns ([SessionRecord] × 2, truth) with ``D_F_step_1[c]`` in the truth."""
    rng = np.random.default_rng(seed)
    step = step or {}
    recs, at_rest, t0 = [], [], 3.0
    for k in range(2):
        truth = dict(BASE)
        if k:
            truth |= {f"D_F[{c}]": BASE[f"D_F[{c}]"] + step.get(c, 0.0) for c in CHANNELS}
        cols, segs, lev, _ = session_columns(
            rng,
            truth,
            poses=poses,
            rest_s=rest_s,
            move_s=move_s,
            rate_hz=rate_hz,
            drift=drift,
            drift_size=scatter_dph,
            gyro_noise_dps=gyro_noise_dps,
            acc_noise_g=acc_noise_g,
            latitude_deg=latitude_deg,
            t0=t0,
        )
        recs.append(record(f"powerup-{seed}-{k + 1}", cols, segs, instrument_id="IMU-43", latitude_deg=latitude_deg))
        at_rest.append(lev)
        t0 = float(cols["time_s"][-1]) + gap_s
    truth = dict(BASE) | {f"D_F_step_1[{c}]": step.get(c, 0.0) for c in CHANNELS}
    return recs, {
        "coefficients": truth,
        "drift": drift,
        "drift_size": scatter_dph,
        "drift_at_rest": np.vstack(at_rest),
        "gyro_noise_dps": gyro_noise_dps,
        "rate_hz": rate_hz,
        "latitude_deg": latitude_deg,
    }


def power_ups(folder, seed: int, **kw):
    """:func:`power_up_records` written to ``folder``: ([JSON paths], truth)."""
    recs, truth = power_up_records(seed, **kw)
    return write(folder, recs), truth
