"""Fisher information of a hand calibration protocol for a MEMS gyro triad, as the triad fit
(:func:`gyrojax.inference.triad.fit_triad`) would weigh it: exact JAX derivatives of its own measurement model.

A protocol is a chain of rests joined by turns (:mod:`gyrojax.simulation.triad_session`). Each part gives rows:

* **rest** k, Up u_k in the body frame, T_k s: the mean indicated rate y = b + G u_k |g| (+ S Ω sin φ u_k with the
  latitude known), rows of :func:`gyrojax.inference.triad.segment_means`; covariance (conventions §9.3, Hu 3-14
  least squares) ARW² / T_k I + ½ Ω_h² (I − u uᵀ) (the horizontal Earth rate of unknown heading);
* **known-angle turn** (imucal) by Θ about n: the mean indicated rate over the turn, same function, with the angle
  error σ_Θ = √2 σ_placement on n (σ_Θ² n nᵀ / T²) and the horizontal Earth rate through the turn's mean phase;
* **gravity-to-gravity move** (imu_tk) by Φ about n in T s: the residual u_to − Rᵀ u_from of
  :func:`gyrojax.inference.triad.move_residual` (the angle integrals of the calibrated rate: to first order
  δφ = ∫ C(T)ᵀ C(t) (δS ω + δb + δG a) dt) projected ⟂ u_to, variance ARW² T (the angle noise) + (Ω_h T)²/2
  (Earth turning Up unseen) + the accelerometer noise of the two Up directions σ_a² / (rate T_rest) each.

The placement error of a rest does not enter a move: both Up directions are measured by the accelerometer. The
rows are evaluated at θ = 0 (nominal S = I): a MEMS triad's 1 % scale errors change F by about 1 %.
``F = Σ Jᵀ C⁻¹ J`` (3p × 3p, report units: deg/h, deg/h/g, ppm, arcsec), coefficients ``<name>[<channel>]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from gyrojax import units
from gyrojax.inference.triad_rows import move_residual, segment_means
from gyrojax.physics import triad as tp

MOVE_SAMPLES = 24
"""Samples of a move in the Fisher information (the first-order rows depend on the profile only through ∫ dt)."""
TURN_SAMPLES = 64
"""Samples of a known-angle turn (its Earth-rate phase and mean specific force)."""


@dataclass(frozen=True)
class TriadNoise:
    """What the design assumes about the session: the gyro's angle random walk ``arw`` (deg/√h, each channel), the
    accelerometer's white noise ``acc_noise_g`` (g per sample at ``rate_hz``), the site (``latitude_deg`` None:
    unknown to the fit, as in most hand calibrations; ``earth_rate`` False: no Earth rate) and the hand's
    ``placement_deg`` (σ of each placement about each body axis, deg)."""

    arw: float = 1.2
    acc_noise_g: float = 0.002
    rate_hz: float = 100.0
    latitude_deg: float | None = None
    earth_rate: bool = True
    placement_deg: float = 0.0
    gravity_mps2: float = 9.81

    def earth(self) -> tuple[float | None, float]:
        """(vertical Earth rate Ω sin φ in deg/h, None when unknown or off; horizontal magnitude Ω_h in deg/h)."""
        if not self.earth_rate:
            return None, 0.0
        om = units.OMEGA_IE_DEG_PER_H
        if self.latitude_deg is None:
            return None, om * math.sqrt(2.0 / 3.0)
        phi = math.radians(self.latitude_deg)
        return om * math.sin(phi), om * math.cos(phi)

    @property
    def g(self) -> float:
        """|g| in g."""
        return self.gravity_mps2 / units.G0


def rot(axis, angle):
    """R(n, α) = I + sin α [n×] + (1 − cos α)[n×]² (conventions §3), JAX; ``axis`` unit, ``angle`` rad."""
    k = jnp.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return jnp.eye(3) + jnp.sin(angle) * k + (1.0 - jnp.cos(angle)) * (k @ k)


def _profile(n_samples: int, angle, duration):
    """Rate (rad/s, (L,)) of a turn by ``angle`` in ``duration`` s ∝ sin(π t / T), samples summing to the angle, and
    the angle at each sample's midpoint (the profile of :func:`gyrojax.simulation.triad.turn_samples`)."""
    dt = duration / n_samples
    prof = jnp.sin(jnp.pi * (jnp.arange(n_samples) + 0.5) / n_samples)
    rate = prof * angle / (prof.sum() * dt)
    ang = jnp.cumsum(rate) * dt - 0.5 * rate * dt
    return rate, ang, dt


def _theta0(model):
    return jnp.zeros(3 * model.size)


def rest_fisher(model, up, rest_s, noise: TriadNoise):
    """F of the rests: ``up`` (N, 3) unit Up in the body frame, ``rest_s`` (N,) s."""
    n = up.shape[0]
    vertical, horizontal = noise.earth()
    w = jnp.zeros((n, 3)) if vertical is None else vertical * up
    arrays = (w, up * noise.g, jnp.zeros(n), jnp.full(n, 20.0), jnp.arange(n), jnp.ones(n))
    jac = jax.jacfwd(segment_means, argnums=1)(model, _theta0(model), arrays).reshape(n, 3, -1)
    alpha = noise.arw**2 / (rest_s / units.SECONDS_PER_HOUR)  # (deg/h)² of a rest mean
    beta = 0.5 * horizontal**2
    uu = up[:, :, None] * up[:, None, :]
    cinv = uu / alpha[:, None, None] + (jnp.eye(3) - uu) / (alpha + beta)[:, None, None]
    return jnp.einsum("kip,kij,kjq->pq", jac, cinv, jac)


