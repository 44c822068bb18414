"""Random drift processes (CONVENTIONS §6, IEEE 952 annex C), generated in JAX.

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
from gyrojax.errors import TruthError

NOISE_NAMES = ("white", "gauss_markov", "random_walk", "quantization", "bias_instability")


def validate_noise(noise: dict | None, where: str = "noise") -> dict:
    """Check a noise dict (truth files, CONVENTIONS §8) and return it with floats."""
    noise = dict(noise or {})
    out = {}
    for k, v in noise.items():
        if k not in NOISE_NAMES:
            raise TruthError(f"{where}: unknown noise term {k!r}; valid: {', '.join(NOISE_NAMES)}")
        if k == "gauss_markov":
            if not isinstance(v, (list, tuple)) or len(v) != 2:
                raise TruthError(f"{where}.gauss_markov must be [sigma_deg_per_h, tau_s], got {v!r}")
            s, tau = float(v[0]), float(v[1])
            if s < 0 or tau <= 0:
                raise TruthError(f"{where}.gauss_markov needs sigma >= 0 and tau > 0, got {v!r}")
            out[k] = (s, tau)
        elif k == "bias_instability":
            if not isinstance(v, (list, tuple)) or len(v) != 3:
                raise TruthError(f"{where}.bias_instability must be [B_deg_per_h, tau_min_s, tau_max_s], got {v!r}")
            out[k] = tuple(float(x) for x in v)
        else:
            x = float(v)
            if not np.isfinite(x) or x < 0:
                raise TruthError(f"{where}.{k} must be a finite number >= 0, got {v!r}")
            out[k] = x
    return out


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

    Each pole carries variance so that the Allan floor is ≈ 0.664·b (IEEE 952: σ_min = B·√(2 ln 2/π)).
    """
    taus = np.geomspace(tau_min, tau_max, n_poles)
    # one GM of σ² gives a peak Allan variance ≈ 0.38·σ² (at τ ≈ 1.9 τ_c); overlap of log-spaced poles adds up
    spacing = np.log(taus[1] / taus[0]) if n_poles > 1 else 1.0
    sigma = b * 0.664 / np.sqrt(0.38) * np.sqrt(min(1.0, spacing / 3.5))
    keys = jax.random.split(key, n_poles)
    return sum(gauss_markov(k, dt_s, sigma, t) for k, t in zip(keys, taus))


def random_drift(key, time_s, noise: dict, dt_white=None):
    """Sum of the random-drift processes of ``noise`` on the sample times ``time_s`` (deg/h).

    ``dt_white`` is the averaging interval of each sample for white and quantisation noise (default: the
    median time step); the coloured processes use the true time steps, so gaps between positions decorrelate.
    """
    noise = validate_noise(noise)
    time_s = jnp.asarray(time_s, dtype=jnp.float64)
    n = time_s.shape[0]
    steps = jnp.concatenate([jnp.zeros(1), jnp.diff(time_s)])
    if dt_white is None:
        dt_white = float(np.median(np.diff(np.asarray(time_s)))) if n > 1 else 1.0
    k_white, k_gm, k_rw, k_q, k_bi = jax.random.split(key, 5)
    out = jnp.zeros(n)
    if noise.get("white", 0.0) > 0:
        out = out + white(k_white, n, dt_white, noise["white"])
    if "gauss_markov" in noise and noise["gauss_markov"][0] > 0:
        out = out + gauss_markov(k_gm, steps, *noise["gauss_markov"])
    if noise.get("random_walk", 0.0) > 0:
        out = out + random_walk(k_rw, steps, noise["random_walk"])
    if noise.get("quantization", 0.0) > 0:
        out = out + quantization(k_q, n, dt_white, noise["quantization"])
    if "bias_instability" in noise and noise["bias_instability"][0] > 0:
        out = out + bias_instability(k_bi, steps, *noise["bias_instability"])
    return out
