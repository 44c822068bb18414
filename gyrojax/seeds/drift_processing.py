"""Random-drift data processing of Hu ch. 4 §1 and ch. 6 §2: rate from angle samples, and averaging of readings.

**Moving-average rate** (Hu 4-5 to 4-11). Angles θ_k are sampled every Δt; the rate over the window ΔT = n·Δt is
the difference quotient of samples n apart, assigned to the window's midpoint (Hu 4-7)::

    θ̇(t) ≈ [θ(t + ΔT/2) − θ(t − ΔT/2)] / ΔT

For θ = A sin ωt the estimate is K·Aω cos ωt with the gain

    K(ω) = sin(ωΔT/2) / (ωΔT/2)                                                        (Hu 4-11)

an amplitude error with no phase error. Independent angle-reading errors of standard deviation ε give a rate error
of standard deviation √2·ε/ΔT (Hu 4-2 writes the worst case of one reading as ε/ΔT). White *rate* noise of
two-sided PSD q (angle random walk N = √q) passes with power gain K², whose noise bandwidth is
∫ K(2πf)² df = 1/ΔT, so the rate estimate has variance q/ΔT (:func:`moving_average_arw_std`).

**Kalman running mean** (Hu 6-21 to 6-23). A slowly varying angle read with white error of variance R,
θ_k = θ_{k−1}, Z_k = θ_k + e_k, is estimated by θ̂_k = θ̂_{k−1} + K_k (Z_k − θ̂_{k−1}) (Hu 6-22). With prior
variance p_0 the variance after k readings and the gain applied to reading k (0-based) are

    p_k = p_0 R / (k p_0 + R),        K_k = p_0 / ((k + 1) p_0 + R)  →  1/(k + 1)  for p_0 ≫ R,

so θ̂_k is the arithmetic mean of Z_0…Z_k (Hu 6-23): "a mean square of 10 sec² falls to 1 sec² after ten
averages". The book's practice averages five readings before and five after the current time, which stays
unbiased while θ changes at a constant rate (:func:`centered_average`).

Units: any consistent angle unit (the book uses arcsec, "sec"); times in s; rates in angle unit per s.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = [
    "centered_average",
    "kalman_gain",
    "kalman_running_mean",
    "kalman_variance",
    "moving_average_arw_std",
    "moving_average_gain",
    "moving_average_rate",
    "moving_average_rate_noise_std",
]


def moving_average_rate(theta, dt: float, n: int):
    """Rate by the moving-average method (Hu 4-5, 4-7).

    Args:
      theta: (m,) angles sampled every ``dt`` seconds.
      dt: sample interval Δt (s).
      n: samples per window, ΔT = n·Δt.

    Returns:
      (t_mid, rate): midpoint times (s, from the first sample) and rates (angle unit/s), each of length m − n.
    """
    theta = jnp.asarray(theta, dtype=jnp.float64)
    window = n * dt
    rate = (theta[n:] - theta[:-n]) / window
    t_mid = (jnp.arange(theta.shape[0] - n) + 0.5 * n) * dt
    return t_mid, rate


def moving_average_gain(omega, window_s):
    """Amplitude gain K = sin(ωΔT/2)/(ωΔT/2) of the moving-average rate (Hu 4-11); ω in rad/s, ΔT in s."""
    x = 0.5 * jnp.asarray(omega, dtype=jnp.float64) * window_s
    return jnp.sinc(x / jnp.pi)  # numpy's sinc is sin(πx)/(πx)


def moving_average_rate_noise_std(angle_noise_std, window_s):
    """Standard deviation of the rate from two independent angle readings of std ε: √2·ε/ΔT (Hu 4-2).

    ``window_s`` = ΔT in s; the result is in ``angle_noise_std``'s angle unit per s (arcsec → arcsec/s = deg/h).
    """
    return jnp.sqrt(2.0) * angle_noise_std / window_s


def moving_average_arw_std(arw, window_s):
    """Rate-estimate std from white rate noise of ARW ``arw`` (angle unit/√s): N/√ΔT (noise bandwidth of 4-11).

    ``window_s`` = ΔT in s; the result is in the same angle unit per s.
    """
    return arw / jnp.sqrt(window_s)


def kalman_variance(k, p0, r):
    """Estimate variance after readings 0…k−1, p_k = p_0 R/(k p_0 + R) (Hu 6-22, the recursion solved)."""
    return p0 * r / (k * p0 + r)


def kalman_gain(k, p0, r):
    """Gain applied to reading k (0-based), K_k = p_0/((k+1) p_0 + R) (Hu 6-22)."""
    return p0 / ((k + 1) * p0 + r)


@jax.jit
def kalman_running_mean(z, r, p0, x0=0.0):
    """Scalar Kalman filter for a constant read with white error (Hu 6-21, 6-22), by ``lax.scan``.

    Args:
      z: (m,) readings Z_k.
      r: reading-error variance R.
      p0: prior variance of the angle (the book's p_0 = mean square of the initial guess).
      x0: prior mean.

    Returns:
      (estimates θ̂_k, variances after each reading, gains K_k), each (m,).
    """
    z = jnp.asarray(z, dtype=jnp.float64)

    def step(carry, zk):
        x, p = carry
        gain = p / (p + r)
        x = x + gain * (zk - x)
        p = p * r / (p + r)
        return (x, p), (x, p, gain)

    _, (x, p, g) = jax.lax.scan(step, (jnp.asarray(x0, jnp.float64), jnp.asarray(p0, jnp.float64)), z)
    return x, p, g


def centered_average(z, half: int = 5):
    """The book's 10-reading average: the mean of ``half`` readings before and ``half`` after each index.

    Unbiased for an angle changing at constant rate (the two halves are symmetric about the current time) and of
    variance R/(2·half) for white reading error (Hu ch. 6 §2, after 6-23). Returns the estimates for indices
    ``half … m−half−1`` (length m − 2·half).
    """
    z = jnp.asarray(z, dtype=jnp.float64)
    c = jnp.concatenate([jnp.zeros(1), jnp.cumsum(z)])
    m = z.shape[0]
    k = jnp.arange(half, m - half)
    before = c[k] - c[k - half]
    after = c[k + half + 1] - c[k + 1]
    return (before + after) / (2 * half)
