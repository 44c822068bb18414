"""Haar wavelet variance: the closed forms against an independent spectral integration, exact arithmetic,
the continuous-time Gauss–Markov Allan variance, Monte Carlo means of simulated series (gyrojax.noise's own
generators), the estimator's covariance against the Monte Carlo covariance, and allantools' oadev."""

import math
from decimal import Decimal, getcontext

import allantools
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.noise import gmwm as gfit
from gyrojax.noise import gmwm_model as gmwm
from gyrojax.noise import processes as noise
from gyrojax.noise import wavelet as wv
from gyrojax.noise.gmwm import haar_wv
from gyrojax.noise.processes import simulate
from gyrojax.noise.spec import NoiseSpec, gauss_markov_avar


def _per_sample(white, random_walk, gm_var, gm_rate):
    """The NoiseSpec (unit sample interval) of per-sample white variance s², random-walk step variance g² and one
    AR1 of variance s² and rate a (the latent parameters of the wavelet table): N = √s²/60, K = 60√g², T = 1/a."""
    return NoiseSpec(
        white=math.sqrt(white) / 60.0,
        random_walk=60.0 * math.sqrt(random_walk),
        gauss_markov=((gm_var**0.5, 1 / gm_rate),),
    )


def _draw(spec, key, n):
    return simulate(spec, key, jnp.arange(n, dtype=float), dt_white=1.0)


def _spectral(ms, spectrum, points_per_decade=2000):
    f, w = wv.frequency_grid(max(ms), points_per_decade)
    g = wv.haar_gain2(np.asarray(ms, float)[:, None], f[None, :])
    return 2.0 * np.asarray(g @ (w * spectrum(f)))


MS = [1, 2, 3, 5, 8, 16, 64]


@pytest.mark.parametrize(
    "closed, spectrum",
    [
        (lambda m: wv.wv_white(m, 2.5), lambda f: wv.spectrum_white(f, 2.5)),
        (lambda m: wv.wv_quantization(m, 0.7), lambda f: wv.spectrum_quantization(f, 0.7)),
        (lambda m: wv.wv_random_walk(m, 0.3), lambda f: wv.spectrum_random_walk(f, 0.3)),
        (lambda m: wv.wv_gauss_markov(m, 4.0, 1.3), lambda f: wv.spectrum_gauss_markov(f, 4.0, 1.3)),
        (lambda m: wv.wv_gauss_markov(m, 4.0, 0.05), lambda f: wv.spectrum_gauss_markov(f, 4.0, 0.05)),
        (lambda m: wv.wv_gauss_markov(m, 4.0, 1e-4), lambda f: wv.spectrum_gauss_markov(f, 4.0, 1e-4)),
    ],
)
def test_closed_forms_equal_the_spectral_integral(closed, spectrum):
    """ν²(m) = ∫|G_m|²S df, integrated numerically from the process spectra (no closed form used in common)."""
    ms = np.array(MS, float)
    np.testing.assert_allclose(np.asarray(closed(ms)), _spectral(MS, spectrum), rtol=2e-5)


def test_gauss_markov_bracket_in_exact_arithmetic():
    """B/(1 − φ)² against 60-digit decimal arithmetic, on both sides of the series switch (m·a = 0.1)."""
    getcontext().prec = 60

    def exact(m, a):
        m, a = Decimal(m), Decimal(a)
        phi = (-a).exp()
        b = m * (1 - phi * phi) - 3 * phi + 4 * (-(m + 1) * a).exp() - (-(2 * m + 1) * a).exp()
        return b / (1 - phi) ** 2

    for m, a in [(1, 0.2), (1, 0.05), (100, 0.000999), (100, 0.001001), (1e4, 1e-6), (3, 1e-9), (1e5, 5e-7), (7, 2.0)]:
        assert float(wv.gm_bracket(m, a)) == pytest.approx(float(exact(m, a)), rel=1e-11)


