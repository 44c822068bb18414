"""Noise figures for the filters people feed: Kalibr's ``imu.yaml`` (also read by OpenVINS, VINS-Fusion and the
ROS tools that follow Kalibr's IMU noise model).

Kalibr (ethz-asl/kalibr wiki, "IMU Noise Model" and "YAML formats") models each axis as continuous-time white
noise of strength σ_g plus a bias driven by white noise of strength σ_bg (a random walk), the same for the three
axes: ``gyroscope_noise_density`` σ_g in rad/s/√Hz, ``gyroscope_random_walk`` σ_bg in rad/s²/√Hz,
``accelerometer_noise_density`` in m/s²/√Hz, ``accelerometer_random_walk`` in m/s³/√Hz, ``update_rate`` Hz and
``rostopic``. Its reader (kalibr_common/ConfigReader.py, ``ImuParameters``) needs all six: ``IccImu`` asks for the
accelerometer statistics of every IMU, a missing key is a RuntimeError ("Field … missing in file"), a density or
random walk ≤ 0 is refused, ``rostopic`` must be a string, ``update_rate`` a number > 0. So a file is written only
with all six, every one a positive number; the accelerometer pair of a gyro-only record comes from the user
(:func:`given_accelerometer`), never invented.

In Allan variance terms (SI) the model is σ²(τ) = σ_g²/τ + σ_bg²·τ/3. IEEE 952 annex C (conventions §6) writes
σ²(τ) = N²/τ_h + K²τ_h/3 with τ_h = τ/3600 the time in h, so σ_g = N/√(1 h) and σ_bg = K/√(1 h) in the sensor's
unit, i.e. with √(1 h) = 60 √s:

- gyro, N deg/√h: σ_g = N·(π/180)/60 rad/s/√Hz; K deg/h/√h: σ_bg = K·(π/180)/(3600·60) rad/s²/√Hz
  (1 deg/h = (π/180)/3600 rad/s);
- accelerometer, VRW N m/s/√h: σ_a = N/60 m/s²/√Hz; K m/s²/√h: σ_ba = K/60 m/s³/√Hz
  (the units of :mod:`gyrojax.noise.sensor_units`).

:data:`TO_KALIBR` holds these factors, keyed by the unit label the report gives each figure, so a figure is
converted by what its label says it is.

Which figure: N is the model's white term when the fitted model has one (the continuous-time white density
itself), else the curve's −½ read-off; K the model's random walk when it has one, else the curve's +½ read-off or
its upper bound when no +½ slope is seen (a conservative value for the filter, said so in the file). Several axes
are one Kalibr figure: the largest of them (conservative), with every axis listed in a comment.
"""

from __future__ import annotations

import json
import math

from gyrojax.noise.spec import NoiseModelError

RAD_PER_DEG = math.pi / 180.0
SQRT_S_PER_SQRT_H = 60.0
"""√(1 h) in √s."""

TO_KALIBR = {
    # unit of the IEEE 952 figure: (Kalibr figure, factor, Kalibr unit)
    "deg/sqrt(h)": ("noise_density", RAD_PER_DEG / SQRT_S_PER_SQRT_H, "rad/s/sqrt(Hz)"),
    "deg/h/sqrt(h)": ("random_walk", RAD_PER_DEG / 3600.0 / SQRT_S_PER_SQRT_H, "rad/s^2/sqrt(Hz)"),
    "m/s/sqrt(h)": ("noise_density", 1.0 / SQRT_S_PER_SQRT_H, "m/s^2/sqrt(Hz)"),
    "m/s^2/sqrt(h)": ("random_walk", 1.0 / SQRT_S_PER_SQRT_H, "m/s^3/sqrt(Hz)"),
}
"""Kalibr's continuous-time figure of an IEEE 952 N or K, by the figure's unit (module doc)."""

SENSORS = ("gyroscope", "accelerometer")
KEYS = tuple(f"{s}_{k}" for s in SENSORS for k in ("noise_density", "random_walk")) + ("rostopic", "update_rate")
"""The keys Kalibr's ImuParameters reads (kalibr_common/ConfigReader.py)."""


def to_kalibr(value: float, unit: str) -> float:
    """Kalibr's figure (rad/s/√Hz, rad/s²/√Hz, m/s²/√Hz or m/s³/√Hz) of an IEEE 952 N or K ``value`` in ``unit``
    (deg/√h, deg/h/√h, m/s/√h or m/s²/√h; :data:`TO_KALIBR`)."""
    if unit not in TO_KALIBR:
        raise NoiseModelError(f"no Kalibr figure for a value in {unit!r} (expected one of {', '.join(TO_KALIBR)})")
    return value * TO_KALIBR[unit][1]


def densities(out: dict) -> dict:
    """Kalibr's two figures of one channel from a ``gyrojax noise`` report ``out`` (:func:`readoff.noise_report`,
    gyro in deg/h or accelerometer in m/s² units, :func:`gyrojax.noise.sensor_units.accelerometer_report`):
    ``noise_density`` (rad/s/√Hz or m/s²/√Hz) and ``random_walk`` (rad/s²/√Hz or m/s³/√Hz), each with the IEEE 952
    figure it came from (value, std, unit) and its source ("model", "curve" or "curve upper bound")."""
    model = out.get("model", {}).get("parameters", {})
    head = out["headline"]

    def pick(model_key, head_key):
        m = model.get(model_key)
        if m is not None and m.get("std") is not None:
            return m["value"], m["std"], m["unit"], "model"
        c = head[head_key]["curve"]
        if c["value"] is None:
            raise NoiseModelError(f"no {head_key} read off the record ({c.get('reason', '')}): no Kalibr figure")
        kind = "curve upper bound" if c.get("kind") == "upper bound" else "curve"
        return c["value"], c["std"], c["unit"], kind

    n, n_std, n_unit, n_src = pick("white", "arw")
    k, k_std, k_unit, k_src = pick("random_walk", "rrw")
    return {
        "noise_density": to_kalibr(n, n_unit),
        "random_walk": to_kalibr(k, k_unit),
        "from": {
            "arw": {"value": n, "std": n_std, "unit": n_unit, "source": n_src},
            "rrw": {"value": k, "std": k_std, "unit": k_unit, "source": k_src},
        },
    }


