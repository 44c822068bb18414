"""Random drift processes (conventions §6, IEEE 952 annex C), generated in JAX: the one noise simulator
(:func:`simulate` of a :class:`~gyrojax.noise.spec.NoiseSpec`, :func:`random_drift` of a truth file's dict).

Each generator returns the *rate averaged over the sample interval* (deg/h) at each sample, which is what a
rebalance loop's current or a servo angle increment measures. Keys are explicit; the same key gives the same
draw on every device and batch size.

==============  ================  ==========================================================
name            parameters        process
==============  ================  ==========================================================
``white``       N, deg/√h         angle random walk: σ = N·60/√Δt deg/h per sample of Δt s
``gauss_markov`` (σ deg/h, τ s)   first-order Gauss–Markov: x' = −x/τ + w, stationary σ
``random_walk`` K, deg/h/√h       rate random walk: increments K·√(Δt/3600 h)
``quantization`` Q, arcsec        angle quantisation: uniform angle error of std Q, differenced
==============  ================  ==========================================================
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.noise.spec import BI_FACTOR, NoiseModelError, NoiseSpec


def white(key, n, dt_s, arw):
    """White rate noise for angle random walk ``arw`` (deg/√h); ``dt_s`` per sample (scalar or (n,))."""
    return arw * 60.0 / jnp.sqrt(dt_s) * jax.random.normal(key, (n,))


def gauss_markov(key, dt_s, sigma, tau):
    """First-order Gauss–Markov samples (deg/h) on the time steps ``dt_s`` (n,) (first step ignored).

    x_{k+1} = φ x_k + σ √(1 − φ²) w_k with φ = exp(−Δt_k/τ); stationary start x_0 ~ N(0, σ²).
    """
    w = jax.random.normal(key, dt_s.shape)
    phi = jnp.exp(-dt_s / tau)

    def step(x, inp):
        p, e = inp
        x = p * x + sigma * jnp.sqrt(1.0 - p * p) * e
        return x, x

    _, xs = jax.lax.scan(step, sigma * w[0], (phi[1:], w[1:]))
    return jnp.concatenate([sigma * w[:1], xs])


def random_walk(key, dt_s, k):
    """Rate random walk (deg/h) with coefficient ``k`` deg/h/√h, starting at 0; ``dt_s`` (n,) steps."""
    w = jax.random.normal(key, dt_s.shape)
    inc = k * jnp.sqrt(dt_s / units.SECONDS_PER_HOUR) * w
    return jnp.cumsum(inc.at[0].set(0.0))


def quantization(key, n, dt_s, q_arcsec):
    """Rate noise (deg/h) from an angle quantisation error of std ``q_arcsec``: (e_{k+1} − e_k)/Δt.

    Uniform angle error on ±√3·Q (std Q), the IEEE 952 quantisation model σ²(τ) = 3Q²/τ².
    """
    e = jax.random.uniform(key, (n + 1,), minval=-1.0, maxval=1.0) * jnp.sqrt(3.0) * q_arcsec
    return (e[1:] - e[:-1]) / 3600.0 * 3600.0 / dt_s  # arcsec/s = deg/h


def bias_instability(key, dt_s, b, tau_min, tau_max, n_poles=6):
    """Flicker (1/f) drift of bias-instability coefficient ``b`` (deg/h) between ``tau_min`` and ``tau_max`` s,
    approximated by a sum of Gauss–Markov processes with log-spaced correlation times.

    Each pole carries variance so that the Allan floor is ≈ BI_FACTOR·b (IEEE 952: σ_min = B·√(2 ln 2/π) = 0.664 B).
    """
    taus = np.geomspace(tau_min, tau_max, n_poles)
    # one GM of σ² gives a peak Allan variance ≈ 0.38·σ² (at τ ≈ 1.9 τ_c); overlap of log-spaced poles adds up
    spacing = np.log(taus[1] / taus[0]) if n_poles > 1 else 1.0
    sigma = b * BI_FACTOR / np.sqrt(0.38) * np.sqrt(min(1.0, spacing / 3.5))
    keys = jax.random.split(key, n_poles)
    return sum(gauss_markov(k, dt_s, sigma, t) for k, t in zip(keys, taus))


def random_drift(key, time_s, noise, dt_white=None):
    """:func:`simulate` of ``noise``, a :class:`NoiseSpec` or a truth file's noise dict (conventions §8, read by
    :meth:`NoiseSpec.from_truth`): deg/h at ``time_s`` (s), ``dt_white`` the averaging interval (s)."""
    spec = noise if isinstance(noise, NoiseSpec) else NoiseSpec.from_truth(noise)
    return simulate(spec, key, time_s, dt_white)


def simulate(spec: NoiseSpec, key, time_s, dt_white=None):
    """Sum of the random-drift processes of ``spec`` on the sample times ``time_s`` (deg/h): the one noise
    simulator.

    ``dt_white`` is the averaging interval of each sample for white and quantisation noise (default: the
    median time step); the coloured processes use the true time steps, so gaps between positions decorrelate. A
    second Gauss–Markov term draws from ``fold_in(key, i)`` of the first's key; the rate ramp is R·(t − t_0).
    """
    if spec.ar:
        raise NoiseModelError("noise model: simulating an AR colour is not implemented; use Gauss-Markov terms")
    time_s = jnp.asarray(time_s, dtype=jnp.float64)
    n = time_s.shape[0]
    steps = jnp.concatenate([jnp.zeros(1), jnp.diff(time_s)])
    if dt_white is None:
        dt_white = float(np.median(np.diff(np.asarray(time_s)))) if n > 1 else 1.0
    k_white, k_gm, k_rw, k_q, k_bi = jax.random.split(key, 5)
    out = jnp.zeros(n)
    if spec.white > 0:
        out = out + white(k_white, n, dt_white, spec.white)
    for i, (s, tau) in enumerate(spec.gauss_markov):
        if s > 0:
            out = out + gauss_markov(k_gm if i == 0 else jax.random.fold_in(k_gm, i), steps, s, tau)
    if spec.random_walk > 0:
        out = out + random_walk(k_rw, steps, spec.random_walk)
    if spec.quantization > 0:
        out = out + quantization(k_q, n, dt_white, spec.quantization)
    if spec.bias_instability > 0:
        if spec.flicker_band is None:
            raise NoiseModelError("noise model: simulating bias instability needs its flicker_band (tau_min, tau_max)")
        out = out + bias_instability(k_bi, steps, spec.bias_instability, *spec.flicker_band)
    if spec.rate_ramp > 0:
        out = out + spec.rate_ramp * (time_s - time_s[0]) / units.SECONDS_PER_HOUR
    return out
