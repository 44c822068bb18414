"""Temperature models of bias and scale factor, and their compensation (seed 001, Peng & Zhu 2009).

**Two-slope model hinged at 20 °C** (001 §5, l.75–132; the paper writes the coefficients, the model below is what
they imply). With τ = T − 20 °C (T the INS internal sensor temperature)::

    k(T) = e + K_1 τ   (τ ≥ 0, high side),      k(T) = e + K_2 τ   (τ < 0, low side)

for a gyro bias, an accelerometer bias or an accelerometer scale factor alike.

**Coefficients from four calibration runs**, in the order room-before (b), hot (h), cold (d), room-after (a), each
giving a coefficient value k and a temperature offset τ. The room-temperature runs are extrapolated to τ = 0 along
the line through the hot (τ_room ≥ 0) or the cold (τ_room < 0) point on the same side (001 l.75–81)::

    S_01 = k_b − (k_h − k_b) τ_b/(τ_h − τ_b)      if τ_b ≥ 0;    k_b − (k_d − k_b) τ_b/(τ_d − τ_b) otherwise
    S_04 = the same with the after-run (a)
    e = (S_01 + S_04)/2,   K_1 = (k_h − e)/τ_h,   K_2 = (k_d − e)/τ_d

S_01 − S_04 measures turn-on repeatability and thermal hysteresis between the two room runs.

**Per-point values** (the paper's "before" case, 001 l.134): using the coefficient of the nearest calibration
temperature makes the compensation a staircase in T, so the navigation solution jumps where T crosses a bin
boundary; :func:`binned_model` builds it for comparison.

**Compensation.** For a rate gyro the indicated rate is ω_ind = (1 + s(T)) ω + b(T), so ω̂ = (ω_ind − b̂(T))/(1 + ŝ(T)).

**Navigation error.** :func:`navigation_position_error` feeds the residual gyro and accelerometer errors of a run
through the single-channel Schuler loop of :mod:`gyrojax.seeds.system` (Titterton 12.2), with and without
compensation. The paper reports 181 m (98 m at 70 s) uncompensated and 29.5 m (15.8 m at 70 s) compensated over 90 s at
100 Hz (001 l.136) but gives neither the fitted coefficients nor the temperatures, so its numbers cannot be recomputed;
only the ordering (compensated < uncompensated) and its spec-sheet scale are testable.

Units: temperature in °C; coefficients in any unit (the model is linear in them); rates in deg/h, specific force
in g where the navigation helper says so.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp

from gyrojax import units
from gyrojax.data import plans
from gyrojax.seeds import system

T_REF_C = 20.0
"""Hinge temperature of the two-slope model, °C (001 l.73)."""

__all__ = [
    "T_REF_C",
    "TwoSlope",
    "binned_model",
    "compensate_rate",
    "extrapolate_to_reference",
    "full_temperature_plan",
    "navigation_position_error",
    "two_slope",
    "two_slope_from_runs",
]


@dataclasses.dataclass(frozen=True)
class TwoSlope:
    """Two-slope temperature model: value ``e`` at 20 °C, slope ``k_hot`` above and ``k_cold`` below (per °C)."""

    e: float
    k_hot: float
    k_cold: float

    def __call__(self, temperature_c):
        return two_slope(temperature_c, self.e, self.k_hot, self.k_cold)


def two_slope(temperature_c, e, k_hot, k_cold, t_ref=T_REF_C):
    """k(T) = e + K_1 (T − 20) above 20 °C, e + K_2 (T − 20) below (the model implied by 001 l.75–132)."""
    tau = jnp.asarray(temperature_c, jnp.float64) - t_ref
    return e + jnp.where(tau >= 0, k_hot, k_cold) * tau


def extrapolate_to_reference(k_room, tau_room, k_hot, tau_hot, k_cold, tau_cold):
    """S_0: a room-temperature run's coefficient extrapolated to 20 °C along its own side (001 l.75–81)."""
    hot = k_room - (k_hot - k_room) * tau_room / (tau_hot - tau_room)
    cold = k_room - (k_cold - k_room) * tau_room / (tau_cold - tau_room)
    return jnp.where(tau_room >= 0, hot, cold)


