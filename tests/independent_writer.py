"""An independent record writer for tests: plain numpy + scipy, written from conventions §2–§6 alone.

It shares no code with gyrojax (no kinematics, effects, noise or record writer of the package) so that diagnosis is
checked on campaigns this project's simulator did not make: other table geometries, derived rates (no rate column),
odd sample intervals, its own random numbers.

Beyond the named effects of §6 a campaign may carry a bias the registry does not name (``extra``: a function of time
and temperature, e.g. :func:`two_slope`, seed 001's hinged temperature bias) and Gauss–Markov drift (§6
``gauss_markov``: σ deg/h, τ s, the exact first-order recursion over each sample's time step, moves included).
"""

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

G0 = 9.80665
WIE = 7.2921150e-5
D2R = np.pi / 180
DPH = D2R / 3600  # deg/h in rad/s
AS = D2R / 3600  # arcsec in rad


def _attitude(axes, angles_rad, base=None):
    c = np.eye(3) if base is None else base.copy()
    for u, t in zip(axes, angles_rad):
        c = c @ Rotation.from_rotvec(np.asarray(u) * t).as_matrix()
    return c


def write_campaign(
    folder,
    runs,
    truth,
    lat_deg=45.5,
    g_site=9.8063,
    noise_white=0.001,
    seed=0,
    t0=1000.0,
    extra=None,
    gauss_markov=None,
):
    """Write one record per run. A run: dict(name, axes=[(name, u)], ia, oa, segments=[(angles_deg0, rates_dps,
    duration_s, dt_s)], temperature=callable(t) or None). ``truth``: coefficient dict (conventions §6 names, report
    units) with optional set-up keys delta_E, delta_N, delta_U (arcsec). ``extra(t_s, temperature_C)``: a further
    bias, deg/h (temperature None without a profile); ``gauss_markov``: (σ deg/h, τ s) drift. Returns the list of
    JSON paths."""
    rng = np.random.default_rng(seed)
    gm_state, gm_time = None, None
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lat = lat_deg * D2R
    omega = WIE * np.array([0, np.cos(lat), np.sin(lat)])
    f = np.array([0, 0, g_site])
    d = np.array([truth.get("delta_E", 0.0), truth.get("delta_N", 0.0), truth.get("delta_U", 0.0)]) * AS
    base = np.eye(3) + np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    out, t_clock = [], t0
    for run in runs:
        ia, oa = np.asarray(run["ia"], float), np.asarray(run["oa"], float)
        sa = np.cross(ia, oa)
        axes = [np.asarray(u, float) for _, u in run["axes"]]
        rows = []
        for seg_id, (ang0, rates, dur, dt) in enumerate(run["segments"]):
            n = int(round(dur / dt))
            for k in range(n):
                t = t_clock + k * dt
                ang = np.asarray(ang0, float) + np.asarray(rates, float) * k * dt
                th = ang * D2R
                c = base @ _attitude(axes, th)
                w_lp = np.zeros(3)
                partial = np.eye(3)
                for u, tt, r in zip(axes, th, np.asarray(rates, float) * D2R):
                    w_lp = w_lp + r * (partial @ u)
                    partial = partial @ Rotation.from_rotvec(u * tt).as_matrix()
                w_lp = base @ w_lp
                w = (omega + w_lp) @ c  # = Cᵀ(Ω + ω_LP) in platform coordinates
                fp = f @ c
                wi, wo, ws = w @ ia / DPH, w @ oa / DPH, w @ sa / DPH
                ai, ao, as_ = fp @ ia / G0, fp @ oa / G0, fp @ sa / G0
                temp = run["temperature"](t) if run.get("temperature") else None
                ind = wi + truth.get("D_F", 0) + truth.get("D_I", 0) * ai + truth.get("D_O", 0) * ao
                ind += truth.get("D_S", 0) * as_ + truth.get("D_II", 0) * ai**2 + truth.get("D_SS", 0) * as_**2
                ind += truth.get("D_OO", 0) * ao**2 + truth.get("D_IO", 0) * ai * ao + truth.get("D_IS", 0) * ai * as_
                ind += truth.get("D_OS", 0) * ao * as_
                ind += truth.get("E_SF", 0) * 1e-6 * wi + truth.get("E_A", 0) * 1e-6 * abs(wi)
                ind += truth.get("E_2", 0) * 1e-6 * wi * wi / 3600
                ind += (truth.get("M_O", 0) * wo + truth.get("M_S", 0) * ws) * AS
                ind += truth.get("D_T", 0) * t / 3600
                if temp is not None:
                    ind += truth.get("D_TEMP", 0) * (temp - 20)
                if extra is not None:
                    ind += extra(t, temp)
                ind += rng.normal() * noise_white * 60 / np.sqrt(dt)
                if gauss_markov is not None:
                    sd, tau = gauss_markov
                    if gm_state is None:
                        gm_state = sd * rng.normal()
                    else:
                        rho = np.exp(-(t - gm_time) / tau)
                        gm_state = rho * gm_state + sd * np.sqrt(1 - rho * rho) * rng.normal()
                    gm_time = t
                    ind += gm_state
                rows.append((t, ang, seg_id, ind, temp))
            t_clock = rows[-1][0] + 45.0
        t_clock += 120.0
        sf = 11.5
        header = ["time_s"] + [f"angle_{a}_deg" for a, _ in run["axes"]] + ["segment", "current_mA"]
        if run.get("temperature"):
            header.append("temperature_C")
        lines = [",".join(header)]
        for t, ang, seg, ind, temp in rows:
            vals = [f"{t:.6f}"] + [f"{a:.9f}" for a in ang] + [str(seg), f"{ind / sf:.12e}"]
            if temp is not None:
                vals.append(f"{temp:.4f}")
            lines.append(",".join(vals))
        (folder / f"{run['name']}.csv").write_text("\n".join(lines) + "\n")
        meta = {
            "format": "gyrojax-record-1",
            "name": run["name"],
            "site": {"latitude_deg": lat_deg, "gravity_mps2": g_site},
            "table": {"axes": [{"name": a, "axis_enu": list(map(float, u))} for a, u in run["axes"]]},
            "instrument": {"kind": "sdf-gyro", "ia": ia.tolist(), "oa": oa.tolist(), "sa": sa.tolist()},
            "mode": "rebalance",
            "scale_factor_deg_per_h_per_mA": sf,
            "servo_axis": None,
            "writer": "tests/independent_writer.py",
        }
        (folder / f"{run['name']}.json").write_text(json.dumps(meta))
        out.append(folder / f"{run['name']}.json")
    return out


