"""A turntable data system's logs, written from the conventions alone (plain numpy; no gyrojax import).

What a rate table or a position table's data system writes, not what gyrojax reads: its own column names, a clock in
integer milliseconds (or microseconds, or ISO 8601 date-times), the table angle as encoder counts that wrap at one
revolution (or degrees, or radians) and optionally the table rate, the instrument's output as volts at a nominal
scale, torquer current, pulse counts per interval or a rate, a temperature column, and optionally the instrument on a
second data system with a clock of its own. The physics is conventions §2–§4 and §6 written out again here:

* L is ENU, Ω = ω_ie (0, cos φ, sin φ), the specific force at rest (0, 0, g_site);
* C(θ) = R(u_1, θ_1)⋯R(u_k, θ_k), ω_LP = Σ θ̇_i R(u_1, θ_1)⋯R(u_{i−1}, θ_{i−1}) u_i, ω_IP = Ω + ω_LP;
* inputs ω_I = (C IA)·ω_IP, a_I = (C IA)·f / g0 (and O, S; TDF X, Y, Z; accelerometer I, P, O);
* the balance equations of §4 with the effects of §6 (deg/h; ppm; arcsec; deg/h/g; deg/h per °C).

The table moves with constant accelerations between holds (``acc_dps2``): a schedule of positions (``("position",
angles_deg, dwell_s)``, the axes moved one after the other) and rate steps (``("rate", rates_dps, duration_s)``); the
true angles and rates are exact (piecewise quadratic) and the phase of every instant is kept (``label``), so a test
can check what the importer detects. A servo run (``servo=True``) lets the table's single axis (∥ IA) turn so that
the untorqued gyro's balance equation holds, θ̇ = −Ω·IA_L − (drift)/(1 + E_SF) (Hu 3-59), integrated by RK4.
"""

from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path

import numpy as np

G0 = 9.80665
WIE = 7.2921150e-5
D2R = np.pi / 180.0
ARCSEC = D2R / 3600.0
DPH = D2R / 3600.0  # 1 deg/h in rad/s


def rot(u, th):
    """Rotation matrices (n, 3, 3) about the unit vector ``u`` by the angles ``th`` (n,) rad (right-hand rule)."""
    u = np.asarray(u, float)
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    th = np.asarray(th, float)[:, None, None]
    return np.eye(3) + np.sin(th) * k + (1 - np.cos(th)) * (k @ k)


def phases(schedule, n_axes, acc_dps2=40.0, slew_dps=60.0):
    """Constant-acceleration phases of a schedule: list of (t0, duration, θ0 (k,), ω0 (k,), α (k,), label), deg."""
    out, t, th, om = [], 0.0, np.zeros(n_axes), np.zeros(n_axes)

    def add(dur, alpha, label):
        nonlocal t, th, om
        if dur <= 0:
            return
        out.append((t, dur, th.copy(), om.copy(), np.asarray(alpha, float), label))
        th = th + om * dur + 0.5 * np.asarray(alpha) * dur**2
        om = om + np.asarray(alpha) * dur
        t += dur

    for k, (kind, values, dur) in enumerate(schedule):
        values = np.asarray(values, float)
        if kind == "rate":
            dmax = np.max(np.abs(values - om))
            if dmax > 0:
                tr = dmax / acc_dps2
                add(tr, (values - om) / tr, "transition")
            add(dur, np.zeros(n_axes), f"rate-{k}")
        else:
            if np.any(om != 0):
                tr = np.max(np.abs(om)) / acc_dps2
                add(tr, -om / tr, "transition")
            for i in range(n_axes):  # each axis in turn: accelerate, slew, brake
                d = values[i] - th[i]
                if d == 0:
                    continue
                s = np.sign(d)
                t_acc = min(slew_dps / acc_dps2, np.sqrt(abs(d) / acc_dps2))
                cruise = (abs(d) - acc_dps2 * t_acc**2) / (acc_dps2 * t_acc)
                a = np.zeros(n_axes)
                a[i] = s * acc_dps2
                add(t_acc, a, "transition")
                add(cruise, np.zeros(n_axes), "transition")
                add(t_acc, -a, "transition")
                th[i] = values[i]  # no rounding drift
            add(dur, np.zeros(n_axes), f"position-{k}")
    return out, t


