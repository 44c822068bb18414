"""The covariance of the mean rates over static intervals (positions) of a random drift, in IEEE 952 units
(:class:`~gyrojax.noise.spec.NoiseSpec`'s: N deg/√h, Q arcsec, σ deg/h, T s, K deg/h/√h, B deg/h): the closed forms
:meth:`~gyrojax.noise.spec.NoiseSpec.mean_covariance` sums, for a design's Fisher information over the plan's time
line (:mod:`gyrojax.planning.fisher`) and a Monte Carlo study's GLS of the position means
(:mod:`gyrojax.montecarlo.pipeline`). Pure JAX, differentiable in the interval starts and spans.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from gyrojax.units import SECONDS_PER_HOUR


def gm_mean_factor(x):
    """f(x) = 2(x − 1 + e^{−x})/x²: Var(mean of a GM process over T)/σ², x = T/τ (→ 1 as x → 0, → 2/x)."""
    x = jnp.asarray(x, dtype=jnp.float64)
    small = x < 1e-4
    xs = jnp.where(small, 1.0, x)
    big = 2.0 * (xs - 1.0 + jnp.exp(-xs)) / (xs * xs)
    return jnp.where(small, 1.0 - x / 3.0, big)


FLICKER_POLES_PER_DECADE = 6
"""Gauss–Markov poles per decade of τ in the flicker floor's expansion (:func:`flicker_poles`)."""


def flicker_poles(b, band, per_decade: int = FLICKER_POLES_PER_DECADE) -> tuple:
    """The flicker floor of bias instability ``b`` (deg/h) over ``band`` = (τ_min, τ_max) s as Gauss–Markov terms
    ((σ deg/h, T s), …): the 1/f rate as a continuous mixture of Gauss–Markov processes of uniform variance density
    ρ = B²/π per unit ln T on [τ_min, τ_max] (two-sided spectrum S(f) = (B²/π²f)[atan 2πfτ_max − atan 2πfτ_min],
    → B²/(2πf) inside the band, whose Allan variance is IEEE 952 C.1's floor (2 ln 2/π)B²), by the midpoint rule
    on ln T with ``per_decade`` poles per decade (each σ² = ρ·Δln T)."""
    t0, t1 = float(band[0]), float(band[1])
    k = max(1, int(math.ceil(per_decade * math.log10(t1 / t0)))) if t1 > t0 else 1
    h = math.log(t1 / t0) / k if t1 > t0 else 1.0
    s = math.sqrt(b * b / math.pi * h)
    return tuple((s, t0 * math.exp((i + 0.5) * h)) for i in range(k))


def flicker_spectrum(f, b, band):
    """Two-sided rate spectrum ((deg/h)²/Hz) at ``f`` Hz of the flicker floor of :func:`flicker_poles`, its exact
    (un-discretised) form."""
    f = np.abs(np.asarray(f, float))
    w = 2.0 * math.pi * f
    return b * b / (math.pi**2 * f) * (np.arctan(w * band[1]) - np.arctan(w * band[0]))


def _pairs(n):
    """(upper, eye) boolean masks of an n × n matrix."""
    i = jnp.arange(n)
    return i[:, None] < i[None, :], i[:, None] == i[None, :]


def gm_mean_covariance(start_s, span_s, sigma, tau, sample_s=None):
    """(n, n) covariance ((deg/h)²) of the means of a Gauss–Markov rate (autocovariance σ² e^{−|t−s|/T}) over the
    intervals [start_k, start_k + span_k) (s; in time order, not overlapping).

    Continuous (``sample_s`` None): Var = σ² f(span/T) (:func:`gm_mean_factor`, the double integral over one
    interval); Cov = σ² g_a g_b e^{−gap/T}, g = T(1 − e^{−span/T})/span, gap from the end of a to the start of b.
    Sampled every ``sample_s`` = Δ s (n = span/Δ point samples, φ = e^{−Δ/T}: the simulator's process):
    Var = σ²[n(1 − φ²) − 2φ(1 − φⁿ)]/(n(1 − φ))², g = (1 − φⁿ)/(n(1 − φ)), gap from the last sample of a."""
    start, span = jnp.asarray(start_s, jnp.float64), jnp.asarray(span_s, jnp.float64)
    upper, eye = _pairs(span.shape[0])
    if sample_s is None:
        g = -tau * jnp.expm1(-span / tau) / span
        diag = gm_mean_factor(span / tau)
        last = start + span
    else:
        n = span / sample_s
        phi = jnp.exp(-sample_s / tau)
        pn = -jnp.expm1(-n * sample_s / tau)  # 1 − φⁿ
        g = pn / (n * (1.0 - phi))
        diag = (n * (1.0 - phi * phi) - 2.0 * phi * pn) / (n * (1.0 - phi)) ** 2
        last = start + span - sample_s
    gap = start[None, :] - last[:, None]
    lag = jnp.where(eye, 0.0, jnp.where(upper, gap, gap.T))
    off = g[:, None] * g[None, :] * jnp.exp(-lag / tau)
    return sigma**2 * jnp.where(eye, diag[:, None], off)


def rw_mean_covariance(start_s, span_s, k, sample_s=None):
    """(n, n) covariance ((deg/h)²) of the means of a rate random walk K (deg/h/√h) that is 0 at t = 0 (the
    record's first sample: Cov(r(t), r(s)) = (K²/3600)·min(t, s), t in s) over the intervals of
    :func:`gm_mean_covariance`. Continuous: Var = q(a + T/3), Cov = q·(a + T_a/2) (the mean time of the earlier
    interval), q = K²/3600; sampled every Δ s: Var = q[a + Δ(n − 1)(2n − 1)/(6n)], Cov = q(a + (n_a − 1)Δ/2). A
    constant in the fitted model absorbs the walk's value at t = 0, so the time origin does not change a fit's
    other coefficients."""
    start, span = jnp.asarray(start_s, jnp.float64), jnp.asarray(span_s, jnp.float64)
    _, eye = _pairs(span.shape[0])
    if sample_s is None:
        mid, var = start + span / 2.0, start + span / 3.0
    else:
        n = span / sample_s
        mid = start + (n - 1.0) * sample_s / 2.0
        var = start + sample_s * (n - 1.0) * (2.0 * n - 1.0) / (6.0 * n)
    q = k * k / SECONDS_PER_HOUR
    return q * jnp.where(eye, var[:, None], jnp.minimum(mid[:, None], mid[None, :]))


def quantization_mean_covariance(span_s, q_arcsec, contiguous: bool = True):
    """(n, n) covariance ((deg/h)²) of the means of the quantisation rate (e_{k+1} − e_k)/Δ (angle error e of
    std Q arcsec, IEEE 952 C.3): a mean over T s is (e_end − e_start)/T, Var = 2Q²/T²; consecutive intervals of one
    sampled series share an end angle (``contiguous``: the simulator's samples, gaps unlogged), Cov = −Q²/(T_a T_b)."""
    span = jnp.asarray(span_s, jnp.float64)
    n = span.shape[0]
    out = jnp.diag(2.0 * q_arcsec**2 / span**2)
    if contiguous and n > 1:
        c = -(q_arcsec**2) / (span[:-1] * span[1:])
        out = out + jnp.diag(c, 1) + jnp.diag(c, -1)
    return out
