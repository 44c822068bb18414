"""Allan variance, confidence intervals, the IEEE 952 noise fit, and the random-drift generators.

References nobody here wrote: ``allantools`` (oadev, NIST SP 1065 Table 5 EDF, chi-square intervals),
``scipy.integrate.quad`` of the IEEE 952 eq. (C.2) PSD integral, the closed-form Allan variances of IEEE 952
annex C, and Monte Carlo coverage with binomial tolerances.
"""

import math

import allantools
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.optimize
from allantools import ci as at_ci
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from gyrojax.noise import allan
from gyrojax.noise import processes as noise
from gyrojax.noise.spec import gauss_markov_avar


def _gm_series(rng, n, phi, sigma):
    x = np.empty(n)
    x[0] = sigma * rng.normal()
    e = rng.normal(size=n) * sigma * math.sqrt(1 - phi * phi)
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


@pytest.mark.parametrize("kind", ["white", "random_walk", "gauss_markov"])
def test_oadev_equals_allantools(kind):
    rng = np.random.default_rng(7)
    n, tau0 = 6000, 0.25
    y = {
        "white": 5.0 + 0.3 * rng.normal(size=n),
        "random_walk": 100.0 + np.cumsum(rng.normal(size=n)),
        "gauss_markov": _gm_series(rng, n, 0.98, 2.0) - 3.0,
    }[kind]
    m = np.concatenate([allan.default_m_list(n), [3, 17, 250, 1999]])
    m = np.unique(m)
    ours = np.asarray(allan.overlapping_adev(y, tau0, m))
    taus, ref, _, ns = allantools.oadev(y, rate=1 / tau0, data_type="freq", taus=m * tau0)
    np.testing.assert_allclose(taus, m * tau0)
    np.testing.assert_allclose(ours, ref, rtol=1e-9, atol=0)
    _, count = allan.overlapping_avar(y, tau0, m)
    np.testing.assert_array_equal(np.asarray(count), ns)


def test_oadev_is_jittable_and_pooled_equals_single():
    rng = np.random.default_rng(1)
    y = rng.normal(size=1000)
    f = jax.jit(lambda r: allan.overlapping_adev(r, 1.0, jnp.array([1, 2, 5])))
    np.testing.assert_allclose(f(jnp.asarray(y)), allan.overlapping_adev(y, 1.0, [1, 2, 5]), rtol=1e-14)
    # pooling two segments: Σ S_j / (2τ² Σ M_j), checked against allantools' per-segment sums
    a, b = y[:600], y[600:]
    res = allan.allan([a, b], 1.0, m_list=[1, 4, 50])
    num = den = 0.0
    for seg in (a, b):
        _, d, _, ns = allantools.oadev(seg, rate=1.0, data_type="freq", taus=np.array([1.0, 4.0, 50.0]))
        num, den = num + d**2 * ns, den + ns
    np.testing.assert_allclose(res.avar, num / den, rtol=1e-10)


def test_host_and_compiled_kernels_agree():
    """The numpy path (concrete arrays) and the compiled path (JAX arrays, tracers) of the overlapping Allan
    variance agree to rounding, at every m up to and beyond the longest (2m = n − 1 and 2m > n: M = 0), for a
    large offset (cancellation in the angle series) and a sample interval that is not 1."""
    rng = np.random.default_rng(11)
    n, tau0 = 5001, 0.01
    y = 3e3 + np.cumsum(rng.normal(size=n)) + rng.normal(size=n)
    m = np.array([1, 2, 3, 7, 64, 1000, 2499, 2500, 2501, 4000])
    host_avar, host_count = allan.overlapping_avar(y, tau0, m)
    jit_avar, jit_count = jax.jit(lambda r: allan.overlapping_avar(r, tau0, m))(jnp.asarray(y))
    assert isinstance(host_avar, np.ndarray)
    np.testing.assert_array_equal(host_count, np.asarray(jit_count))
    np.testing.assert_array_equal(host_count, np.maximum(n + 1 - 2 * m, 0))
    ok = host_count > 0
    np.testing.assert_allclose(host_avar[ok], np.asarray(jit_avar)[ok], rtol=1e-12)
    np.testing.assert_array_equal(host_avar[~ok], 0.0)
    # and against the textbook double loop on a short piece (no cumulative sums)
    z = y[:300]
    theta = np.concatenate([[0.0], np.cumsum((z - z.mean()) * tau0)])
    for mm in (1, 5, 149):
        d = [theta[i + 2 * mm] - 2 * theta[i + mm] + theta[i] for i in range(301 - 2 * mm)]
        ref = math.fsum(x * x for x in d) / (2 * (mm * tau0) ** 2 * len(d))
        np.testing.assert_allclose(allan.overlapping_avar(z, tau0, [mm])[0][0], ref, rtol=1e-12)


