"""FFT correlation functions (Hu 4-55 to 4-63) and AR/ARMA fitting with order selection.

References: numpy's direct correlation sums, scipy.linalg.solve_toeplitz (Yule–Walker), scipy.signal.lfilter
simulations of known models with the asymptotic standard errors of the estimators as tolerances.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import linalg, signal

from gyrojax.noise import processes as noise
from gyrojax.noise import randomdrift as rd


def _arma(rng, n, phi=(), theta=(), burn=2000):
    a = rng.normal(size=n + burn)
    x = signal.lfilter(np.r_[1.0, -np.asarray(theta, float)], np.r_[1.0, -np.asarray(phi, float)], a)
    return x[burn:]


def test_autocovariance_equals_direct_sums():
    rng = np.random.default_rng(0)
    for n in (2, 7, 100, 1023, 1024, 3001):
        x = 3.0 + rng.normal(size=n)
        xc = x - x.mean()
        direct = np.correlate(xc, xc, "full")[n - 1 :] / n  # Hu 4-61
        np.testing.assert_allclose(rd.autocovariance(x), direct, rtol=1e-10, atol=1e-12)
    y = rng.normal(size=500) + 0.5 * np.roll(x[:500], 3)
    direct = np.correlate(y - y.mean(), x[:500] - x[:500].mean(), "full")[499:] / 500  # Σ x_j y_{j+p}
    np.testing.assert_allclose(rd.cross_covariance(x[:500], y, 40), direct[:41], rtol=1e-10, atol=1e-12)
    assert float(rd.autocorrelation(x, 5)[0]) == pytest.approx(1.0, rel=1e-14)


def test_circular_autocovariance_identities():
    """r^c(p) = (1/N) Σ x_{(j+p) mod N} x_j (4-55) = r(p) + r(N − p) (4-63); r^c(p) = r^c(N − p) (4-60)."""
    rng = np.random.default_rng(1)
    n = 257
    x = rng.normal(size=n)
    xc = x - x.mean()
    rc = np.asarray(rd.circular_autocovariance(x))
    direct = np.array([np.dot(np.roll(xc, -p), xc) / n for p in range(n)])
    np.testing.assert_allclose(rc, direct, rtol=1e-10, atol=1e-12)
    r = np.asarray(rd.autocovariance(x))
    np.testing.assert_allclose(rc[1:], r[1:] + r[::-1][: n - 1], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(rc[1:], rc[1:][::-1], rtol=1e-10, atol=1e-12)


def test_levinson_equals_solve_toeplitz():
    rng = np.random.default_rng(2)
    x = _arma(rng, 5000, phi=(0.6, -0.3, 0.1))
    r = np.asarray(rd.autocovariance(x, 8))
    phis, sig, pacf = rd.levinson_durbin(r, 8)
    for p in range(1, 9):
        ref = linalg.solve_toeplitz(r[:p], r[1 : p + 1])
        np.testing.assert_allclose(phis[p - 1], ref, rtol=1e-10, atol=1e-12)
        assert sig[p] == pytest.approx(r[0] - ref @ r[1 : p + 1], rel=1e-10)
        assert pacf[p - 1] == pytest.approx(ref[-1], rel=1e-10, abs=1e-14)


N = 20000


def test_ar1_ar2_recovered_and_orders_selected():
    """Yule–Walker is asymptotically N(φ, Γ⁻¹σ²/N): AR(1) sd √((1−φ²)/N) = 0.0031 (φ = 0.9); AR(2) with
    (0.75, −0.5) sd √((1−φ2²)/N) = 0.0061 for each coefficient. Tolerance 5 sd. BIC picks the true order."""
    rng = np.random.default_rng(3)
    x1 = _arma(rng, N, phi=(0.9,))
    m1, t1 = rd.select_ar(x1, 8, "bic")
    assert (len(m1.ar), len(m1.ma)) == (1, 0) and m1.ar[0] == pytest.approx(0.9, abs=5 * math.sqrt(0.19 / N))
    assert m1.white_variance == pytest.approx(1.0, abs=5 * math.sqrt(2 / N)) and m1.method == "ar"
    assert m1.std("ar1") == pytest.approx(math.sqrt((1 - 0.9**2) / N), rel=0.05)  # the asymptotic sd of φ̂
    x2 = _arma(rng, N, phi=(0.75, -0.5))
    m2, _ = rd.select_ar(x2, 8, "bic")
    assert (len(m2.ar), len(m2.ma)) == (2, 0)
    np.testing.assert_allclose(m2.ar, [0.75, -0.5], atol=5 * math.sqrt(0.75 / N))
    np.testing.assert_allclose([m2.std("ar1"), m2.std("ar2")], math.sqrt(0.75 / N), rtol=0.05)
    m2a, ta = rd.select_ar(x2, 8, "aic")
    assert 2 <= len(m2a.ar) <= 4 and min(ta, key=ta.get) == len(m2a.ar)


def test_arma11_hannan_rissanen_and_selection():
    """ARMA(1,1), φ = 0.8, θ = 0.4 (Hu 4-122 signs): MLE asymptotic sd of φ is √((1−φ²)(1−φθ)²/(N(φ−θ)²))
    = 0.0072, of θ 0.011; Hannan–Rissanen is less efficient, so the tolerance is 0.05 (≈ 4.5 MLE sd of θ).
    Its theoretical autocovariance (Hu 4-106) matches the closed form λ_1/λ_0 = (1−φθ)(φ−θ)/(1+θ²−2φθ)."""
    rng = np.random.default_rng(4)
    x = _arma(rng, N, phi=(0.8,), theta=(0.4,))
    m = rd.fit_arma(x, 1, 1)
    assert m.ar[0] == pytest.approx(0.8, abs=0.05) and m.ma[0] == pytest.approx(0.4, abs=0.05)
    best, table = rd.select_arma(x, 2, 2, "bic")
    assert (len(best.ar), len(best.ma)) == (1, 1)
    lam = rd.model_autocovariance(rd.arma_spec([0.8], [0.4], 1.0, 0.0, N), 2)
    assert lam[1] / lam[0] == pytest.approx((1 - 0.32) * 0.4 / (1 + 0.16 - 0.64), rel=1e-9)
    assert lam[0] == pytest.approx((1 + 0.16 - 0.64) / (1 - 0.64), rel=1e-9)


def test_gauss_markov_drift_as_ar1():
    """noise.gauss_markov (σ = 0.01 deg/h, T = 60 s) at 1 s is AR(1) with φ = e^{−1/60}: the AR(1) fit gives
    back (σ, T). Over 20 000 s ≈ 330 T the sample variance has relative sd ≈ √(2T/N_s·…) ≈ 8 %, so σ within 20 %;
    φ has sd √((1−φ²)/N) = 0.0013, T = −1/ln φ then within 25 %."""
    y = np.asarray(noise.gauss_markov(jax.random.PRNGKey(9), jnp.ones(N), 0.01, 60.0))
    m = rd.fit_ar(y, 1)
    s, T = rd.ar1_to_gauss_markov(m.ar[0], m.white_variance, 1.0)
    assert s == pytest.approx(0.01, rel=0.2) and T == pytest.approx(60.0, rel=0.25)


def test_errors():
    with pytest.raises(rd.RandomDriftError):
        rd.autocovariance([1.0])
    with pytest.raises(rd.RandomDriftError):
        rd.fit_ar(np.ones(100), 2)
    with pytest.raises(rd.RandomDriftError):
        rd.ar1_to_gauss_markov(-0.5, 1.0, 1.0)
    with pytest.raises(rd.RandomDriftError):
        rd.autocovariance(np.arange(5.0), 5)