def motion(ph, t):
    """True table angles and rates (n, k) deg, deg/s, and the phase label of each instant ``t`` (n,) s."""
    starts = np.array([p[0] for p in ph])
    idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(ph) - 1)
    th = np.empty((len(t), len(ph[0][2])))
    om = np.empty_like(th)
    for j, (t0, _dur, th0, om0, al, _lab) in enumerate(ph):
        sel = idx == j
        tau = (t[sel] - t0)[:, None]
        th[sel] = th0 + om0 * tau + 0.5 * al * tau**2
        om[sel] = om0 + al * tau
    return th, om, np.array([ph[j][5] for j in idx])


def platform_inputs(axes, th_deg, om_dps, lat_deg, g_site):
    """Inertial rate (rad/s) and specific force (m/s²) in platform coordinates, (n, 3) each (conventions §3)."""
    lat = lat_deg * D2R
    omega = WIE * np.array([0.0, np.cos(lat), np.sin(lat)])
    n = len(th_deg)
    c = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    w_lp = np.zeros((n, 3))
    for i, u in enumerate(axes):
        w_lp += (om_dps[:, i] * D2R)[:, None] * (c @ np.asarray(u, float))
        c = c @ rot(u, th_deg[:, i] * D2R)
    w_p = np.einsum("nji,nj->ni", c, omega + w_lp)
    f_p = np.einsum("nji,j->ni", c, np.array([0.0, 0.0, g_site]))
    return w_p, f_p


def sdf_rate(tr, wi, wo, ws, ai, ao, as_, t_s, temp, optical=False):
    """Indicated rate (deg/h) of an SDF or optical gyro from its inputs (deg/h, g), conventions §4 and §6."""
    v = (1 + tr.get("E_SF", 0) * 1e-6) * wi + (tr.get("M_O", 0) * wo + tr.get("M_S", 0) * ws) * ARCSEC
    v = v + tr.get("D_F", 0) + tr.get("E_A", 0) * 1e-6 * np.abs(wi) + tr.get("E_2", 0) * 1e-6 * wi * wi / 3600
    v = v + tr.get("D_T", 0) * t_s / 3600 + tr.get("D_TEMP", 0) * (temp - 20.0)
    if not optical:
        v = v + tr.get("D_I", 0) * ai + tr.get("D_O", 0) * ao + tr.get("D_S", 0) * as_
        v = v + tr.get("D_II", 0) * ai**2 + tr.get("D_OO", 0) * ao**2 + tr.get("D_SS", 0) * as_**2
        v = v + tr.get("D_IO", 0) * ai * ao + tr.get("D_IS", 0) * ai * as_ + tr.get("D_OS", 0) * ao * as_
    return v


def tdf_rates(tr, w, a):
    """Indicated rates (n, 2) deg/h of a TDF gyro's X, Y channels: ω_c + DC_F + DC_X a_X + … (Hu 2-45/2-46)."""
    names = ("X", "Y", "Z")
    out = []
    for c, ch in enumerate(("X", "Y")):
        v = w[:, c] + tr.get(f"D{ch}_F", 0)
        for j, nj in enumerate(names):
            v = v + tr.get(f"D{ch}_{nj}", 0) * a[:, j]
        for j in range(3):
            for k in range(j, 3):
                v = v + tr.get(f"D{ch}_{names[j]}{names[k]}", 0) * a[:, j] * a[:, k]
        out.append(v)
    return np.stack(out, axis=1)


def accel_output(tr, ai, ap, ao):
    """Indicated acceleration (g) of a pendulous accelerometer, Hu 3-38 in the conventions' axis names."""
    v = tr.get("K_0", 0) + tr.get("K_1", 1.0) * ai + tr.get("K_2", 0) * ai**2 + tr.get("K_3", 0) * ai**3
    return v + tr.get("K_IP", 0) * ai * ap + tr.get("K_IO", 0) * ai * ao