def given_accelerometer(spec: str) -> dict:
    """The accelerometer pair a user gives for a gyro-only record (``--kalibr-accel``): ``"ND,RW"``, Kalibr's
    ``accelerometer_noise_density`` (m/s²/√Hz) and ``accelerometer_random_walk`` (m/s³/√Hz), e.g. from the
    datasheet or another record; each a positive number (Kalibr refuses ≤ 0)."""
    try:
        nd, rw = (float(x) for x in spec.split(","))
    except ValueError:
        raise NoiseModelError(
            f"--kalibr-accel {spec!r}: expected NOISE_DENSITY,RANDOM_WALK (m/s^2/sqrt(Hz), m/s^3/sqrt(Hz))"
        ) from None
    for name, v in (("noise density", nd), ("random walk", rw)):
        if not (math.isfinite(v) and v > 0):
            raise NoiseModelError(f"--kalibr-accel: the {name} {v!r} must be a positive number (Kalibr refuses <= 0)")
    return {"noise_density": nd, "random_walk": rw, "from": "given (--kalibr-accel)"}


def kalibr_figures(gyro: dict, accel: dict, update_rate_hz: float, rostopic: str) -> dict:
    """The ``kalibr`` object of ``gyrojax noise --json``: per sensor the largest of its channels' densities
    (``gyro``/``accel``: channel name → :func:`densities`, or ``accel`` the :func:`given_accelerometer` pair),
    ``update_rate`` (Hz), ``rostopic`` and the channels; densities in Kalibr's units, rad/s/√Hz and m/s²/√Hz.
    Refuses (NoiseModelError) a sensor without figures or a figure that is not a positive number: Kalibr's reader
    would not load the file."""
    out = {"rostopic": rostopic, "update_rate": float(update_rate_hz), "channels": {}}
    if not (math.isfinite(out["update_rate"]) and out["update_rate"] > 0):
        raise NoiseModelError(f"update_rate {update_rate_hz!r} Hz: Kalibr needs a positive rate")
    for sensor, chans in zip(SENSORS, (gyro, accel)):
        if not chans:
            raise NoiseModelError(f"no {sensor} figures: Kalibr's reader needs {sensor}_noise_density and _random_walk")
        if "from" in chans and isinstance(chans["from"], str):  # given by the user
            out["channels"][sensor] = {"given": chans}
        else:
            out["channels"][sensor] = chans
        for k in ("noise_density", "random_walk"):
            v = max(c[k] for c in out["channels"][sensor].values())
            if not (math.isfinite(v) and v > 0):
                raise NoiseModelError(f"{sensor}_{k} = {v!r}: Kalibr refuses a figure that is not positive")
            out[f"{sensor}_{k}"] = v
    return out


def _float(x: float) -> str:
    """A YAML 1.1 float (PyYAML reads ``1e-05`` without a point as a string): always a point and a signed
    exponent."""
    return f"{x:.6e}"


def imu_yaml(fig: dict, source: str = "") -> str:
    """Kalibr ``imu.yaml`` text of :func:`kalibr_figures` (one ``key: value`` per line, comments after ``#``):
    all six keys Kalibr's ImuParameters reads."""
    lines = [f"# Kalibr IMU noise model written by gyrojax noise{(' from ' + source) if source else ''}"]
    units = {
        "gyroscope": ("rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"),
        "accelerometer": ("m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)"),
    }
    for sensor, (u_n, u_k) in units.items():
        chans = fig["channels"][sensor]
        if "given" in chans:
            lines.append(f"# {sensor}: given by --kalibr-accel (not measured in these records)")
            bound = False
        else:
            per = ", ".join(
                f"{name} N {c['from']['arw']['value']:.4g} {c['from']['arw']['unit']} ({c['from']['arw']['source']}) "
                f"K {c['from']['rrw']['value']:.4g} {c['from']['rrw']['unit']} ({c['from']['rrw']['source']})"
                for name, c in chans.items()
            )
            lines.append(f"# {sensor}: the largest of the channels ({per})")
            bound = any(c["from"]["rrw"]["source"] == "curve upper bound" for c in chans.values())
        lines.append(f"{sensor}_noise_density: {_float(fig[f'{sensor}_noise_density'])}  # [{u_n}]")
        note = " (an upper bound: no +1/2 slope in the record)" if bound else ""
        lines.append(f"{sensor}_random_walk: {_float(fig[f'{sensor}_random_walk'])}  # [{u_k}]{note}")
    lines.append(f"rostopic: {json.dumps(fig['rostopic'])}")  # quoted: Kalibr wants a string, whatever the topic
    rate = float(f"{fig['update_rate']:.9g}")  # a float with a point, 9 digits: 1/0.01 s reads 100.0
    lines.append(f"update_rate: {rate!r}  # [Hz]")
    return "\n".join(lines) + "\n"