def test_gauss_markov_tends_to_the_continuous_allan_variance():
    """Sampled finely (T = 2000 samples), 2ν² → the continuous GM Allan variance of noise.allan.gauss_markov_avar."""
    ms = np.array([200, 1000, 4000, 20000], float)
    t_c = 2000.0
    np.testing.assert_allclose(
        2 * np.asarray(wv.wv_gauss_markov(ms, 1.0, 1 / t_c)), gauss_markov_avar(ms, 1.0, t_c), rtol=3e-3
    )


def test_other_limits():
    """Random walk: 2ν² → g²m/3 (IEEE 952 K²τ/3); white 2ν² = s²/m; quantization 2ν² = 3q²/m²; drift w²m²/2."""
    m = 1e4
    assert 2 * wv.wv_random_walk(m, 1.0) == pytest.approx(m / 3, rel=1e-6)
    assert 2 * wv.wv_white(m, 3.0) == pytest.approx(3.0 / m)
    assert 2 * wv.wv_quantization(m, 2.0) == pytest.approx(6.0 / m**2)
    assert 2 * wv.wv_drift(m, 2.0) == pytest.approx(m * m)


def _mc(n, draws, gen):
    m = wv.dyadic_m(n)
    nus = np.array([haar_wv(np.asarray(gen(jax.random.PRNGKey(d))), m)[0] for d in range(draws)])
    return m, nus


def test_monte_carlo_mean_of_gyrojax_noise_generators():
    """gyrojax.noise's generators (white, Gauss–Markov, random walk, quantization in their natural units) give
    mean wavelet variances equal to the model's, within 4 standard errors of the mean at every dyadic scale."""
    dt, n, draws = 0.5, 4096, 200
    nz = {"white": 0.02, "gauss_markov": (3.0, 40.0), "random_walk": 1.5, "quantization": 2.0}
    t = jnp.arange(n) * dt
    gen = jax.jit(lambda k: noise.random_drift(k, t, nz, dt_white=dt))
    m, nus = _mc(n, draws, gen)
    spec = gmwm.ModelSpec(white=True, quantization=True, random_walk=True, n_gm=1)
    th = gmwm.theta_from_natural(
        spec, {"white": 0.02, "quantization": 2.0, "random_walk": 1.5, "gm1_sigma": 3.0, "gm1_tau": 40.0}, dt
    )
    theory = np.asarray(gmwm.model_wv(spec, jnp.asarray(th), m))
    se = nus.std(axis=0, ddof=1) / np.sqrt(draws)
    assert np.all(np.abs(nus.mean(axis=0) - theory) < 4 * se), nus.mean(axis=0) / theory
    # and the precision is real: the means are within 3 % of the theory where the standard error allows it
    tight = se / theory < 0.005
    assert tight.sum() >= 3
    np.testing.assert_allclose(nus.mean(axis=0)[tight], theory[tight], rtol=0.03)


def test_covariance_against_monte_carlo():
    """The model covariance Ω of the estimates (spectral, Percival 1995) against 300 simulated series: variances
    within 25 % (the Monte Carlo variance itself is ±8 %), adjacent-scale correlations within 0.12."""
    n, draws = 2**14, 300
    nz = _per_sample(4.0, 1e-4, 9.0, 1.0 / 60.0)
    gen = jax.jit(lambda k: _draw(nz, k, n))
    m, nus = _mc(n, draws, gen)
    spec = gmwm.ModelSpec(white=True, random_walk=True, n_gm=1)
    th = jnp.log(jnp.asarray([4.0, 1e-4, 9.0, 1.0 / 60.0]))
    _, cnt = haar_wv(np.zeros(n), m)
    om = gfit.covariance_at(spec, th, m, cnt)
    emp = np.cov(nus.T)
    np.testing.assert_allclose(np.diag(emp) / np.diag(om), 1.0, atol=0.25)
    corr = lambda c: np.diag(c / np.sqrt(np.outer(np.diag(c), np.diag(c))), 1)  # noqa: E731
    np.testing.assert_allclose(corr(emp), corr(om), atol=0.12)
    # mean of the estimates unbiased against the closed forms
    theory = np.asarray(gmwm.model_wv(spec, th, m))
    assert np.all(np.abs(nus.mean(0) - theory) < 4 * np.sqrt(np.diag(om) / draws))