def servo_angles(t, u, ia, oa, tr, lat_deg, g_site, step_s=5.0):
    """Angle (deg) and rate (deg/s) of a single servo axis u ∥ IA that keeps an untorqued SDF gyro's balance
    ω_ind = 0 (conventions §4): θ̇ = −Ω·IA_L − (M_O ω_O + M_S ω_S + D(a))/(1 + E_SF), a function of θ alone,
    tabulated every 0.05° and integrated by RK4 in steps of at most ``step_s``."""
    sa = np.cross(ia, oa)
    grid = np.linspace(-720.0, 720.0, 28801)
    w, f = platform_inputs([u], grid[:, None], np.zeros((len(grid), 1)), lat_deg, g_site)
    wi, wo, ws = (w @ np.asarray(x, float) / DPH for x in (ia, oa, sa))
    ai, ao, as_ = (f @ np.asarray(x, float) / G0 for x in (ia, oa, sa))
    drift = sdf_rate(tr, 0.0 * wi, wo, ws, ai, ao, as_, 0.0, 20.0)
    table = (-wi - drift / (1 + tr.get("E_SF", 0) * 1e-6)) / 3600.0

    def rate(theta):
        return np.interp(theta, grid, table)

    sub = max(1, int(np.ceil((t[1] - t[0]) / step_s))) if len(t) > 1 else 1
    fine = np.linspace(t[0], t[-1], (len(t) - 1) * sub + 1)
    h = fine[1] - fine[0] if len(fine) > 1 else 0.0
    th = np.empty(len(fine))
    th[0] = 0.0
    for k in range(len(fine) - 1):
        x = th[k]
        k1 = rate(x)
        k2 = rate(x + 0.5 * h * k1)
        k3 = rate(x + 0.5 * h * k2)
        k4 = rate(x + h * k3)
        th[k + 1] = x + h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
    ang = th[::sub]
    return ang, rate(ang)


def temperature(t, base=20.0, rise=6.0, tau=900.0, ripple=1.5, period=1200.0):
    """A chamber's temperature, °C: a warm-up plus a slow ripple (so that it is no ramp in time)."""
    return base + rise * (1 - np.exp(-t / tau)) + ripple * np.sin(2 * np.pi * t / period)


def encoder_counts(angle_deg, counts_per_rev):
    """An encoder's reading: the angle in counts, floored, wrapping at one revolution."""
    return np.floor(np.asarray(angle_deg) / 360.0 * counts_per_rev).astype(np.int64) % counts_per_rev


