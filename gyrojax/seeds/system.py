"""System view (Titterton ch. 12): what a residual gyro error costs in navigation error.

**Single-channel Schuler loop** (Titterton 12.2–12.4, Fig. 12.2, Tables 12.3/12.4). Tilt θ (rad), velocity error
δv (m/s), position error δx (m) and, for the vertical-gyro term, heading error γ (rad)::

    γ̇ = δω_D
    θ̇ = −δv/R_0 + δω_H − Ȧ cos L · γ          (Ȧ = Ω for a vehicle at rest)
    δv̇ = g θ + δf
    δẋ = δv

characteristic equation s² + g/R_0 = 0, ω_s = √(g/R_0) = 0.00124 rad/s, T_s = 84.4 min (12.2–12.4). For constant
inputs the closed forms of Table 12.3/12.4 are (signs as printed there)::

    horizontal gyro bias δω_H:   δx = R_0 δω_H (t − sin ω_s t / ω_s)                  short time: g δω_H t³/6
    accelerometer bias δf:       δx = δf (1 − cos ω_s t)/ω_s²                          short time: δf t²/2
    initial tilt θ_0:            δx = R_0 θ_0 (1 − cos ω_s t)                          short time: g θ_0 t²/2
    initial velocity δv_0:       δx = δv_0 sin ω_s t / ω_s
    vertical gyro bias δω_D:     δx = −R_0 Ω cos L {t²/2 − (1 − cos ω_s t)/ω_s²} δω_D  short time: −Ω cos L g δω_D t⁴/24

(Table 12.4 prints the short-time vertical-bias entry without the minus sign of its medium-time entry.)
Without the Schuler feedback (R_0 → ∞, Titterton 12.1, the 2-D inertial frame) the gyro bias gives g δω t³/6 for all t.

**Propagating identification uncertainty.** Every position error above is linear in the constant errors, so
δx(t) = s(t)ᵀ β for the vector β of constant errors (δω_H, δω_D, δf, θ_0, δv_0) and sensitivities s(t). If the residual
gyro drift is δω = J δc (J: drift per unit coefficient error at the operating condition, e.g. a row of
``gyrojax.physics.model.jacobian`` in deg/h per report unit) and the identified coefficients have covariance Σ_c, then

    σ²_x(t) = s(t)ᵀ J Σ_c Jᵀ s(t) = trace(W(t) Σ_c),   W(t) = Jᵀ s(t) s(t)ᵀ J

so W(t) is a navigation-cost weight for a design criterion (weighted A-optimality of a test plan).

**Angle random walk** N (rad/√s, white rate noise of PSD N²) on the level channel: a rate impulse at time s tilts
the platform for good, so δx(t) = R_0 ∫ (1 − cos ω_s(t − s)) w(s) ds and

    σ²_x(t) = R_0² N² [3t/2 − 2 sin(ω_s t)/ω_s + sin(2ω_s t)/(4ω_s)]     (Schuler loop)
    σ²_x(t) = g² N² t⁵/20                                              (no feedback, short time)

**Heading.** A vertical (azimuth) drift turns the heading error at its own rate, γ = δω_D t (free azimuth); an east
drift biases gyrocompass alignment by δγ = δω_E/(Ω cos L) (Titterton 10.13: 0.01 °/h → about 1 mrad at 45°).

Units: SI inside (rad, rad/s, m, s); public helpers that take drifts in deg/h say so.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from gyrojax import units

R0 = units.WGS84_A
"""Earth radius used for the Schuler loop, m (equatorial radius; Titterton's R_0)."""

__all__ = [
    "R0",
    "drift_position_weight",
    "alignment_heading_error",
    "drift_to_position_rate",
    "heading_error",
    "position_error_std_arw",
    "position_error_closed_form",
    "position_error_std",
    "position_sensitivities",
    "schuler_frequency",
    "schuler_period_min",
    "simulate_channel",
]

ERROR_SOURCES = ("gyro_h", "gyro_d", "accel", "tilt0", "vel0")
"""Order of the constant-error vector β: horizontal gyro bias (rad/s), vertical gyro bias (rad/s), accelerometer
bias (m/s²), initial tilt (rad), initial velocity error (m/s)."""


def schuler_frequency(g=units.G0, radius=R0):
    """ω_s = √(g/R_0), rad/s (Titterton 12.3)."""
    return jnp.sqrt(g / radius)


def schuler_period_min(g=units.G0, radius=R0):
    """T_s = 2π √(R_0/g), minutes (Titterton 12.4: 84.4 min)."""
    return 2 * jnp.pi / schuler_frequency(g, radius) / 60.0


def position_sensitivities(t, lat=0.0, g=units.G0, radius=R0, schuler=True, omega=units.OMEGA_IE):
    """s(t): position error (m) per unit of each source in :data:`ERROR_SOURCES`, shape t.shape + (5,).

    ``schuler=False`` drops the R_0 feedback (short-time / 2-D inertial frame forms, Titterton 12.1, Table 12.4).
    """
    t = jnp.asarray(t, jnp.float64)
    a = omega * jnp.cos(lat)
    if schuler:
        ws = schuler_frequency(g, radius)
        one_minus_cos = 1 - jnp.cos(ws * t)
        gyro_h = radius * (t - jnp.sin(ws * t) / ws)
        gyro_d = -radius * a * (t**2 / 2 - one_minus_cos / ws**2)
        accel = one_minus_cos / ws**2
        tilt = radius * one_minus_cos
        vel = jnp.sin(ws * t) / ws
    else:
        gyro_h = g * t**3 / 6
        gyro_d = -a * g * t**4 / 24
        accel = t**2 / 2
        tilt = g * t**2 / 2
        vel = t
    return jnp.stack([gyro_h, gyro_d, accel, tilt, vel], axis=-1)


def position_error_closed_form(t, beta, **kw):
    """δx(t) = s(t)ᵀ β (m) for the constant errors β (order of :data:`ERROR_SOURCES`)."""
    return position_sensitivities(t, **kw) @ jnp.asarray(beta, jnp.float64)


def _channel_matrix(lat, g, radius, schuler, omega):
    """State x = (γ, θ, δv, δx); ẋ = A x + G u with u = (δω_D, δω_H, δf)."""
    k = 1.0 / radius if schuler else 0.0
    a_cos = omega * jnp.cos(lat)
    a = jnp.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [-a_cos, 0.0, -k, 0.0],
            [0.0, g, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    gm = jnp.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    return a, gm


def _channel_transition(dt, lat, g, radius, schuler, omega):
    """(Φ, Γ) of one step ``dt`` for inputs held over the step: the matrix exponential of the augmented system.

    The SI state mixes radians, m/s and m, so A spans ten decades (g ≈ 10 beside 1/R_0 ≈ 1.6e-7) and an exponential
    accurate in norm would be accurate only to ‖Φ‖·u ≈ 1e-13 absolute in its small entries: about 1e-8 relative,
    growing over the steps of a neutrally stable loop. The exponential is therefore taken in balanced units (angles;
    δv over √(g R_0) = R_0 ω_s; δx over R_0; rate inputs over ω_s, δf over g), where every entry of A·dt is of the
    order ω_s·dt, then scaled back: each element of Φ and Γ is then accurate to a few units of round-off."""
    a, gm = _channel_matrix(lat, g, radius, schuler, omega)
    v0 = jnp.sqrt(g * radius)
    state = jnp.stack([1.0, 1.0, v0, radius])
    inputs = jnp.stack([v0 / radius, v0 / radius, g])
    a_b = a * state[None, :] / state[:, None]
    g_b = gm * inputs[None, :] / state[:, None]
    big = jnp.zeros((7, 7)).at[:4, :4].set(a_b).at[:4, 4:].set(g_b)
    e = jax.scipy.linalg.expm(big * dt)
    phi = e[:4, :4] * state[:, None] / state[None, :]
    gam = e[:4, 4:] * state[:, None] / inputs[None, :]
    return phi, gam


def simulate_channel(
    dt, gyro_h, gyro_d=None, accel=None, x0=None, lat=0.0, g=units.G0, radius=R0, schuler=True, omega=units.OMEGA_IE
):
    """Propagate the single-channel error loop for time series of errors held over each step (``lax.scan``).

    Exact discretisation (matrix exponential of the augmented system) for inputs constant over each step, so it
    handles time-varying residual drifts (e.g. a temperature-dependent bias) as well as constant ones.

    Args:
      dt: step (s). gyro_h, gyro_d: (n,) horizontal / vertical gyro error (rad/s). accel: (n,) accelerometer error
      (m/s²). x0: initial (γ, θ, δv, δx).

    Returns:
      (n + 1, 4) states (γ, θ, δv, δx) at t = 0, dt, …, n·dt.
    """
    gyro_h = jnp.asarray(gyro_h, jnp.float64)
    n = gyro_h.shape[0]
    gyro_d = jnp.zeros(n) if gyro_d is None else jnp.asarray(gyro_d, jnp.float64)
    accel = jnp.zeros(n) if accel is None else jnp.asarray(accel, jnp.float64)
    x0 = jnp.zeros(4) if x0 is None else jnp.asarray(x0, jnp.float64)
    phi, gam = _channel_transition(dt, lat, g, radius, schuler, omega)
    u = jnp.stack([gyro_d, gyro_h, accel], axis=1)

    def step(x, uk):
        x = phi @ x + gam @ uk
        return x, x

    _, xs = jax.lax.scan(step, x0, u)
    return jnp.concatenate([x0[None], xs])


def drift_to_position_rate(drift_deg_per_h, radius=R0):
    """Long-run growth of position error from a horizontal drift, m/h: R_0·δω (Titterton §12.2.5, "1 km/h")."""
    return radius * jnp.asarray(drift_deg_per_h) * units.DEG_PER_H * units.SECONDS_PER_HOUR


def drift_position_weight(t, jac, lat=0.0, source="gyro_h", **kw):
    """W(t) = Jᵀ s s ᵀ J: σ²_x(t) = trace(W Σ_c) for coefficient covariance Σ_c (module doc).

    ``jac``: (p,) or (k, p) drift (deg/h) per unit of each coefficient at the operating condition(s); several rows
    are summed (a constant drift that is the sum of the rows). ``source`` picks the loop input it drives.
    """
    s = position_sensitivities(t, lat=lat, **kw)[..., ERROR_SOURCES.index(source)]
    j = jnp.atleast_2d(jnp.asarray(jac, jnp.float64)).sum(0) * units.DEG_PER_H
    return jnp.outer(j, j) * s**2


def position_error_std(t, cov, jac, lat=0.0, source="gyro_h", **kw):
    """1σ position error (m) at time t from the residual uncertainty Σ_c of identified coefficients."""
    return jnp.sqrt(jnp.trace(drift_position_weight(t, jac, lat, source, **kw) @ jnp.asarray(cov, jnp.float64)))


def heading_error(t, drift_deg_per_h):
    """Heading error (rad) from an uncompensated vertical drift (deg/h): γ = δω_D t (free azimuth)."""
    return jnp.asarray(drift_deg_per_h) * units.DEG_PER_H * jnp.asarray(t, jnp.float64)


def position_error_std_arw(t, arw_deg_per_rt_h, g=units.G0, radius=R0, schuler=True):
    """1σ position error (m) from angle random walk N (deg/√h) on the level gyro (module doc)."""
    t = jnp.asarray(t, jnp.float64)
    n = arw_deg_per_rt_h * units.DEG / 60.0  # rad/√s
    if not schuler:
        return g * n * jnp.sqrt(t**5 / 20.0)
    ws = schuler_frequency(g, radius)
    return radius * n * jnp.sqrt(1.5 * t - 2 * jnp.sin(ws * t) / ws + jnp.sin(2 * ws * t) / (4 * ws))


def alignment_heading_error(east_drift_deg_per_h, lat, omega=units.OMEGA_IE):
    """Gyrocompassing heading error (rad) from an east gyro drift: δγ = δω_E/(Ω cos L) (Titterton 10.13)."""
    return jnp.asarray(east_drift_deg_per_h) * units.DEG_PER_H / (omega * jnp.cos(lat))