def test_estimator_equals_allantools_and_model_matches_it():
    """ν̂² = oadev²/2 of allantools to rounding; on a long white + GM + RW series allantools' oadev² lies within
    4 model standard errors (2√Ω) of the model's 2ν² at every octave τ."""
    n = 2**16
    y = np.asarray(_draw(_per_sample(1.0, 1e-6, 0.5, 1.0 / 300.0), jax.random.PRNGKey(3), n))
    m = wv.dyadic_m(n)
    nu, cnt = haar_wv(y, m)
    taus, ad, _, _ = allantools.oadev(y, rate=1.0, data_type="freq", taus=m.astype(float))
    np.testing.assert_allclose(taus, m)
    np.testing.assert_allclose(nu, ad**2 / 2, rtol=1e-9)
    spec = gmwm.ModelSpec(white=True, random_walk=True, n_gm=1)
    th = jnp.log(jnp.asarray([1.0, 1e-6, 0.5, 1.0 / 300.0]))
    om = gfit.covariance_at(spec, th, m, cnt)
    model_avar = 2 * np.asarray(gmwm.model_wv(spec, th, m))
    assert np.all(np.abs(ad**2 - model_avar) < 4 * 2 * np.sqrt(np.diag(om)))


def test_factored_covariance_equals_the_averaged_gain_integral():
    """Ω from the (J, K) gain factors equals the plain (J, J, K) sum of the averaged products |G_i|²|G_j|² (sin⁴
    replaced by its mean where the grid cannot follow it: 35/128 for m_i = m_j, 7/64 for m_j = 2m_i, 9/64 otherwise,
    3/8 sin⁴ of the other when only one is fast), to rounding, padding rows (m = 1) included."""
    m = np.array([1, 2, 3, 4, 6, 8, 12, 16, 100, 200, 1000, 4096, 1.0, 1.0])
    f, w = wv.frequency_grid(4096, n_points=1500)
    spec = gmwm.ModelSpec(white=True, quantization=True, random_walk=True, n_gm=2)
    theta = np.log([2.0, 0.3, 1e-5, 4.0, 1.0 / 50.0, 1.0, 1.0 / 2000.0])
    spectrum = np.asarray(gmwm.full_spectrum(gmwm.expand(spec, theta), gmwm.spec_mask(spec), f))
    counts = 10**6 - 2 * m + 1
    fm = f[None, :] * m[:, None]
    s4 = np.sin(np.pi * fm) ** 4
    fast = fm > wv.OSCILLATION_AVERAGE
    dense = np.empty((len(m), len(m)))
    for i in range(len(m)):
        for j in range(len(m)):
            mean = 35 / 128 if m[i] == m[j] else (7 / 64 if max(m[i], m[j]) == 2 * min(m[i], m[j]) else 9 / 64)
            prod = np.where(fast[i] & fast[j], mean, s4[i] * s4[j])
            prod = np.where(fast[i] & ~fast[j], 3 / 8 * s4[j], prod)
            prod = np.where(~fast[i] & fast[j], 3 / 8 * s4[i], prod)
            g = prod / (m[i] ** 2 * m[j] ** 2 * np.sin(np.pi * f) ** 4)
            dense[i, j] = 2 * 2 * np.sum(g * w * spectrum**2) / max(counts[i], counts[j])
    om = np.asarray(wv.wv_covariance(m, counts, spectrum, f, w))
    scale = np.sqrt(np.outer(np.diag(dense), np.diag(dense)))
    assert np.all(np.diag(dense) > 0)
    np.testing.assert_allclose(om / scale, dense / scale, rtol=0, atol=1e-12)