def test_edf_and_interval_match_allantools():
    for N in (101, 1001, 36001):
        for m in (1, 2, 7, 30, N // 4):
            for alpha in (2, 1, 0, -1, -2):
                ref = at_ci.edf_simple(N, m, alpha)
                assert allan.edf_simple(N, m, alpha) == pytest.approx(ref, rel=1e-12)
    for edf in (1.3, 4.0, 55.0, 3000.0):
        lo, hi = allan.confidence_interval(2.0, edf, 0.9)
        rlo, rhi = at_ci.confidence_interval(2.0, edf, 0.9)
        assert (lo, hi) == (pytest.approx(rlo, rel=1e-12), pytest.approx(rhi, rel=1e-12))


def test_interval_coverage_white_noise():
    """68.3 % intervals cover the true ADEV of white noise at the binomial rate (400 records, ±4σ) for
    m ≤ n/10; at m = 0.3 n the simple EDF (NIST SP 1065 Table 5) is low, so the interval is wider than needed
    (measured coverage 0.785): conservative, never below the nominal rate."""
    rng = np.random.default_rng(3)
    n, reps, m = 2000, 400, np.array([1, 10, 100, 200, 600])
    ys = rng.normal(size=(reps, n))
    hits = np.zeros(len(m))
    for y in ys:
        r = allan.allan(y, 1.0, m_list=m, alpha=0)
        truth = 1.0 / np.sqrt(m)
        hits += (r.low <= truth) & (truth <= r.high)
    p = allan.ONE_SIGMA
    tol = 4 * math.sqrt(p * (1 - p) / reps)
    np.testing.assert_array_less(np.abs(hits[:-1] / reps - p), tol)
    assert p - tol < hits[-1] / reps < 0.9


# ---- closed forms and the generators (IEEE 952 annex C) -------------------------------------------------------


def test_gauss_markov_avar_against_psd_integral():
    """σ²(τ) = 4∫ S(f) sin⁴(πfτ)/(πfτ)² df (IEEE 952 C.2) with the two-sided GM PSD 2σ²T/(1 + (2πfT)²)."""
    sigma, T = 0.7, 30.0
    for tau in (0.01, 1.0, 30.0, 57.0, 400.0, 1e4):

        def integrand(f):
            x = math.pi * f * tau
            return 4 * 2 * sigma**2 * T / (1 + (2 * math.pi * f * T) ** 2) * math.sin(x) ** 4 / x**2

        edges = np.concatenate([[0.0], np.arange(1, 400) / tau])
        ref = sum(integrate.quad(integrand, a, b, limit=200)[0] for a, b in zip(edges[:-1], edges[1:], strict=True))
        ref += integrate.quad(integrand, edges[-1], np.inf, limit=200)[0]
        assert gauss_markov_avar(tau, sigma, T) == pytest.approx(ref, rel=2e-3)
    x = np.geomspace(0.1, 20, 20001)
    v = gauss_markov_avar(x, 1.0, 1.0)
    assert v.max() == pytest.approx(0.3811, abs=2e-4) and x[v.argmax()] == pytest.approx(1.8923, rel=1e-3)


def _within(res, truth_adev, k=4.0, extra=0.0):
    """Truth inside the estimate's ±kσ chi-square band (plus a relative model allowance ``extra``)."""
    p = math.erf(k / math.sqrt(2))
    lo, hi = allan.confidence_interval(res.adev, res.edf, p)
    return np.all((lo * (1 - extra) <= truth_adev) & (truth_adev <= hi * (1 + extra)))


def test_generators_follow_ieee952_slopes():
    """noise.white, quantization, random_walk, gauss_markov against their IEEE 952 Allan variances.

    white N (deg/√h): σ(τ) = N/√τ_h = 60 N/√τ deg/h; quantization Q (arcsec): √3 Q/τ (1 arcsec/s = 1 deg/h);
    rate random walk K (deg/h/√h): K √(τ_h/3); Gauss–Markov: the exact formula checked above.
    """
    n, dt = 36000, 1.0
    keys = jax.random.split(jax.random.PRNGKey(11), 4)
    m = np.array([1, 3, 10, 30, 100, 300, 1000])
    tau = m * dt
    y = np.asarray(noise.white(keys[0], n, dt, 0.01))
    assert _within(allan.allan(y, dt, m, alpha=0), 0.01 * 60 / np.sqrt(tau))
    y = np.asarray(noise.quantization(keys[1], n, dt, 0.5))
    assert _within(allan.allan(y, dt, m, alpha=2), math.sqrt(3) * 0.5 / tau)
    y = np.asarray(noise.random_walk(keys[2], jnp.full(n, dt), 0.2))
    mm = m[m >= 10]  # the sampled random walk has σ² = K²τ/3·(1 + 1/(2m²)); negligible from m = 10
    assert _within(allan.allan(y, dt, mm, alpha=-2), 0.2 * np.sqrt(mm * dt / 3600 / 3))
    # noise.gauss_markov returns *point* samples of the AR(1) x_k = φ x_{k−1} + …, not interval averages (as
    # the noise module's docstring says of every generator): its exact Allan variance is the discrete one,
    # which exceeds the continuous IEEE 952 formula by 22 % in σ at m = 1 (T = 50 Δt) and by < 1 % from m = 10.
    y = np.asarray(noise.gauss_markov(keys[3], jnp.full(n, dt), 0.3, 50.0))
    r = allan.allan(y, dt, m, alpha=-2)  # RW-FM EDF is the smallest of the table: conservative for GM
    discrete = np.array([_discrete_avar(lambda k: 0.09 * np.exp(-np.abs(k) * dt / 50.0), mi) for mi in m])
    assert _within(r, np.sqrt(discrete))
    cont = gauss_markov_avar(tau, 0.3, 50.0)
    np.testing.assert_allclose(np.sqrt(discrete[m >= 10]), np.sqrt(cont[m >= 10]), rtol=0.01)


def _discrete_avar(r, m):
    """Exact Allan variance of m-sample means of a stationary sequence with autocovariance r(k):
    [Var(S1) − Cov(S1, S2)]/m², S1 = Σ_{0..m−1} x, S2 = Σ_{m..2m−1} x."""
    d = np.arange(-(m - 1), m)
    w = m - np.abs(d)
    return (np.sum(w * r(d)) - np.sum(w * r(d + m))) / m**2


def test_bias_instability_generator_floor():
    """noise.bias_instability of B: Allan floor 0.664 B (IEEE 952: σ = B√(2 ln 2/π)) inside its band.

    The generator is a sum of Gauss–Markov poles, so its floor ripples; its exact Allan variance (sum of the
    poles' closed forms) stays within 3 % of 0.664 B from 10 τ_min to τ_max/20. Simulated 10-h ADEVs must lie
    inside their 4σ intervals widened by that 3 %.
    """
    n, B = 36000, 0.05
    y = np.asarray(noise.bias_instability(jax.random.PRNGKey(5), jnp.ones(n), B, 1.0, 1e5))
    m = np.array([10, 30, 100, 300, 1000])
    r = allan.allan(y, 1.0, m, alpha=-1)
    assert _within(r, np.full(len(m), 0.664 * B), extra=0.03)


# ---- the noise-model fit -----------------------------------------------------------------------------------------


def _simulate(key, n, dt, white=0.0, bi=None, rrw=0.0, q=0.0, gm=None):
    k = jax.random.split(key, 5)
    steps = jnp.full(n, dt)
    y = jnp.zeros(n)
    if white:
        y = y + noise.white(k[0], n, dt, white)
    if bi:
        y = y + noise.bias_instability(k[1], steps, *bi)
    if rrw:
        y = y + noise.random_walk(k[2], steps, rrw)
    if q:
        y = y + noise.quantization(k[3], n, dt, q)
    if gm:
        y = y + noise.gauss_markov(k[4], steps, *gm)
    return np.asarray(y)


def test_fit_recovers_arw_bias_instability_rrw():
    """Three 10-h, 1 Hz records of N = 0.001 deg/√h, B = 0.05 deg/h (flicker band 1 s to 1e5 s) and
    K = 0.5 deg/h/√h, pooled. Monte Carlo over 25 such campaigns (seeds 0–24, this code): N/N0 = 1.041 ± 0.006
    (the flicker band's lower edge at 1 s adds a little white noise), B/B0 = 1.000 ± 0.010, K/K0 = 1.010 ± 0.023,
    so the 10 % tolerance is ≥ 4σ from the mean."""
    N, B, K = 0.001, 0.05, 0.5
    recs = [_simulate(jax.random.PRNGKey(100 + j), 36000, 1.0, white=N, bi=(B, 1.0, 1e5), rrw=K) for j in range(3)]
    res, fit = allan.analyze(recs, 1.0)
    assert set(fit.names) >= {"white", "bias_instability", "random_walk"}
    assert fit.method == "ieee952" and fit.converged
    assert fit.white == pytest.approx(N, rel=0.1)
    assert fit.bias_instability == pytest.approx(B, rel=0.1)
    assert fit.random_walk == pytest.approx(K, rel=0.1)
    # GMWM-style view: each term's own curve has its IEEE 952 slope, and they add up to the model
    taus = res.taus_s
    curves = fit.term_adev(taus)
    np.testing.assert_allclose(np.sqrt(sum(c**2 for c in curves.values())), fit.adev(taus), rtol=1e-12)
    slope = {k: np.polyfit(np.log(taus), np.log(c), 1)[0] for k, c in curves.items()}
    assert slope["white"] == pytest.approx(-0.5) and slope["random_walk"] == pytest.approx(0.5)
    assert slope["bias_instability"] == pytest.approx(0.0, abs=1e-12)


def test_fit_selects_white_only_and_quantization():
    """White-only record: only ``white`` survives selection (other terms have nothing to carry); white +
    quantisation at 10 Hz: Q recovered (3Q²/τ² dominates below 2 s)."""
    y = _simulate(jax.random.PRNGKey(2), 36000, 1.0, white=0.001)
    _, fit = allan.analyze(y, 1.0)
    assert fit.names == ("white",)
    assert fit.white == pytest.approx(0.001, rel=0.03)
    j = allan.terms_json(fit)
    assert j["random_walk"]["value"] == 0.0 and j["gauss_markov"]["value"] is None
    y = _simulate(jax.random.PRNGKey(3), 100000, 0.1, white=0.001, q=0.05)
    _, fit = allan.analyze(y, 0.1)
    assert fit.names == ("quantization", "white")
    assert fit.quantization == pytest.approx(0.05, rel=0.05)
    assert fit.white == pytest.approx(0.001, rel=0.05)


def test_fit_gauss_markov():
    """White + Gauss–Markov (σ = 0.05 deg/h, T = 100 s) over 10 h, fitted with the GM term: σ within 15 %,
    T within 25 % (seeds 0–5 of this code: σ within 5 %, T from 90 to 115 s; in one seed a small bias-instability
    term also survives, since a GM tail and a flicker floor look alike over a decade)."""
    y = _simulate(jax.random.PRNGKey(0), 36000, 1.0, white=0.001, gm=(0.05, 100.0))
    _, fit = allan.analyze(y, 1.0, gauss_markov=True)
    assert "gm1_sigma" in fit.names
    ((s, T),) = fit.gauss_markov
    assert s == pytest.approx(0.05, rel=0.15) and T == pytest.approx(100.0, rel=0.25)
    assert allan.terms_json(fit)["gauss_markov"] == {"value": [s, T], "unit": ["deg/h", "s"]}
    assert fit.std("gm1_sigma") > 0 and math.isnan(fit.std("gm1_tau"))  # T is read off a grid: no stated error


def test_input_errors():
    with pytest.raises(allan.AllanError):
        allan.allan(np.ones(3), 1.0)
    with pytest.raises(allan.AllanError):
        allan.allan(np.ones(100), 0.0)
    with pytest.raises(allan.AllanError):
        allan.allan(np.array([1.0, np.nan, 2.0, 3.0, 4.0]), 1.0)
    with pytest.raises(allan.AllanError, match="constant"):
        allan.allan(np.full(100, 0.4), 1.0)
    with pytest.raises(allan.AllanError):
        allan.fit_noise_model([1.0, 2.0], [1.0, 1.0], [1.0, 1.0], terms=("flicker",))


@settings(max_examples=25, deadline=None)
@given(
    a=st.floats(-1e3, 1e3).filter(lambda v: abs(v) > 1e-3),
    b=st.floats(-1e4, 1e4),
    seed=st.integers(0, 2**31 - 1),
)
def test_adev_affine_invariance(a, b, seed):
    """σ_A(a·y + b) = |a|·σ_A(y): a constant bias (D_F, Earth rate) never enters the Allan deviation."""
    y = np.random.default_rng(seed).normal(size=300)
    m = [1, 2, 5, 30, 99]
    ref = np.asarray(allan.overlapping_adev(y, 0.5, m))
    np.testing.assert_allclose(allan.overlapping_adev(a * y + b, 0.5, m), abs(a) * ref, rtol=1e-8)


def test_gauss_markov_search_cut_short_is_not_converged(monkeypatch):
    """The bounded search for the Gauss–Markov T stopped after one iteration: the IEEE 952 fit says it did not
    converge, with scipy's message, instead of passing for a fit."""
    y = _simulate(jax.random.PRNGKey(0), 36000, 1.0, white=0.001, gm=(0.05, 100.0))
    res = allan.allan(y, 1.0)
    real = scipy.optimize.minimize_scalar
    monkeypatch.setattr(scipy.optimize, "minimize_scalar", lambda *a, **k: real(*a, **{**k, "options": {"maxiter": 1}}))
    fit = allan.fit_noise_model(res.taus_s, res.avar, res.edf, gauss_markov=True)
    assert not fit.converged
    assert fit.reason.startswith("the bounded search for the Gauss–Markov T stopped after 2 evaluations: Maximum")
    monkeypatch.setattr(scipy.optimize, "minimize_scalar", real)
    assert allan.fit_noise_model(res.taus_s, res.avar, res.edf, gauss_markov=True).converged
