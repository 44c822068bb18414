"""Haar wavelet variance of a rate series: estimator, exact theoretical values of latent processes, covariance.

**Haar coefficients.** For a rate series y_k (deg/h, one sample every Δt s) and half-width m samples (scale
τ = m·Δt), the maximal-overlap Haar coefficient is W_t = (ȳ⁽²⁾ − ȳ⁽¹⁾)/2, the half difference of two adjacent
m-sample means, and the wavelet variance is ν²(τ) = E W_t². The Allan variance is twice it, σ²_A(τ) = 2ν²(τ)
(Percival & Guttorp 1994; NIST SP 1065 eq. 11), so ν̂² = σ̂²_A/2 from :func:`gyrojax.noise.allan.overlapping_avar`,
with M = n − 2m + 1 coefficients (the estimate is :func:`gyrojax.noise.gmwm.haar_wv`; this module holds the theory
and imports nothing of gyrojax).

**Exact values** (discrete time, per sample; derived here from Var(S₂ − S₁)/(4m²), S_i the two m-sample sums):

==================  ==========================  ================================================================
process             latent parameter            ν²(m)
==================  ==========================  ================================================================
white               s² per-sample variance       s² / (2m)
quantization        q² = (Q/Δt)², Q angle std    3q² / (2m²)            (y_k = (e_{k+1} − e_k)/Δt)
random walk         g² per-step variance         g² (2m² + 1) / (12m)   (Σ c_i², c = 0..m−1, m..1)
drift (ramp)        w per-sample increment       w² m² / 4
Gauss–Markov (AR1)  s² stationary, φ = e^{−a}    s² B(a, m) / (2m²(1 − φ)²),
                                                 B = m(1 − φ²) − 3φ + 4φ^{m+1} − φ^{2m+1}
==================  ==========================  ================================================================

B cancels to O((ma)³) when T = Δt/a ≫ τ; there the Taylor series B = Σ_{k≥3} c_k a^k with
c_k = (−1)^k [4(m+1)^k − (2m+1)^k − m 2^k − 3]/k! is used (c_1 = c_2 = 0, c_3 = m(2m² + 1)/3, the random-walk
limit with g² = s²(1 − φ²)).

**Spectra and covariance.** The Haar filter has squared gain |G_m(f)|² = sin⁴(πfm)/(m² sin²(πf)) (f in
cycles per sample), so ν²(m) = ∫_{−½}^{½} |G_m|² S(f) df, with the per-sample spectra S = s² (white),
4q² sin²(πf) (quantization), g²/(4 sin²(πf)) (random walk) and s²(1 − φ²)/((1 − φ)² + 4φ sin²(πf)) (AR1).
For a Gaussian series, Cov(ν̂²_i, ν̂²_j) ≈ (2/max(M_i, M_j)) ∫_{−½}^{½} |G_i|²|G_j|² S² df (Percival 1995,
the large-M limit of 2 Σ_h Cov(W_i,t, W_j,t+h)²/M); :func:`wv_covariance` integrates it on a log grid in f.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

SERIES_LIMIT = 0.1
"""m·a below which the Gauss–Markov ν² uses the Taylor series of B (truncation error < 1e-13 relative)."""

SERIES_ORDER = 12


# ---- exact theoretical wavelet variances (per sample, m = half-width in samples) -------------------------------


def wv_white(m, s2):
    """ν² ((deg/h)²) of white rate noise of per-sample variance ``s2`` at half-width ``m`` samples."""
    return s2 / (2.0 * m)


def wv_quantization(m, q2):
    """ν² of differenced white angle error, y_k = (e_{k+1} − e_k)/Δt, with q² = Var(e)/Δt² ((deg/h)²)."""
    return 1.5 * q2 / (m * m)


def wv_random_walk(m, g2):
    """ν² of a rate random walk with per-step increment variance ``g2`` ((deg/h)²)."""
    return g2 * (2.0 * m * m + 1.0) / (12.0 * m)


def wv_drift(m, w2):
    """ν² of a rate ramp y_k = w·k (``w2`` = w², (deg/h)² per sample²): (w m / 2)²."""
    return w2 * m * m / 4.0


def gm_bracket(m, a):
    """B(a, m)/(1 − φ)² of the AR1 wavelet variance (dimensionless), φ = e^{−a}, m in samples; closed form, or
    the Taylor series where it cancels (m·a < :data:`SERIES_LIMIT`)."""
    m = jnp.asarray(m, dtype=jnp.float64)
    a = jnp.asarray(a, dtype=jnp.float64)
    small = m * a < SERIES_LIMIT
    a_big = jnp.where(small, 1.0, a)  # safe inputs for the branch not taken (finite gradients)
    a_sml = jnp.where(small, a, 0.0)
    phi = jnp.exp(-a_big)
    one_m_phi = -jnp.expm1(-a_big)
    big = m * (-jnp.expm1(-2.0 * a_big)) - 3.0 * phi
    big = big + 4.0 * jnp.exp(-(m + 1.0) * a_big) - jnp.exp(-(2.0 * m + 1.0) * a_big)
    big = big / (one_m_phi * one_m_phi)
    # series: Σ_{k≥3} c_k a^k, divided by (1 − φ)² = a²(1 − a/2 + a²/6 − …)² (exact expm1 form)
    ser = jnp.zeros_like(a_sml * m)
    for k in range(SERIES_ORDER, 2, -1):
        ck = (-1.0) ** k * (4.0 * (m + 1.0) ** k - (2.0 * m + 1.0) ** k - m * 2.0**k - 3.0) / math.factorial(k)
        ser = ser * a_sml + ck
    # ser now holds Σ c_k a^{k−3}; B/(1−φ)² = a ser / ((1−φ)/a)²
    ratio = jnp.where(a_sml > 0, -jnp.expm1(-a_sml) / jnp.where(a_sml > 0, a_sml, 1.0), 1.0)
    small_val = a_sml * ser / (ratio * ratio)
    return jnp.where(small, small_val, big)


@jax.jit
def wv_gauss_markov(m, s2, a):
    """ν² of a stationary AR1 (first-order Gauss–Markov) of variance ``s2``, φ = e^{−a}, a = Δt/T."""
    return s2 * gm_bracket(m, a) / (2.0 * jnp.asarray(m, dtype=jnp.float64) ** 2)


# ---- spectra (per sample, f in cycles per sample) --------------------------------------------------------------


def haar_gain2(m, f):
    """|G_m(f)|² = sin⁴(πfm)/(m² sin²(πf)) of the Haar wavelet filter of half-width m (f in cycles/sample)."""
    return jnp.sin(jnp.pi * f * m) ** 4 / (m * m * jnp.sin(jnp.pi * f) ** 2)


def spectrum_white(f, s2):
    """S(f) of white noise, (deg/h)² per cycle/sample."""
    return jnp.full_like(f, 1.0) * s2


def spectrum_quantization(f, q2):
    """S(f) of the differenced white angle error, 4q² sin²(πf), (deg/h)² per cycle/sample."""
    return 4.0 * q2 * jnp.sin(jnp.pi * f) ** 2


def spectrum_random_walk(f, g2):
    """Pseudo-spectrum g²/(4 sin²(πf)) of the random walk (the Haar filter makes every integral finite)."""
    return g2 / (4.0 * jnp.sin(jnp.pi * f) ** 2)


def spectrum_gauss_markov(f, s2, a):
    """S(f) of a stationary AR1 of variance s², φ = e^{−a}: s²(1 − φ²)/((1 − φ)² + 4φ sin²(πf))."""
    phi = jnp.exp(-a)
    p = -jnp.expm1(-a)
    return s2 * (-jnp.expm1(-2.0 * a)) / (p * p + 4.0 * phi * jnp.sin(jnp.pi * f) ** 2)


def frequency_grid(m_max, points_per_decade: int = 400, n_points: int | None = None):
    """Log grid on (0, ½] for the spectral integrals: (f, weights) with ∫₀^½ g df ≈ Σ w g(f).

    From f_lo = 1e-4/m_max (the part below f_lo taken as a rectangle, where |G|⁴S² is flat for the random walk
    and vanishes for the others) to ½, trapezoid rule in ln f; ``n_points`` fixes the number of points instead
    (one shape for every m_max: one compilation of the covariance).
    """
    f_lo = 1e-4 / float(m_max)
    k = n_points or int(points_per_decade * math.log10(0.5 / f_lo)) + 1
    lf = np.linspace(math.log(f_lo), math.log(0.5), k)
    f = np.exp(lf)
    h = np.diff(lf)
    w = np.zeros(k)
    w[:-1] += h / 2
    w[1:] += h / 2
    w = w * f
    w[0] += f_lo  # [0, f_lo]
    return f, w


OSCILLATION_AVERAGE = 20.0
"""f·m above which sin⁴(πfm) is replaced by its mean in the covariance integral (the grid cannot follow it)."""


@jax.jit
def gain_factors(ms, f):
    """Factors (a, b), each (J, K), of the averaged products |G_i|²|G_j|² on the grid ``f`` (half-widths ``ms``).

    With a_ik = s_ik/(m_i² sin²πf_k), s_ik = sin⁴(πf_k m_i) where the grid follows it and its mean 3/8 where it
    oscillates faster (f·m > :data:`OSCILLATION_AVERAGE`), and b_ik = [f_k m_i > OSCILLATION_AVERAGE]/(m_i² sin²πf_k):
    |G_i|²|G_j|² ≈ a_i a_j + (μ_ij − 9/64) b_i b_j, where μ_ij, the mean of sin⁴(πfm_i) sin⁴(πfm_j) when both
    oscillate fast, is 35/128 for m_i = m_j, 7/64 for m_j = 2m_i (shared harmonic) and 9/64 = (3/8)² otherwise.
    The (J, J, K) products are never formed: :func:`wv_covariance` needs two (J, K)·(K, J) products.
    """
    ms = jnp.asarray(ms, dtype=jnp.float64)
    s2f = jnp.sin(jnp.pi * f) ** 2
    fast = f[None, :] * ms[:, None] > OSCILLATION_AVERAGE
    s4 = jnp.sin(jnp.pi * f[None, :] * ms[:, None]) ** 4
    scale = (ms * ms)[:, None] * s2f[None, :]
    return jnp.where(fast, 3.0 / 8.0, s4) / scale, jnp.where(fast, 1.0, 0.0) / scale


def wv_covariance(ms, counts, spectrum, f, w, factors=None):
    """Asymptotic covariance (J, J) of the Haar wavelet variance estimates at half-widths ``ms`` (Percival 1995).

    ``counts`` the number of coefficients M of each estimate; ``spectrum`` S(f) of the rate series on the grid
    ``f`` with weights ``w`` (:func:`frequency_grid`); ``factors`` from :func:`gain_factors` (recomputed if None).
    Cov_ij = (2/max(M_i, M_j)) · 2∫₀^½ |G_i|²|G_j|² S² df, in (deg/h)⁴, the fast oscillations averaged.
    """
    ms = jnp.asarray(ms, dtype=jnp.float64)
    a, b = gain_factors(ms, f) if factors is None else factors
    c = w * spectrum * spectrum
    mi, mj = ms[:, None], ms[None, :]
    harmonic = jnp.where(mi == mj, 35.0 / 128.0, jnp.where((mj == 2 * mi) | (mi == 2 * mj), 7.0 / 64.0, 9.0 / 64.0))
    integral = 2.0 * ((a * c) @ a.T + (harmonic - 9.0 / 64.0) * ((b * c) @ b.T))
    counts = jnp.asarray(counts, dtype=jnp.float64)
    return 2.0 * integral / jnp.maximum(counts[:, None], counts[None, :])


# ---- estimator ------------------------------------------------------------------------------------------------


def dyadic_m(n: int, max_fraction: float = 0.125) -> np.ndarray:
    """Half-widths m = 1, 2, 4, … with 2m ≤ n·2·``max_fraction`` (default: m ≤ n/8, so M ≥ 3n/4)."""
    m_max = max(1, int(n * max_fraction))
    return 2 ** np.arange(int(math.floor(math.log2(m_max))) + 1)