def turn_fisher(model, up, axis, angle, duration, noise: TriadNoise):
    """F of known-angle turns (K of them): start Up ``up`` (K, 3), body ``axis`` (K, 3), ``angle`` (K,) rad,
    ``duration`` (K,) s; angle error √2 σ_placement."""
    k, n = up.shape[0], TURN_SAMPLES
    vertical, horizontal = noise.earth()

    def one(u, ax, th, dur):
        rate, ang, dt = _profile(n, th, dur)
        a = jax.vmap(lambda al: rot(ax, al).T @ u)(ang) * noise.g
        w = rate[:, None] * ax / units.DEG_PER_H
        if vertical is not None:
            w = w + vertical * a / noise.g
        arrays = (w, a, jnp.zeros(n), jnp.full(n, 20.0), jnp.zeros(n, dtype=int), jnp.array([float(n)]))
        jac = jax.jacfwd(segment_means, argnums=1)(model, _theta0(model), arrays)
        sd = math.radians(math.sqrt(2.0) * noise.placement_deg) / units.DEG_PER_H / dur  # deg/h, mean rate
        m2 = jnp.abs(jnp.mean(jnp.exp(1j * ang))) ** 2
        nn = jnp.outer(ax, ax)
        cov = noise.arw**2 / (dur / units.SECONDS_PER_HOUR) * jnp.eye(3)
        cov = cov + sd**2 * nn + 0.5 * horizontal**2 * m2 * (jnp.eye(3) - nn)
        return jac.T @ jnp.linalg.solve(cov, jac)

    if k == 0:
        return jnp.zeros((3 * model.size, 3 * model.size))
    return jnp.sum(jax.vmap(one)(up, axis, angle, duration), axis=0)


def turn_pairs_fisher(model, up_hosts, pairs: int, duration, noise: TriadNoise):
    """F of ``pairs`` pairs of known-angle 360° turns (one each way, back to the mark) about body axis e_j at the
    rest of Up ``up_hosts[j]`` (j = 0, 1, 2: x, y, z), each turn ``duration`` s (differentiable in the Ups)."""
    if pairs == 0:
        return jnp.zeros((3 * model.size, 3 * model.size))
    e = jnp.eye(3)
    up = jnp.repeat(jnp.concatenate([up_hosts[:3], up_hosts[:3]]), pairs, axis=0)
    axis = jnp.repeat(jnp.concatenate([e, -e]), pairs, axis=0)
    k = up.shape[0]
    return turn_fisher(model, up, axis, jnp.full(k, 2.0 * math.pi), jnp.full(k, duration), noise)


def move_fisher(model, up_from, axis, angle, duration, rest_from, rest_to, noise: TriadNoise):
    """F of gravity-to-gravity moves (M of them): start Up ``up_from`` (M, 3), body ``axis`` (M, 3) unit,
    ``angle`` (M,) rad, ``duration`` (M,) s, the rests on either side ``rest_from``/``rest_to`` (M,) s."""
    n = MOVE_SAMPLES
    _, horizontal = noise.earth()

    def one(u, ax, th, dur, t0, t1):
        rate, ang, dt = _profile(n, th, dur)
        g = jnp.concatenate([jnp.zeros((1, 3)), rate[:, None] * ax / units.DEG_PER_H, jnp.zeros((1, 3))])
        u_to = rot(ax, th).T @ u
        a = jnp.concatenate([u[None], jax.vmap(lambda al: rot(ax, al).T @ u)(ang), u_to[None]]) * noise.g
        mask = jnp.ones(n + 1)

        def resid(theta):
            t_h = jnp.zeros(n + 2)  # a designed move: no trend time, the reference temperature
            temp = jnp.full(n + 2, 20.0)
            return move_residual(model, theta, g, a, t_h, temp, mask, dt, u, u_to)

        jac = jax.jacfwd(resid)(_theta0(model))
        span_h = (dur + 2.0 / noise.rate_hz) / units.SECONDS_PER_HOUR
        var = (noise.arw * jnp.sqrt(span_h) * units.DEG) ** 2
        var = var + (horizontal * span_h * units.SECONDS_PER_HOUR * units.DEG_PER_H) ** 2 / 2.0
        var = var + noise.acc_noise_g**2 / noise.rate_hz / noise.g**2 * (1.0 / t0 + 1.0 / t1)
        proj = jnp.eye(3) - jnp.outer(u_to, u_to)
        return jac.T @ proj @ jac / var

    if up_from.shape[0] == 0:
        return jnp.zeros((3 * model.size, 3 * model.size))
    return jnp.sum(jax.vmap(one)(up_from, axis, angle, duration, rest_from, rest_to), axis=0)


def coefficient_names(model) -> list[str]:
    """The fit's coefficient names in the order of F: ``D_F[x]``, …, channel by channel."""
    return [tp.channel_name(c, ch) for ch in tp.CHANNELS for c in model.coefficient_names]


def scaled(f):
    """F / (s sᵀ), s = √diag F, and log s (the scaling that keeps log det and inverses well conditioned)."""
    s = jnp.sqrt(jnp.maximum(jnp.diag(f), 1e-300))
    return f / jnp.outer(s, s), jnp.log(s)


def covariance(f):
    """F⁻¹ through the scaled F (same units as F⁻¹)."""
    fs, ls = scaled(f)
    s = jnp.exp(ls)
    return jnp.linalg.inv(fs) / jnp.outer(s, s)