def indicated_angle(t_edges, rate_fn, sub=20):
    """The indicated angle ∫ ω_ind dt (arcsec) at the times ``t_edges`` (n+1,) from the first, by Simpson's rule on
    a grid ``sub`` (even) times finer; ``rate_fn`` gives ω_ind (deg/h) at any times (deg/h · s = arcsec)."""
    fine = np.linspace(t_edges[0], t_edges[-1], (len(t_edges) - 1) * sub + 1)
    r = rate_fn(fine)
    h = fine[1] - fine[0]
    inc = (r[:-1:2] + 4 * r[1::2] + r[2::2]) * h / 3.0
    return np.concatenate([[0.0], np.cumsum(inc)])[:: sub // 2]


def write_csv(path, header, columns, fmt):
    """A data system's CSV: its own header and number formats."""
    lines = [",".join(header)]
    for row in zip(*columns):
        lines.append(",".join(f(v) for f, v in zip(fmt, row)))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def iso(t0: _dt.datetime, t_s):
    """ISO 8601 date-times of the times ``t_s`` (s) after ``t0``, to the microsecond."""
    return [(t0 + _dt.timedelta(microseconds=int(round(x * 1e6)))).isoformat(timespec="microseconds") for x in t_s]


def rate_table_run(
    folder,
    name,
    *,
    axes=(("spin", (0.0, 0.0, 1.0)),),
    mounting=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    schedule,
    truth,
    kind="fog",
    output="volts",
    sigma_dph=30.0,
    lat_deg=39.98,
    g_site=9.80155,
    table_dt_ms=20,
    gyro_dt_s=None,
    clock_offset_s=0.0,
    gyro_clock="us",
    counts_per_rev=2**24,
    volts_per_dps=0.02,
    scale_per_ma=None,
    pulse_arcsec=0.5,
    rate_column=False,
    temperature_column=True,
    servo=False,
    seed=0,
):
    """Write one run's data-system log(s) into ``folder``; returns what was written and the truth.

    The table's log (``NAME-table.csv``, or ``NAME.csv`` when the instrument shares its clock): ``Time [ms]``
    (integer ms), one ``Enc<i>`` column of encoder counts per axis (``counts_per_rev``, wrapping), optionally
    ``TableRate<i> [deg/s]``. With ``gyro_dt_s`` the instrument has a data system of its own (``NAME-gyro.csv``): a
    clock starting ``clock_offset_s`` after the table's (``gyro_clock``: ``"us"`` integer µs or ``"iso"``
    date-times), its output and temperature, at its own rate. ``output``: ``"volts"`` (``volts_per_dps``, written to
    0.1 µV), ``"current"`` (mA at ``scale_per_ma``, deg/h/mA or g/mA; TDF two columns), ``"pulses"`` (counts per
    interval of ``pulse_arcsec``), ``"rate"`` (deg/s). ``kind``: ``"sdf-gyro"``, ``"fog"``, ``"rlg"``, ``"tdf-gyro"``,
    ``"pendulous-accel"``. ``mounting``: the first two instrument axes in platform coordinates (IA, OA; TDF X, Y;
    accelerometer IA, PA); the third is their cross product. ``sigma_dph``: white noise of the output per sample,
    deg/h (g for an accelerometer).
    """
    rng = np.random.default_rng(seed)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ax_names = [a for a, _ in axes]
    ax_u = [np.asarray(u, float) for _, u in axes]
    m1, m2 = (np.asarray(v, float) for v in mounting)
    m3 = np.cross(m1, m2)
    # the clocks: the table's ticks, and the instrument's (the same, or its own)
    if servo:
        ph, total = None, float(schedule)
    else:
        ph, total = phases(schedule, len(axes))
    n_tab = int(total * 1000) // table_dt_ms
    t_tab = np.arange(n_tab) * table_dt_ms / 1000.0
    two = gyro_dt_s is not None
    if two:
        n_g = int((total - clock_offset_s) / gyro_dt_s)
        t_g = clock_offset_s + np.arange(n_g) * gyro_dt_s
    else:
        t_g = t_tab
    if servo:
        ang_g, om_g = servo_angles(t_g, ax_u[0], m1, m2, truth, lat_deg, g_site)
        ang_g, om_g = ang_g[:, None], om_g[:, None]
        lab_g = np.array(["servo"] * len(t_g))
        ang_t = np.interp(t_tab, t_g, ang_g[:, 0])[:, None]
        om_t = np.interp(t_tab, t_g, om_g[:, 0])[:, None]
    else:
        ang_g, om_g, lab_g = motion(ph, t_g)
        ang_t, om_t, _ = motion(ph, t_tab)
    temp_g = temperature(t_g)

    def inputs(t, ang, om):
        w, f = platform_inputs(ax_u, ang, om, lat_deg, g_site)
        w = w / DPH
        f = f / G0
        return [w @ m for m in (m1, m2, m3)], [f @ m for m in (m1, m2, m3)]

    (w1, w2, w3), (a1, a2, a3) = inputs(t_g, ang_g, om_g)
    if kind in ("sdf-gyro", "fog", "rlg"):
        optical = kind != "sdf-gyro"
        ind = sdf_rate(truth, w1, w2, w3, a1, a2, a3, t_g, temp_g, optical)
        if servo:
            ind = np.zeros_like(ind)  # untorqued: the table keeps the balance (commanded current 0)
            sigma_dph = 0.0
        if output == "pulses":
            dt = gyro_dt_s or table_dt_ms / 1000.0
            edges = np.concatenate([[t_g[0] - dt], t_g])

            def rate_fn(tt):
                a, o, _ = motion(ph, tt)
                (x1, x2, x3), (y1, y2, y3) = inputs(tt, a, o)
                return sdf_rate(truth, x1, x2, x3, y1, y2, y3, tt, temperature(tt), optical)

            # white rate noise σ per sample: an angle increment N(0, σ dt) per interval; the pulses count the
            # indicated angle in steps of the pulse weight, the remainder carried to the next interval
            angle = indicated_angle(edges, rate_fn)
            angle[1:] += np.cumsum(rng.normal(size=len(t_g)) * sigma_dph * dt)
            pulses = np.diff(np.floor(angle / pulse_arcsec)).astype(np.int64)
            out_cols = [("Pulses", pulses, str)]
        else:
            ind = ind + rng.normal(size=len(t_g)) * sigma_dph
            if output == "volts":
                out_cols = [("Vout [V]", ind / 3600.0 * volts_per_dps, lambda v: f"{v:.7f}")]
            elif output == "current":
                out_cols = [("Itorq [mA]", ind / scale_per_ma, lambda v: f"{v:.9f}")]
            else:
                out_cols = [("Rate [deg/s]", ind / 3600.0, lambda v: f"{v:.9f}")]
    elif kind == "tdf-gyro":
        wz = np.stack([w1, w2, w3], axis=1)
        az = np.stack([a1, a2, a3], axis=1)
        ind = tdf_rates(truth, wz, az) + rng.normal(size=(len(t_g), 2)) * sigma_dph
        out_cols = [(f"I{c} [mA]", ind[:, j] / scale_per_ma, lambda v: f"{v:.9f}") for j, c in enumerate("XY")]
    else:  # pendulous accelerometer: output in g at the nominal scale g/mA
        ind = accel_output(truth, a1, a2, a3) + rng.normal(size=len(t_g)) * sigma_dph
        out_cols = [("Iacc [mA]", ind / scale_per_ma, lambda v: f"{v:.9f}")]
    enc = [encoder_counts(ang_t[:, i], counts_per_rev) for i in range(len(axes))]
    tab_header = ["Time [ms]"] + [f"Enc{i + 1}" for i in range(len(axes))]
    tab_cols = [np.round(t_tab * 1000).astype(np.int64)] + enc
    tab_fmt = [str] * (1 + len(axes))
    if rate_column:
        tab_header += [f"TableRate{i + 1} [deg/s]" for i in range(len(axes))]
        tab_cols += [om_t[:, i] for i in range(len(axes))]
        tab_fmt += [lambda v: f"{v:.6f}"] * len(axes)
    g_header = [h for h, _, _ in out_cols] + (["Temp [C]"] if temperature_column else [])
    g_cols = [c for _, c, _ in out_cols] + ([temp_g] if temperature_column else [])
    g_fmt = [f for _, _, f in out_cols] + ([lambda v: f"{v:.3f}"] if temperature_column else [])
    files = {}
    if two:
        local = t_g - clock_offset_s  # the instrument's clock starts at its first sample
        if gyro_clock == "iso":
            clock = iso(_dt.datetime(2026, 3, 1, 9, 30, 0), local)
            g_header, g_cols, g_fmt = ["Timestamp"] + g_header, [clock] + g_cols, [str] + g_fmt
        else:
            g_header = ["t_us"] + g_header
            g_cols = [np.round(local * 1e6).astype(np.int64)] + g_cols
            g_fmt = [str] + g_fmt
        files["table"] = folder / f"{name}-table.csv"
        files["gyro"] = folder / f"{name}-gyro.csv"
        write_csv(files["table"], tab_header, tab_cols, tab_fmt)
        write_csv(files["gyro"], g_header, g_cols, g_fmt)
    else:
        files["table"] = folder / f"{name}.csv"
        write_csv(files["table"], tab_header + g_header, tab_cols + g_cols, tab_fmt + g_fmt)
    info = {
        "files": {k: str(v) for k, v in files.items()},
        "axes": [{"name": a, "axis_enu": u.tolist()} for a, u in zip(ax_names, ax_u)],
        "mounting": [m1.tolist(), m2.tolist(), m3.tolist()],
        "truth": dict(truth),
        "sigma": sigma_dph,
        "lat_deg": lat_deg,
        "g_site": g_site,
        "clock_offset_s": clock_offset_s,
        "labels": lab_g.tolist(),
    }
    (folder / f"{name}-truth.json").write_text(json.dumps(info))
    info["inputs"] = {"t": t_g, "w": np.stack([w1, w2, w3], 1), "a": np.stack([a1, a2, a3], 1), "temp": temp_g}
    info["angles"] = ang_g
    info["rates"] = om_g
    return info
