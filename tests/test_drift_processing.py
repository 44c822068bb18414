"""Hu ch. 4 §1 moving-average rate (4-5 to 4-11) and ch. 6 §2 Kalman running mean (6-21 to 6-23)."""

import numpy as np
import pytest

from gyrojax.seeds import drift_processing as dp


@pytest.mark.parametrize("omega, n", [(0.05, 20), (0.3, 10), (1.1, 8), (2.0, 31)])
def test_moving_average_gain_is_sinc_without_phase_error(omega, n):
    # θ = A sin ωt (Hu 4-8); the estimate must be K·Aω cos ωt at the window midpoints (Hu 4-10, 4-11).
    dt, a = 0.05, 3.0
    t = np.arange(4000) * dt
    t_mid, rate = dp.moving_average_rate(a * np.sin(omega * t), dt, n)
    window = n * dt
    k_book = np.sin(omega * window / 2) / (omega * window / 2)  # Hu 4-11 typed from the seed
    expected = k_book * a * omega * np.cos(omega * np.asarray(t_mid))
    np.testing.assert_allclose(rate, expected, atol=1e-12)
    np.testing.assert_allclose(dp.moving_average_gain(omega, window), k_book, rtol=1e-14)


def test_moving_average_gain_fitted_amplitude():
    # Independent route: least-squares amplitude of cos/sin in the estimate → ratio = K, sine part (phase) = 0.
    dt, omega, n = 0.01, 7.0, 50
    t = np.arange(20000) * dt
    tm, rate = dp.moving_average_rate(np.sin(omega * t), dt, n)
    design = np.column_stack([np.cos(omega * tm), np.sin(omega * tm)])
    (c, s), *_ = np.linalg.lstsq(design, np.asarray(rate), rcond=None)
    assert c / omega == pytest.approx(np.sin(omega * n * dt / 2) / (omega * n * dt / 2), abs=1e-10)
    assert abs(s) < 1e-10


def test_moving_average_rate_noise_monte_carlo():
    # White angle error ε → rate std √2 ε/ΔT (two independent readings; Hu 4-2 gives the one-reading ε/ΔT).
    rng = np.random.default_rng(1)
    eps, dt, n = 2.0, 0.1, 25
    theta = 0.5 * np.arange(200_000) * dt + rng.normal(0, eps, 200_000)
    _, rate = dp.moving_average_rate(theta, dt, n)
    rate = np.asarray(rate)
    assert rate.mean() == pytest.approx(0.5, abs=0.01)
    std_expected = float(dp.moving_average_rate_noise_std(eps, n * dt))
    assert std_expected == pytest.approx(np.sqrt(2) * 2.0 / 2.5)
    assert rate.std() == pytest.approx(std_expected, rel=0.01)


def test_moving_average_white_rate_noise_bandwidth():
    # White rate noise through the moving average: variance = q·∫K(2πf)² df (Hu 4-11 as a power gain), which
    # scipy's quadrature evaluates to q/ΔT; and a Monte Carlo of an angle random walk agrees.
    from scipy.integrate import quad

    window = 2.0
    half, _ = quad(lambda f: float(dp.moving_average_gain(2 * np.pi * f, window)) ** 2, 0, 200, limit=2000)
    assert 2 * half == pytest.approx(1 / window, rel=2e-3)  # tail beyond 200 Hz is ≈ 1/(π² ΔT²·200) of it
    rng = np.random.default_rng(6)
    arw, dt, n = 0.3, 0.01, 200
    theta = np.cumsum(rng.normal(0, arw * np.sqrt(dt), 400_000))
    _, rate = dp.moving_average_rate(theta, dt, n)
    assert float(np.std(rate)) == pytest.approx(
        float(dp.moving_average_arw_std(arw, n * dt)), rel=0.05
    )  # ~2000 independent windows: 1.6 % std error


def test_kalman_recursion_matches_book_closed_forms():
    # Hu 6-22: p_k = p0 R/(k p0 + R), K_k = p0/((k+1) p0 + R), for an arbitrary (not large) prior.
    p0, r = 3.0, 10.0
    z = np.linspace(-1, 1, 25)
    _, p, g = dp.kalman_running_mean(z, r, p0)
    k = np.arange(25)
    np.testing.assert_allclose(g, p0 / ((k + 1) * p0 + r), rtol=1e-13)
    np.testing.assert_allclose(p, p0 * r / ((k + 1) * p0 + r), rtol=1e-13)
    np.testing.assert_allclose(dp.kalman_gain(k, p0, r), g, rtol=1e-13)
    np.testing.assert_allclose(dp.kalman_variance(k + 1, p0, r), p, rtol=1e-13)


def test_kalman_large_prior_is_running_mean_and_book_example():
    # Hu 6-23: with p0 ≫ R the estimate is the arithmetic mean; 10 sec² → 1 sec² after ten averages.
    rng = np.random.default_rng(2)
    z = 100.0 + rng.normal(0, np.sqrt(10.0), 40)
    x, p, g = dp.kalman_running_mean(z, 10.0, 1e12)
    np.testing.assert_allclose(x, np.cumsum(z) / np.arange(1, 41), rtol=1e-9)  # prior weight R/p0 = 1e-11
    np.testing.assert_allclose(g[:10], 1 / np.arange(1, 11), rtol=1e-10)
    assert float(p[9]) == pytest.approx(1.0, rel=1e-10)  # ten readings of 10 sec² → 1 sec²


def test_kalman_variance_monte_carlo():
    # The filter's own variance p_k must equal the Monte Carlo mean-square error (finite prior, correct prior draw).
    rng = np.random.default_rng(3)
    p0, r, trials = 4.0, 10.0, 20000
    theta = rng.normal(0, np.sqrt(p0), trials)
    z = theta[:, None] + rng.normal(0, np.sqrt(r), (trials, 10))
    import jax

    x, p, _ = jax.vmap(lambda zz: dp.kalman_running_mean(zz, r, p0))(z)
    mse = np.mean((np.asarray(x)[:, -1] - theta) ** 2)
    assert mse == pytest.approx(float(p[0, -1]), rel=0.03)  # 2.5 % is about 1.8 σ of the MSE estimate


def test_centered_average_unbiased_for_ramp_and_ten_to_one():
    rng = np.random.default_rng(4)
    m = 200_000
    ramp = 0.37 * np.arange(m)
    est = np.asarray(dp.centered_average(ramp, 5))
    np.testing.assert_allclose(est, ramp[5 : m - 5], atol=1e-7)  # constant-rate θ: no bias
    noisy = np.asarray(dp.centered_average(ramp + rng.normal(0, np.sqrt(10.0), m), 5)) - ramp[5 : m - 5]
    # each estimate uses 10 independent readings: 10 sec² → 1 sec² (the overlap correlates neighbours only)
    assert noisy.var() == pytest.approx(1.0, rel=0.02)