def two_slope_from_runs(k_b, tau_b, k_h, tau_h, k_d, tau_d, k_a, tau_a):
    """The 001 procedure: (e, K_1, K_2, S_01 − S_04) from runs before (b), hot (h), cold (d), after (a).

    τ are the run temperatures minus 20 °C (the paper's t_3 or t_34 with suffixes b, h, d, a).
    """
    s01 = extrapolate_to_reference(k_b, tau_b, k_h, tau_h, k_d, tau_d)
    s04 = extrapolate_to_reference(k_a, tau_a, k_h, tau_h, k_d, tau_d)
    e = 0.5 * (s01 + s04)
    return e, (k_h - e) / tau_h, (k_d - e) / tau_d, s01 - s04


def binned_model(cal_temps_c, cal_values):
    """Piecewise-constant model: the value at the nearest calibration temperature (001 l.134, uncompensated case).

    ``cal_temps_c`` in °C; returns f(temperature_c in °C) in the same units as ``cal_values``.
    """
    temps = jnp.asarray(cal_temps_c, jnp.float64)
    vals = jnp.asarray(cal_values, jnp.float64)

    def model(temperature_c):
        t = jnp.asarray(temperature_c, jnp.float64)
        return vals[jnp.argmin(jnp.abs(t[..., None] - temps), axis=-1)]

    return model


def compensate_rate(indicated, temperature_c, bias: TwoSlope | None = None, scale: TwoSlope | None = None):
    """ω̂ = (ω_ind − b̂(T)) / (1 + ŝ(T)): the rate with the modelled bias and scale-factor error removed.

    ``bias`` in the unit of ``indicated``; ``scale`` dimensionless (use ppm·1e-6).
    """
    w = jnp.asarray(indicated, jnp.float64)
    b = 0.0 if bias is None else bias(temperature_c)
    s = 0.0 if scale is None else scale(temperature_c)
    return (w - b) / (1.0 + s)


def navigation_position_error(
    dt_s, temperature_c, gyro_bias_deg_h, accel_bias_g, gyro_model=None, accel_model=None, latitude_deg=45.0
):
    """Single-channel position error (m) of a stationary strapdown INS from residual temperature errors.

    The residual is the true error minus the model's prediction at the run temperature; with no model the 20 °C
    (room-calibration) value is all that is removed, i.e. the residual is the true error minus its value at 20 °C
    given as ``gyro_bias_deg_h(20)``. ``gyro_bias_deg_h`` and ``accel_bias_g`` are callables of temperature (°C);
    the gyro error drives the level channel (θ), the accelerometer error the velocity (Titterton Table 12.3).

    Returns the (n + 1,) position error at t = 0, dt, … with n = len(temperature_c).
    """
    temp = jnp.asarray(temperature_c, jnp.float64)
    g_true, a_true = gyro_bias_deg_h(temp), accel_bias_g(temp)
    g_model = gyro_model(temp) if gyro_model is not None else gyro_bias_deg_h(T_REF_C)
    a_model = accel_model(temp) if accel_model is not None else accel_bias_g(T_REF_C)
    gyro = (g_true - g_model) * units.DEG_PER_H * jnp.ones_like(temp)
    accel = (a_true - a_model) * units.G0 * jnp.ones_like(temp)
    x = system.simulate_channel(dt_s, gyro, accel=accel, lat=jnp.deg2rad(latitude_deg))
    return x[:, 3]


def full_temperature_plan(
    base: plans.Plan | None = None,
    hot_c: float = 60.0,
    cold_c: float = -45.0,
    room_c=(22.0, 18.0),
    soak_ramp_c: float | None = None,
) -> plans.Plan:
    """The 001 calibration sequence: the base plan's runs at room (before), hot, cold, room (after).

    ``base`` defaults to a six-position test (001 §4). Run names get suffixes ``_b``, ``_h``, ``_d``, ``_a``. With
    ``soak_ramp_c`` each run's temperature ramps linearly by that many °C toward 20 °C (a chamber not yet settled),
    using ``Run.temperature_C = [start, end]``.
    """
    base = base or plans.multiposition(6)
    steps = (("b", room_c[0]), ("h", hot_c), ("d", cold_c), ("a", room_c[1]))
    runs = []
    for suffix, temp in steps:
        spec = temp
        if soak_ramp_c is not None:
            spec = (temp, temp - soak_ramp_c * (1 if temp >= T_REF_C else -1))
        for r in base.runs:
            runs.append(dataclasses.replace(r, name=f"{r.name}_{suffix}", temperature_C=spec))
    return plans.Plan(
        f"{base.name}-full-temperature",
        tuple(runs),
        base.latitude_deg,
        base.gravity_mps2,
        description=f"{base.description} at room (before), {hot_c} °C, {cold_c} °C, room (after)",
        reference="Peng & Zhu 2009 (seed 001) §4-5",
    )
