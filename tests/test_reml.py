"""The JAX white + Gauss–Markov likelihood (gyrojax.reml) against the dense-covariance Gaussian likelihood (closed
form), central finite differences (gradient and Hessian), and the Satterthwaite ν of the previous finite-difference
implementation; the whitening filter against the Cholesky factor of the dense covariance; the search's status."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import linalg

from gyrojax import simulate
from gyrojax.data import plans
from gyrojax.inference import identify
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.noisefit import group_series
from gyrojax.noise import reml
from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import gm_loglik, gm_profile, gm_reml, whiten
from gyrojax.optimize import Status


def GMNoise(tau, gm_var, white_var, dt=1.0):  # noqa: N802 — the (τ, σ_g², σ_w²) of the filter as a NoiseSpec
    return NoiseSpec.from_sample_variances(white_var, dt, [(gm_var, tau)])


def _series(seed=0, n=600):
    """Two independent series (the second restarts its clock), an excluded row, a gap, irregular steps."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(1.0, 3.0, n))
    t[n // 2 :] -= t[n // 2]
    t[100:] += 50.0 * (np.arange(n - 100) < n // 2 - 100)  # a gap inside the first series
    lab = np.zeros(n, dtype=int)
    lab[n // 2 :] = 1
    lab[40] = -1
    g = np.zeros(n)
    for k in range(1, n):
        g[k] = 0.95 * g[k - 1] + 0.3 * rng.normal()
    r = g + rng.normal(size=n)
    x = np.column_stack([np.ones(n), t / t.max(), np.sin(t / 40.0), lab == 1])
    return r, x, lab, t


NZ = GMNoise(35.0, 0.6, 0.8)
THETA = np.array(NZ.whitening_theta())


def _dense_cov(t, nz):
    """V = σ_w² I + σ_g² exp(−|Δt|/τ) within each series (a series restarts where time does not increase)."""
    tau, g, w = nz.whitening_theta()
    series = np.cumsum(np.r_[True, np.diff(t) <= 0])
    same = series[:, None] == series[None, :]
    return w * np.eye(len(t)) + g * np.exp(-np.abs(t[:, None] - t[None, :]) / tau) * same


def _dense_neg2(r, x, lab, t, nz, restricted):
    """−2 log L from the dense covariance V = σ_w² I + σ_g² exp(−|Δt|/τ) within each series (no Kalman filter)."""
    ok = lab >= 0
    r, x, t = r[ok], x[ok], t[ok]
    c = linalg.cho_factor(_dense_cov(t, nz))
    vi_x = linalg.cho_solve(c, x)
    beta = np.linalg.solve(x.T @ vi_x, vi_x.T @ r)
    e = r - x @ beta
    out = 2 * np.sum(np.log(np.diag(c[0]))) + e @ linalg.cho_solve(c, e)
    if restricted:
        out += np.linalg.slogdet(x.T @ vi_x)[1]
    return out


def test_reml_and_profile_values_match_the_dense_covariance():
    r, x, lab, t = _series()
    for restricted, fn in ((True, gm_reml), (False, gm_profile)):
        assert fn(r, x, lab, t, NZ) == pytest.approx(_dense_neg2(r, x, lab, t, NZ, restricted), abs=1e-7)
    # no regressors: the plain likelihood, 2 Σ log diag(L) + |L⁻¹r|² of the Cholesky factor L of V
    ok = lab >= 0
    c = linalg.cholesky(_dense_cov(t[ok], NZ), lower=True)
    plain = 2 * np.sum(np.log(np.diag(c))) + np.sum(linalg.solve_triangular(c, r[ok], lower=True) ** 2)
    assert gm_loglik(r, lab, t, NZ)[0] == pytest.approx(plain, abs=1e-7)


def test_whitening_is_the_inverse_cholesky_factor():
    """The one Kalman filter's normalised innovations are L⁻¹x for the Cholesky factor L of the dense covariance
    (the filter factors V = L Lᵀ row by row), and a white-only spec whitens by 1/σ_w."""
    r, x, lab, t = _series(2)
    ok = lab >= 0
    c = linalg.cholesky(_dense_cov(t[ok], NZ), lower=True)
    w, keep = whiten(np.column_stack([r, x]), lab, NZ, t)
    np.testing.assert_array_equal(keep, np.flatnonzero(ok))
    np.testing.assert_allclose(w, linalg.solve_triangular(c, np.column_stack([r, x])[ok], lower=True), atol=1e-10)
    # wider than one compiled call (gyrojax.noise.whiten.WHITEN_COLUMNS): filtered in chunks, the same factor
    wide = np.column_stack([r, x, np.random.default_rng(3).normal(size=(len(r), 15))])
    w, _ = whiten(wide, lab, NZ, t)
    np.testing.assert_allclose(w, linalg.solve_triangular(c, wide[ok], lower=True), atol=1e-10)
    white = NoiseSpec.from_sample_variances(0.8, 1.0)
    w, _ = whiten(r, lab, white, t)
    np.testing.assert_allclose(w, r[ok] / np.sqrt(0.8), rtol=1e-12)


def test_search_stopped_early_says_so():
    """The trust-region search stopped by its iteration limit reports not converged, with the reason; and that status
    reaches the fitted NoiseSpec."""
    r, x, lab, t = _series(4, n=1500)
    s = reml.prepare(r, x, lab, t, 1.0)
    sol = reml.minimise(s, np.log([10.0, 0.2, 1.0]), True, max_iter=1)
    assert not sol.converged and sol.status is Status.ITERATION_LIMIT and "iteration limit" in sol.reason
    sol = reml.minimise(s, np.log([10.0, 0.2, 1.0]), True)
    assert sol.converged and sol.reason == ""


def test_noise_fit_stopped_early_reaches_the_fit(monkeypatch):
    """A noise search cut to one iteration: the fit's NoiseSpec says not converged, and so does FitResult.converged
    (with the reason), with a ConvergenceWarning."""
    from functools import partial

    from gyrojax.errors import ConvergenceWarning

    truth = {"coefficients": {"D_F": 0.3, "D_I": 0.5}, "noise": {"white": 0.001, "gauss_markov": [0.05, 300.0]}}
    records = simulate(plans.eight_position(minutes=5, dt_s=2), truth, seed=3)
    monkeypatch.setattr(reml, "minimise", partial(reml.minimise, max_iter=1))
    with pytest.warns(ConvergenceWarning, match="noise model"):
        res = identify.fit(records, ["D_F", "D_I"])
    assert not res.converged and "iteration limit" in res.convergence_note
    assert not res.noise[0].converged and res.noise[0].method == "reml"


def test_collinear_columns_give_the_rank_reduced_reml():
    """A column in the span of the others (the diagnosis' per-record offset beside D_F) is not estimated: REML over
    the independent columns, as the dense formula on those columns gives."""
    r, x, lab, t = _series(1)
    xc = np.column_stack([x[:, :1], 2.0 * x[:, :1], x[:, 1:]])
    s = reml.prepare(r, xc, lab, t, 1.0)
    assert s.rank == x.shape[1]
    assert reml.neg2_loglik(s, THETA, True) == pytest.approx(_dense_neg2(r, x, lab, t, NZ, True), abs=1e-7)


_HESSIAN = jax.jit(jax.hessian(reml.objective))
"""Exact second derivatives (forward over reverse mode): the reference of :func:`gyrojax.noise.reml.reml_hessian`."""


@pytest.mark.parametrize("restricted", [True, False])
def test_gradient_and_hessian_match_finite_differences(restricted):
    r, x, lab, t = _series(2)
    s = reml.prepare(r, x, lab, t, 1.0)
    u = np.log(THETA)
    c = 1.0 if restricted else 0.0
    f0, g = reml.value_and_grad(u, *s.arrays, c)
    h = np.asarray(_HESSIAN(u, *s.arrays, c))

    def f(v):  # the numpy reference (no JAX)
        nz = GMNoise(*np.exp(v))
        return (gm_reml if restricted else gm_profile)(r, x, lab, t, nz)

    step = 1e-4
    eye = np.eye(3) * step
    fd = np.array([(f(u + e) - f(u - e)) / (2 * step) for e in eye])
    np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-5, atol=1e-5)
    hstep = 1e-3
    fd_h = np.array(
        [
            [(f(u + a + b) - f(u + a - b) - f(u - a + b) + f(u - a - b)) / (4 * hstep**2) for b in np.eye(3) * hstep]
            for a in np.eye(3) * hstep
        ]
    )
    np.testing.assert_allclose(h, fd_h, rtol=2e-4, atol=2e-3)
    assert np.allclose(h, h.T, atol=1e-8 * np.abs(h).max())
    if restricted:  # the Satterthwaite curvature: central differences of the exact gradient, against jax.hessian
        np.testing.assert_allclose(reml.reml_hessian(s, THETA), h, rtol=1e-6, atol=1e-6 * np.abs(h).max())


def test_whitened_gram_derivative_matches_forward_mode():
    r, x, lab, t = _series(3)
    s = reml.prepare(r, x, lab, t, 1.0, select=False)
    u = np.log(THETA)
    a, da = reml.whitened_gram(s, THETA)
    p, d = s.rank, s.norms

    def gram(u):
        return reml.likelihood_terms(jnp.exp(u), *s.arrays)[3]

    ref = np.asarray(jax.jacfwd(gram)(u))[:p, :p] * np.outer(d, d)[:, :, None]
    np.testing.assert_allclose(a, np.asarray(gram(u))[:p, :p] * np.outer(d, d), rtol=1e-12)
    np.testing.assert_allclose(da, ref, rtol=1e-6, atol=1e-7 * np.abs(ref).max())


@pytest.mark.parametrize("columns", [3, 5])
def test_padding_does_not_change_the_likelihood(columns):
    """Rows and columns padded to the buckets are inert: the value equals the one on unpadded arrays (3 regressors
    padded to 4, 5 to 8)."""
    r, x, lab, t = _series(3, n=333)
    x = np.column_stack([x, np.cos(t / 25.0)])[:, :columns]
    s = reml.prepare(r, x, lab, t, 1.0)
    assert s.rank == columns and s.x.shape[0] > s.n and s.x.shape[1] == 1 + reml.bucket_cols(columns) > 1 + s.rank
    ok = lab >= 0
    m = s.n
    arrays = (s.x[:m, : 1 + s.rank], s.dt[:m], s.restart[:m], s.mask[:m])
    unpadded = float(reml.objective(np.log(THETA), *arrays, 1.0))
    assert float(reml.objective(np.log(THETA), *s.arrays, 1.0)) == pytest.approx(unpadded, abs=1e-9)
    assert ok.sum() == m


def test_fit_finds_the_reml_optimum():
    """The minimiser lands where the exact gradient vanishes (or a bound holds it) and beats every grid start."""
    r, x, lab, t = _series(4, n=1500)
    s = reml.prepare(r, x, lab, t, 1.0)
    sol = reml.fit(s, (10.0, 0.2, 1.0))
    theta, f = sol.x, sol.value
    assert sol.converged and sol.reason == ""
    _, g = reml.value_and_grad(np.log(theta), *s.arrays, 1.0)
    assert np.abs(np.asarray(g)).max() < 1e-3
    assert f == pytest.approx(gm_reml(r, x, lab, t, GMNoise(*theta)), abs=1e-7)
    starts = reml.grid(s, (10.0, 0.2, 1.0), False)
    assert f <= float(np.min(reml.values(s, starts, True))) + s.logdet_const + 1e-9
    # the simulated drift (φ = 0.95 per ~2 s step: τ ≈ 39 s) is found within its sampling error
    assert 15.0 < theta[0] < 100.0


def _fd_satterthwaite(res, records, free, step=0.05):
    """The previous implementation of ν: central differences of the numpy REML and of the GLS variances, in the free
    log-parameters (τ held when at its cap)."""
    camp = Campaign.of(records)
    lin = linearize(res.model, res.theta, camp)
    nz = res.noise[0]
    r, j, lab, t = group_series(lin, list(range(len(records))))

    def variances(moved):
        rows = [whiten(np.column_stack([rr, jj]), ll, moved, tt)[0] for rr, jj, ll, tt in lin]
        jw = np.concatenate([w[:, 1:] for w in rows])
        return np.diag(np.linalg.inv(jw.T @ jw))

    u0 = np.log(nz.whitening_theta())
    basis = np.eye(3)[free] * step
    k = len(free)

    def f(u):
        return gm_reml(r, j, lab, t, GMNoise(*np.exp(u)))

    f0 = f(u0)
    hess = np.zeros((k, k))
    for a in range(k):
        hess[a, a] = (f(u0 + basis[a]) - 2 * f0 + f(u0 - basis[a])) / step**2
        for b in range(a):
            ea, eb = basis[a], basis[b]
            hess[a, b] = hess[b, a] = (f(u0 + ea + eb) - f(u0 + ea - eb) - f(u0 - ea + eb) + f(u0 - ea - eb)) / (
                4 * step * step
            )
    cov_u = 2.0 * np.linalg.inv(hess)
    grad = np.column_stack(
        [(variances(GMNoise(*np.exp(u0 + e))) - variances(GMNoise(*np.exp(u0 - e)))) / (2 * step) for e in basis]
    )
    v0 = variances(nz)
    return 2.0 * v0**2 / np.einsum("ka,ab,kb->k", grad, cov_u, grad)


def test_satterthwaite_dof_from_the_exact_hessian_matches_finite_differences():
    """8 positions under drift as slow as a position: ν from the exact REML Hessian and exact ∂V/∂u agrees with the
    previous finite-difference estimate (step 0.05 in log-parameters, so to its truncation error)."""
    truth = {
        "coefficients": {"D_F": 0.3, "D_I": 0.5, "D_O": -0.2, "D_S": 0.1},
        "noise": {"white": 0.001, "gauss_markov": [0.05, 300.0]},
    }
    records = simulate(plans.eight_position(minutes=5, dt_s=2), truth, seed=3)
    res = identify.fit(records, list(truth["coefficients"]))
    nz = res.noise[0]
    assert nz.gauss_markov and nz.method == "reml" and res.dof_eff is not None
    tau_max = max(np.ptp(rec.time_s) for rec in records)
    free = [1, 2] if nz.gm_tau >= 0.999 * tau_max else [0, 1, 2]
    ref = _fd_satterthwaite(res, records, free)
    np.testing.assert_allclose(res.dof_eff, np.maximum(ref, 1.0), rtol=0.03)
    assert np.all(res.dof_eff < 1e4)


def test_satterthwaite_reuses_the_noise_fits_curvature():
    """ν from the curvature campaign_noise stored in the noise model (with_reml_covariance, before the GLS pass
    moved the residual along the regressors) equals ν from the REML Hessian evaluated again at the final residual:
    the REML likelihood is invariant to that move, so the two agree to the Hessian's own numerical error (central
    differences of the gradient at the same step, rounding over ~1e4 rows: far below HESSIAN_STEP² ≈ 1e-8)."""
    from dataclasses import replace

    from gyrojax.inference.noisefit import noise_scale, satterthwaite_dof
    from gyrojax.noise.whiten import reml_u_covariance

    truth = {
        "coefficients": {"D_F": 0.3, "D_I": 0.5, "D_O": -0.2, "D_S": 0.1},
        "noise": {"white": 0.001, "gauss_markov": [0.05, 300.0]},
    }
    records = simulate(plans.eight_position(minutes=5, dt_s=2), truth, seed=3)
    res = identify.fit(records, list(truth["coefficients"]))
    assert reml_u_covariance(res.noise[0]) is not None and res.dof_eff is not None
    camp = Campaign.of(records)
    lin = linearize(res.model, res.theta, camp)
    scales = [noise_scale(r, lab) for r, _, lab, _ in lin]
    bare = [replace(nz, cov=(), cov_names=()) for nz in res.noise]  # no stored curvature: evaluated again
    assert reml_u_covariance(bare[0]) is None
    again = satterthwaite_dof(lin, camp, bare, scales)
    reused = satterthwaite_dof(lin, camp, res.noise, scales)
    assert np.all(np.isfinite(again)) and np.all(again < 1e4)
    np.testing.assert_allclose(reused, again, rtol=reml.HESSIAN_STEP**2)


def test_gradient_is_finite_across_a_clock_restart_at_short_correlation_time():
    """Stacked records restart their clocks (a step of −span): at τ of about one step, exp(+span/τ) overflows in the
    unselected branch of the filter's φ, which once made the reverse-mode gradient NaN (and stopped the search)."""
    r, x, lab, t = _series(4)
    s = reml.prepare(r, x, lab, t, 1.0)
    u = np.log([0.5, 0.05, 1.0])  # τ 0.5 s against a restart step of about −600 s: exp(1200) overflows
    for c in (0.0, 1.0):
        f0, g = reml.value_and_grad(u, *s.arrays, c)
        assert np.all(np.isfinite(np.asarray(g)))
        step = 1e-5
        val = [float(reml.value_and_grad(u + e * sgn, *s.arrays, c)[0]) for e in np.eye(3) * step for sgn in (1, -1)]
        fd = [(val[2 * k] - val[2 * k + 1]) / (2 * step) for k in range(3)]
        np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-5, atol=1e-5)


def test_reml_covariance_of_the_natural_parameters():
    """with_reml_covariance against an independent route: the Hessian of −2 log L_R by second differences of its
    values (not of the gradient) in u = log(τ, σ_g², σ_w²), Cov(u) = 2H⁻¹, mapped to (N, σ, T) by a numerical
    Jacobian."""
    from gyrojax.noise.whiten import fit_gm, with_reml_covariance

    r, x, lab, t = _series(4, n=1500)
    nz = fit_gm(r, lab, t, design=x, tau_span_fraction=1.0)
    got = with_reml_covariance(nz, r, x, lab, t, 1.0)
    assert got.cov_names == ("white", "gm1_sigma", "gm1_tau") and got.white == nz.white
    u0, h = np.log(nz.whitening_theta()), 1e-3

    def f(u):
        return gm_reml(r, x, lab, t, GMNoise(*np.exp(u), dt=nz.dt_s))

    e = np.eye(3) * h
    hess = np.array(
        [[(f(u0 + a + b) - f(u0 + a - b) - f(u0 - a + b) + f(u0 - a - b)) / (4 * h * h) for b in e] for a in e]
    )
    cov_u = 2 * np.linalg.inv(hess)

    def natural(u):
        s = GMNoise(*np.exp(u), dt=nz.dt_s)
        return np.array([s.white, s.gauss_markov[0][0], s.gauss_markov[0][1]])

    jac = np.column_stack([(natural(u0 + d) - natural(u0 - d)) / (2 * h) for d in e])
    np.testing.assert_allclose(np.asarray(got.cov), jac @ cov_u @ jac.T, rtol=2e-3, atol=1e-12)


@pytest.mark.parametrize("p", [1, 2, 3, 5])
def test_ar_whitening_is_scipys_lfilter_to_the_last_bit(p):
    """The AR whitening's FIR filter (numpy, so that a diagnosis does not import scipy.signal) against
    ``scipy.signal.lfilter`` on each labelled segment: the rows past a segment's first p, equal to the last bit, for
    columns and for a vector; a segment of p rows or fewer gives none."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(p)
    phi = tuple(0.5 * rng.standard_normal(p))
    nz = NoiseSpec.from_sample_variances(2.5, 0.1, ar=phi, method="ar")
    b = np.concatenate([[1.0], -np.asarray(phi)]) / nz.innovation_std
    x = rng.standard_normal((700, 4)) * 1e3
    labels = np.repeat([0, 1, 2], [300, p, 400 - p])  # the middle segment is too short to keep a row
    segments = [(0, 300), (300 + p, 700)]
    for data in (x, x[:, 1]):
        w, keep = whiten(data, labels, nz)
        want = np.concatenate([lfilter(b, [1.0], data[s:e], axis=0)[p:] for s, e in segments])
        np.testing.assert_array_equal(w, want)
        np.testing.assert_array_equal(keep, np.concatenate([np.arange(s + p, e) for s, e in segments]))