def three_axis_positions(n=18, seed=1, dwell=300.0, dt=1.5):
    """A three-axis table (outer Up, middle North, inner East at zero) visiting random orientations."""
    rng = np.random.default_rng(seed)
    axes = [("azimuth", (0, 0, 1)), ("pitch", (0, 1, 0)), ("roll", (1, 0, 0))]
    segs = [(list(rng.uniform(-180, 180, 3)), [0, 0, 0], dwell, dt) for _ in range(n)]
    s = 1 / np.sqrt(2)
    return {"name": "threeaxis", "axes": axes, "ia": (s, s, 0), "oa": (-s, s, 0), "segments": segs}


def tilted_ladder(name, ia, oa, rates=(2, 8, 25, 60), dur=40.0, dt=0.2):
    """Rate steps ± about an axis tilted 10° from Up toward East (no rate column: rates derived from angles)."""
    u = (np.sin(10 * D2R), 0.0, np.cos(10 * D2R))
    segs = [([0.0], [sg * r], dur, dt) for r in rates for sg in (1, -1)]
    return {"name": name, "axes": [("spin", u)], "ia": ia, "oa": oa, "segments": segs}


def two_slope(k_hot, k_cold, knee_c=20.0):
    """Seed 001's hinged temperature bias, deg/h (without its value e at the knee, which D_F holds): with τ = T − 20 °C
    (001 l.73: "相对于 20℃ 的实时温度"), the bias is e + K_tx1 τ on the hot side (τ ≥ 0) and e + K_tx2 τ on the cold
    side, K_tx1 = (k_x0_h − e_x)/t_3h, K_tx2 = (k_x0_d − e_x)/t_3d (001 §5.1 step 4, l.79–81). As a function for
    :func:`write_campaign`'s ``extra``; ``knee_c`` moves the hinge away from the paper's 20 °C."""

    def bias(t_s, temperature_c):
        tau = temperature_c - knee_c
        return (k_hot if tau >= 0 else k_cold) * tau

    return bias


def chamber_cycle(low_c=10.0, high_c=32.0, period_s=8000.0, start_s=1000.0):
    """A temperature profile from ``low_c`` through ``high_c`` and back, T(t) = mid − half · cos(2π (t − start)/period),
    °C: not monotone in time, so a temperature effect is not a trend."""
    mid, half = 0.5 * (low_c + high_c), 0.5 * (high_c - low_c)
    return lambda t: mid - half * np.cos(2 * np.pi * (t - start_s) / period_s)


def twenty_four_positions(name="pos24", dwell=300.0, dt=3.0, temperature=None, order_seed=2):
    """A 24-position static test on a two-axis table (outer axis North, inner axis normal to the platform, Up at
    zero): outer 0, 60, …, 300° × inner 0, 90, 180, 270°, visited in a shuffled order so that no g-term follows
    the temperature or time; a skew SDF mounting (IA (2, 1, 2)/3, OA (1, −2, 0)/√5)."""
    grid = [(a, b) for a in range(0, 360, 60) for b in (0, 90, 180, 270)]
    order = np.random.default_rng(order_seed).permutation(len(grid))
    segs = [([float(grid[i][0]), float(grid[i][1])], [0, 0], dwell, dt) for i in order]
    run = {"name": name, "axes": [("outer", (0, 1, 0)), ("inner", (0, 0, 1))], "segments": segs}
    run |= {"ia": (2 / 3, 1 / 3, 2 / 3), "oa": (1 / np.sqrt(5), -2 / np.sqrt(5), 0.0), "temperature": temperature}
    return run
