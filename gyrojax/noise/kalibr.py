"""Noise figures for the filters people feed: Kalibr's ``imu.yaml`` (also read by OpenVINS, VINS-Fusion and the
ROS tools that follow Kalibr's IMU noise model).

Kalibr (ethz-asl/kalibr wiki, "IMU Noise Model" and "YAML formats") models each axis as continuous-time white
noise of strength σ_g plus a bias driven by white noise of strength σ_bg (a random walk), the same for the three
axes: ``gyroscope_noise_density`` σ_g in rad/s/√Hz, ``gyroscope_random_walk`` σ_bg in rad/s²/√Hz,
``accelerometer_noise_density`` in m/s²/√Hz, ``accelerometer_random_walk`` in m/s³/√Hz, ``update_rate`` Hz and
``rostopic``.

From IEEE 952 figures (conventions §6 units): a white rate of ARW N deg/√h has the two-sided density
σ(τ = 1 s)·√(1 s) = 60 N deg/h/√Hz, i.e. N·(π/180)/60 rad/s/√Hz; a rate random walk K deg/h/√h grows as
σ²(t) = K²t/3600 (t in s), i.e. K/60 deg/h/√s = K·(π/180)/(60·3600) rad/s²/√Hz. An accelerometer channel analysed
in m/s² where the report says deg/h (:func:`densities` ``si_per_unit`` = 1) maps the same way: 60 N m/s²/√Hz and
K/60 m/s³/√Hz.

Which figure: N is the model's white term when the fitted model has one (the continuous-time white density
itself), else the curve's −½ read-off; K the model's random walk when it has one, else the curve's +½ read-off or
its upper bound when no +½ slope is seen (a conservative value for the filter, said so in the file). Several axes
are one Kalibr figure: the largest of them (conservative), with every axis listed in a comment.
"""

from __future__ import annotations

import math

from gyrojax.noise.spec import NoiseModelError

RAD_PER_S_PER_DEG_PER_H = math.pi / 180.0 / 3600.0
"""One deg/h in rad/s."""


def densities(out: dict, si_per_unit: float = RAD_PER_S_PER_DEG_PER_H) -> dict:
    """Kalibr's two figures of one channel from a ``gyrojax noise`` report ``out`` (:func:`readoff.noise_report`):
    ``noise_density`` (SI unit/√Hz) and ``random_walk`` (SI unit/s/√Hz), each with the IEEE 952 figure it came
    from, its source ("model", "curve" or "curve upper bound") and relative standard error."""
    model = out.get("model", {}).get("parameters", {})
    head = out["headline"]

    def pick(model_key, head_key):
        m = model.get(model_key)
        if m is not None and m.get("std") is not None:
            return m["value"], m["std"], "model"
        c = head[head_key]["curve"]
        if c["value"] is None:
            raise NoiseModelError(f"no {head_key} read off the record ({c.get('reason', '')}): no Kalibr figure")
        kind = "curve upper bound" if c.get("kind") == "upper bound" else "curve"
        return c["value"], c["std"], kind

    n, n_std, n_src = pick("white", "arw")
    k, k_std, k_src = pick("random_walk", "rrw")
    return {
        "noise_density": 60.0 * n * si_per_unit,
        "random_walk": k / 60.0 * si_per_unit,
        "from": {
            "arw": {"value": n, "std": n_std, "source": n_src},
            "rrw": {"value": k, "std": k_std, "source": k_src},
        },
    }


def kalibr_figures(gyro: dict, accel: dict | None, update_rate_hz: float, rostopic: str) -> dict:
    """The ``kalibr`` object of ``gyrojax noise --json``: per sensor the largest of its channels' densities
    (``gyro``/``accel``: channel name → :func:`densities`), ``update_rate`` (Hz), ``rostopic`` and the channels;
    densities in Kalibr's units, rad/s/√Hz and m/s²/√Hz."""
    out = {"rostopic": rostopic, "update_rate": float(update_rate_hz), "channels": {"gyroscope": gyro}}
    for sensor, chans in (("gyroscope", gyro), ("accelerometer", accel)):
        if not chans:
            continue
        out["channels"][sensor] = chans
        out[f"{sensor}_noise_density"] = max(c["noise_density"] for c in chans.values())
        out[f"{sensor}_random_walk"] = max(c["random_walk"] for c in chans.values())
    return out


def imu_yaml(fig: dict, source: str = "") -> str:
    """Kalibr ``imu.yaml`` text of :func:`kalibr_figures` (one ``key: value`` per line, comments after ``#``)."""
    lines = [f"# Kalibr IMU noise model written by gyrojax noise{(' from ' + source) if source else ''}"]
    units = {
        "gyroscope": ("rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"),
        "accelerometer": ("m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)"),
    }
    for sensor, (u_n, u_k) in units.items():
        chans = fig["channels"].get(sensor)
        if not chans:
            lines.append(f"# {sensor}_*: the record has no {sensor} channels; add them before Kalibr reads this file")
            continue
        per = ", ".join(
            f"{name} N {c['from']['arw']['value']:.4g} ({c['from']['arw']['source']}) "
            f"K {c['from']['rrw']['value']:.4g} ({c['from']['rrw']['source']})"
            for name, c in chans.items()
        )
        lines.append(f"# {sensor}: the largest of the channels ({per}); IEEE 952 N, K in their report units")
        bound = any(c["from"]["rrw"]["source"] == "curve upper bound" for c in chans.values())
        lines.append(f"{sensor}_noise_density: {fig[f'{sensor}_noise_density']:.6e}  # [{u_n}]")
        note = " (an upper bound: no +1/2 slope in the record)" if bound else ""
        lines.append(f"{sensor}_random_walk: {fig[f'{sensor}_random_walk']:.6e}  # [{u_k}]{note}")
    lines.append(f"rostopic: {fig['rostopic']}")
    lines.append(f"update_rate: {fig['update_rate']:.6g}  # [Hz]")
    return "\n".join(lines) + "\n"
