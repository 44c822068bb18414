"""Latent-process noise models fitted by the generalized method of wavelet moments (GMWM).

A rate series (deg/h, sample interval Δt s) is modelled as a sum of independent latent processes with exact Haar
wavelet variance (:mod:`gyrojax.noise.wavelet`): white noise, angle quantization, rate random walk, rate ramp, a
flicker floor (bias instability B, :mod:`gyrojax.noise.gmwm_model`) and one or more first-order Gauss–Markov (AR1)
processes — the latter also stand for flicker over a narrow band and for the sensor's own output filter. The
Allan variance of the model is twice its wavelet variance at the same τ.

**Estimation** (Guerrier, Skaloud, Stebler & Victoria-Feser 2013): θ̂ = argmin (ν̂ − ν(θ))ᵀ Ω⁻¹ (ν̂ − ν(θ)) over
the empirical Haar wavelet variances ν̂ at the dyadic scales m = 1, 2, 4, … (m ≤ n/8), with Ω the asymptotic
covariance of ν̂ (:func:`gyrojax.noise.wavelet.wv_covariance`) evaluated under the model (two-step efficient GMM: a
first fit with diagonal weights, then Ω(θ̂), refit, Ω(θ̂) again, refit). θ are the logarithms of the latent
parameters (variances, AR1 rate a = Δt/T), so every parameter stays positive; the minimisation is
Levenberg–Marquardt in JAX with the exact Jacobian (``jax.jacfwd``), which returns its convergence status, started
from a weighted NNLS of the variances on a grid of correlation times (the model is linear in the variances once
the T are fixed).

**Uncertainty.** Cov(θ̂) = (DᵀΩ⁻¹D)⁻¹, D = ∂ν/∂θ at θ̂ (efficient GMM); natural parameters (N, K, Q, σ, T, …)
by the delta method. The quadratic form Q(θ̂) is asymptotically χ²(J − p) under the model (Hansen's J test):
its p-value is the model's adequacy test at the dyadic scales.

**Model selection** (:mod:`gyrojax.noise.gmwm_select`). Among candidate sums (default
:data:`DEFAULT_CANDIDATES`) that the record identifies (no parameter at a bound, no duplicate or unidentified
component, no flicker floor that is nowhere seen), the one of least Q(θ̂) + Σ cost, every candidate weighed with the
Ω of the largest one, that passes its own J test; each process beside the white one costs the critical value of a
test at one level (a boundary χ² for one variance, Davies' bound for a Gauss–Markov component whose T is not
identified without it), the level calibrated by Monte Carlo for the stated false-component rate (the WIC's 2 per
parameter of Guerrier et al. is not).

**AVLR** (Allan-variance linear regression, Guerrier et al. 2016) is the same fit with relative least-squares
weights diag(1/ν̂²) instead of Ω⁻¹; its covariance is the sandwich with the model's Ω. The IEEE 952 read-off
stays :func:`gyrojax.noise.allan.fit_noise_model`.

The fitted model is a :class:`~gyrojax.noise.spec.NoiseSpec` (``method`` "gmwm" or "avlr", ``dt_s`` the sample
interval) with the covariance of its natural parameters, the solver's convergence status and, in ``info``, the
model label, Q(θ̂), its degrees of freedom and J-test p-value, the parameters pinned at a bound and the selection
table. The latent processes and their compiled wavelet variances are :mod:`gyrojax.noise.gmwm_model`; the read-offs
(ARW, bias instability, RRW, the adequacy check and the report of ``gyrojax noise``) :mod:`gyrojax.noise.readoff`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache, partial

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize

from gyrojax import tails
from gyrojax.noise import gmwm_select as sel
from gyrojax.noise import robust_wv as rwv
from gyrojax.noise import wavelet as wv
from gyrojax.noise.allan import overlapping_avar
from gyrojax.noise.gmwm_model import (
    DEFAULT_CANDIDATES,
    FULL_NAMES,
    ModelSpec,
    expand,
    full_wv,
    full_wv_jacobian,
    model_covariance,
    model_wv,
    pad,
    padded_length,
    spec_mask,
    to_noise_spec,
    wv_flicker,
)
from gyrojax.noise.spec import NoiseModelError, NoiseSpec

# ---- weights and the Levenberg–Marquardt solver ----------------------------------------------------------------


def whitening_matrix(omega) -> np.ndarray:
    """P with PᵀP = Ω⁻¹ (Cholesky of the correlation matrix, scaled by the standard deviations); Ω in (deg/h)⁴,
    P in (deg/h)⁻²."""
    omega = np.asarray(omega, float)
    d = np.sqrt(np.diag(omega))
    c = omega / np.outer(d, d)
    c = 0.5 * (c + c.T) + 1e-12 * np.eye(len(d))
    lc = np.linalg.cholesky(c)
    return np.linalg.solve(lc, np.diag(1.0 / d))


@partial(jax.jit, static_argnames=("n_iter",))
def levenberg_marquardt(theta0, mask, nu_hat, m, p_mat, lo, hi, n_iter: int = 80):
    """min_θ |P(ν̂ − ν(θ))|² by Levenberg–Marquardt with the exact Jacobian, θ clipped to [lo, hi].

    Full log-parameters θ (:data:`FULL_NAMES`) with the inactive ones masked out (one compilation for every
    model). Returns (θ̂, cost, converged, iterations). A step is taken only when it lowers the cost; the damping λ
    falls by 3 after a success and rises by 4 after a failure; the loop ends when an accepted step lowers the cost
    by less than 1e-12 of it or λ exceeds 1e12 (no step lowers it any more: both converged), or after ``n_iter``
    iterations (not converged).
    """
    maskf = mask.astype(jnp.float64)

    def resid(th):
        return p_mat @ (nu_hat - full_wv(th, mask, m))

    def cost(th):
        r = resid(th)
        return r @ r

    def body(carry):
        k, th, c, lam, _ = carry
        r = resid(th)
        jac = jax.jacfwd(resid)(th) * maskf[None, :]
        a = jac.T @ jac
        g = jac.T @ r
        damp = lam * jnp.diag(a) + 1e-12 * jnp.max(jnp.diag(a)) + (1.0 - maskf)
        step = jnp.linalg.solve(a + jnp.diag(damp), -g) * maskf
        new = jnp.clip(th + step, lo, hi)
        cn = cost(new)
        ok = jnp.isfinite(cn) & (cn < c)
        done = ok & (c - cn <= 1e-12 * c)
        return (k + 1, jnp.where(ok, new, th), jnp.where(ok, cn, c), jnp.where(ok, lam / 3.0, lam * 4.0), done)

    def more(carry):
        k, _, _, lam, done = carry
        return (k < n_iter) & ~done & (lam < 1e12)

    th0 = jnp.clip(theta0, lo, hi)
    init = (jnp.asarray(0), th0, cost(th0), jnp.asarray(1e-3), jnp.asarray(False))
    k, th, c, lam, done = jax.lax.while_loop(more, body, init)
    return th, c, done | (lam >= 1e12), k


# ---- starting values -------------------------------------------------------------------------------------------


def _basis(spec: ModelSpec, m, rates):
    """Columns of ν(m) per unit variance of each process, for fixed AR1 rates (numpy)."""
    m = np.asarray(m, float)
    cols = []
    if spec.white:
        cols.append(np.asarray(wv.wv_white(m, 1.0)))
    if spec.quantization:
        cols.append(np.asarray(wv.wv_quantization(m, 1.0)))
    if spec.random_walk:
        cols.append(np.asarray(wv.wv_random_walk(m, 1.0)))
    if spec.drift:
        cols.append(np.asarray(wv.wv_drift(m, 1.0)))
    if spec.flicker:
        cols.append(np.asarray(wv_flicker(m, 1.0)))
    for a in rates:
        cols.append(_gm_column(tuple(m), float(a)))
    return np.stack(cols, axis=1)


@lru_cache(maxsize=4096)
def _gm_column(m: tuple, a: float) -> np.ndarray:
    """ν²(m) of a unit-variance AR1 of rate ``a`` (cached: the starting-value grid repeats across candidates)."""
    mp = pad(m, padded_length(len(m)), 1.0)
    return np.asarray(wv.wv_gauss_markov(mp, 1.0, a))[: len(m)]


def _nnls(basis, nu_hat, p_mat):
    a = p_mat @ basis
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    c, rn = optimize.nnls(a / scale, p_mat @ nu_hat, maxiter=50 * basis.shape[1])
    return c / scale, rn * rn


def _bounds(spec: ModelSpec, m, nu_hat):
    """Box for θ: each variance between 1e-10 and 1e4 times the value that explains ν̂ on its own at its most
    constraining scale; AR1 rates a = Δt/T with T inside what the scales can identify (:func:`gm_tau_limits`)."""
    lo, hi = [], []
    unit = _basis(ModelSpec(True, True, True, True, n_gm=0, flicker=True), m, [])
    lin = ("white", "quantization", "random_walk", "drift", "flicker")
    full = {k: float(np.min(nu_hat / unit[:, i])) for i, k in enumerate(lin)}
    for k in lin:
        if getattr(spec, k):
            lo.append(math.log(full[k] * 1e-10))
            hi.append(math.log(full[k] * 1e4))
    gm_full = float(np.max(nu_hat)) / 0.2  # an AR1 peaks at ν² ≈ 0.19 s²
    t_lo, t_hi = gm_tau_limits(m)
    for _ in range(spec.n_gm):
        lo += [math.log(gm_full * 1e-10), math.log(1.0 / t_hi)]
        hi += [math.log(gm_full * 1e4), math.log(1.0 / t_lo)]
    return np.asarray(lo), np.asarray(hi)


TAU_MIN_SAMPLES = 3.0
"""Shortest Gauss–Markov correlation time, in sample intervals: a shorter one is white noise under another name
(its Allan deviation has the −½ slope from the first scale on) and only trades variance with the white term."""


def gm_tau_limits(m) -> tuple[float, float]:
    """(T_min, T_max) of a Gauss–Markov component, in samples (dimensionless; × dt for s), for a fit at
    half-widths ``m``: from max(:data:`TAU_MIN_SAMPLES`, the shortest scale) to the longest scale. A longer T
    shows only its rising +½ part inside the record (a rate random walk, which the candidates hold); a shorter
    one is white at every scale."""
    m = np.asarray(m, float)
    return max(TAU_MIN_SAMPLES, float(m.min())), max(float(m.max()), 2.0 * TAU_MIN_SAMPLES)


def starting_values(spec: ModelSpec, m, nu_hat, p_mat, memo: dict | None = None) -> np.ndarray:
    """θ₀: the AR1 correlation times T (in samples, dimensionless) chosen greedily on a log grid, each new one
    with the earlier ones fixed; the variances ((deg/h)²) by weighted NNLS for those T; a variance the NNLS sets to
    zero starts at 1e-6 of its scale.

    ``memo``: a dict shared by the fits of one model selection; each greedy step is a function of the linear
    processes, the rates already chosen and the data (m, ν̂, P), so candidates that share them reuse it."""
    m = np.asarray(m, float)
    grid = np.geomspace(*gm_tau_limits(m), 28)  # T in samples
    data_key = (m.tobytes(), np.asarray(nu_hat, float).tobytes(), np.asarray(p_mat, float).tobytes())
    rates: list[float] = []
    for _ in range(spec.n_gm):
        key = (data_key, replace(spec, n_gm=0), tuple(rates))
        if memo is not None and key in memo:
            rates.append(memo[key])
            continue
        best = None
        for t in grid:
            if any(abs(math.log(t * r)) < 0.2 for r in rates):
                continue
            sub = replace(spec, n_gm=len(rates) + 1)
            c, sse = _nnls(_basis(sub, m, [*rates, 1.0 / t]), nu_hat, p_mat)
            if best is None or sse < best[0]:
                best = (sse, 1.0 / t)
        if memo is not None:
            memo[key] = best[1]
        rates.append(best[1])
    c, _ = _nnls(_basis(spec, m, rates), nu_hat, p_mat)
    lo, hi = _bounds(spec, m, nu_hat)
    var_lo = np.exp(lo) * 1e4  # 1e-6 of the full scale
    n_lin = spec.n_params - 2 * spec.n_gm
    th = []
    for i in range(n_lin):
        th.append(math.log(max(c[i], var_lo[i])))
    for k in range(spec.n_gm):
        j = n_lin + 2 * k
        th += [math.log(max(c[n_lin + k], var_lo[j])), math.log(rates[k])]
    return np.clip(np.asarray(th), lo, hi)


# ---- the fit ---------------------------------------------------------------------------------------------------


def haar_wv(segments, m_list):
    """Empirical Haar wavelet variance ((deg/h)²) of one or several rate series at half-widths ``m_list``.

    Returns (ν̂², M): several independent segments are pooled as Σ_j M_j ν̂²_j / Σ_j M_j over the segments long
    enough for each m (2m ≤ n_j); ν̂² = σ̂²_A/2 (overlapping Allan variance, allantools ``oadev``²/2).
    """
    if isinstance(segments, (np.ndarray, jnp.ndarray)) and np.ndim(segments) == 1:
        segments = [segments]
    m = np.asarray(m_list, dtype=np.int64)
    num = np.zeros(len(m))
    cnt = np.zeros(len(m))
    for s in segments:
        ok = 2 * m <= len(s)
        if not ok.any():
            continue
        avar, c = overlapping_avar(np.asarray(s, float), 1.0, m[ok])
        num[ok] += np.asarray(avar) / 2.0 * np.asarray(c)
        cnt[ok] += np.asarray(c)
    with np.errstate(invalid="ignore"):
        return num / cnt, cnt


@dataclass
class WaveletVariance:
    """Empirical Haar wavelet variance ν̂² ((deg/h)²) at half-widths ``m`` (samples), ``counts`` coefficients,
    of ``n_samples`` samples every ``dt`` s."""

    m: np.ndarray
    nu2: np.ndarray
    counts: np.ndarray
    dt: float
    n_samples: int
    efficiency: float | None = None
    """None: the classical estimate; else the Gaussian efficiency of the robust one (:mod:`gyrojax.noise.robust_wv`)."""

    @classmethod
    def of(cls, segments, dt: float, m=None, robust: bool = False, efficiency: float = rwv.DEFAULT_EFFICIENCY):
        """Estimate at the dyadic scales (default, :func:`wavelet.dyadic_m` of the longest segment) or at ``m``;
        ``robust``: the biweight M-estimate of Gaussian efficiency ``efficiency`` (:func:`robust_wv.robust_wv`)."""
        if isinstance(segments, (np.ndarray, jnp.ndarray)) and np.ndim(segments) == 1:
            segments = [segments]
        n = max(len(s) for s in segments)
        if n < 16:
            raise NoiseModelError(f"a GMWM fit needs at least 16 samples, got {n}")
        m = wv.dyadic_m(n) if m is None else np.asarray(m, dtype=np.int64)
        if robust:
            nu2, cnt, info = rwv.robust_wv([np.asarray(s, float) for s in segments], m, efficiency)
            if info["not_converged"]:
                bad = info["not_converged"]
                raise NoiseModelError(f"robust wavelet variance: the M-estimate did not converge at m = {bad}")
        else:
            nu2, cnt = haar_wv(segments, m)
        ok = cnt > 0
        n_all = int(sum(len(s) for s in segments))
        return cls(m[ok], nu2[ok], cnt[ok], float(dt), n_all, float(efficiency) if robust else None)

    def estimator(self) -> dict:
        """Which wavelet-variance estimator made ``nu2``: for the JSON (``model.info.wavelet_variance``)."""
        if self.efficiency is None:
            return {"estimator": "classical", "efficiency": 1.0}
        return {
            "estimator": "robust: Tukey biweight M-estimate (Guerrier et al. 2016)",
            "efficiency": self.efficiency,
            "tuning_constant": rwv.Biweight.of(self.efficiency).c,
        }

    @classmethod
    def from_allan_table(cls, taus_s, avar, dt: float, n_samples: int) -> "WaveletVariance":
        """From a published maximum-overlap Allan variance table (τ in s, σ²_A in any unit²) of a series of
        ``n_samples`` samples every ``dt`` s: ν̂² = σ²_A/2, m = τ/dt (must be integers), M = n − 2m + 1."""
        m = np.asarray(taus_s, float) / dt
        if np.any(np.abs(m - np.round(m)) > 1e-6 * m) or np.any(m < 1):
            raise NoiseModelError("the Allan table's taus are not integer multiples of the sample interval")
        m = np.round(m).astype(np.int64)
        counts = n_samples - 2 * m + 1
        if np.any(counts < 1):
            raise NoiseModelError("the Allan table has taus longer than half the series")
        return cls(m, np.asarray(avar, float) / 2.0, counts.astype(float), float(dt), int(n_samples))

    @property
    def taus_s(self) -> np.ndarray:
        """Scales τ = m·Δt, s."""
        return self.m * self.dt


GRID_POINTS = 4000
"""Points of the frequency grid of the covariance integrals (400 per decade or more for m ≤ 10⁷)."""


class _Grid:
    """Frequency grid and Haar gain factors for the covariance Ω at the (padded) half-widths of one estimate."""

    def __init__(self, m):
        jp = padded_length(len(m))
        self.f, self.w = wv.frequency_grid(np.max(m), n_points=GRID_POINTS)
        self.factors = wv.gain_factors(pad(m, jp, 1.0), self.f)


def robust_scaling(theta_full, mask, est: WaveletVariance) -> np.ndarray:
    """√r per scale of ``est`` (dimensionless): the robust estimate's Var ν̂² over the classical one under the model
    with full log-parameters ``theta_full`` (:func:`robust_wv.variance_ratios`); ones for the classical estimate.
    A flicker floor has no coefficient autocovariance in :mod:`robust_wv`: with one on, r takes its upper bound
    1/efficiency at every scale (the conservative end of [1, 1/eff])."""
    if est.efficiency is None:
        return np.ones(len(est.m))
    e = np.exp(np.asarray(theta_full, float))
    on = np.asarray(mask, bool)
    if on[FULL_NAMES.index("bias_instability")]:
        return np.full(len(est.m), math.sqrt(1.0 / est.efficiency))
    latent = {k: float(e[i]) if on[i] else 0.0 for i, k in enumerate(("white", "quantization", "random_walk"))}
    gm = range(FULL_NAMES.index("gm1_var"), len(FULL_NAMES), 2)
    latent["gm"] = [(float(e[i]), float(e[i + 1])) for i in gm if on[i]]
    r = rwv.variance_ratios(est.m, latent, rwv.Biweight.of(est.efficiency), est.n_samples)
    return np.sqrt(r)


def covariance_at(spec: ModelSpec, theta, m, counts) -> np.ndarray:
    """Ω (J, J), (deg/h)⁴: covariance of Haar wavelet variance estimates at half-widths ``m`` (samples) with
    ``counts`` coefficients each, under the model ``spec`` with log-parameters ``theta``."""
    j = len(m)
    jp = padded_length(j)
    grid = _Grid(np.asarray(m))
    mp = pad(m, jp, 1.0)
    cp = pad(counts, jp, float(np.max(counts)))
    om = model_covariance(expand(spec, theta), spec_mask(spec), mp, cp, grid.f, grid.w, grid.factors)
    return np.asarray(om)[:j, :j]


def _scatter(idx, values, fill: float = 0.0):
    out = np.full(len(FULL_NAMES), fill)
    out[idx] = values
    return out


def fit_spec(
    spec: ModelSpec,
    est: WaveletVariance,
    omega=None,
    method: str = "gmwm",
    grid=None,
    n_steps: int = 2,
    memo: dict | None = None,
) -> NoiseSpec:
    """Fit one model by GMWM (``method='gmwm'``) or AVLR (``'avlr'``) to the wavelet variance ``est``.

    ``omega``: a fixed weighting covariance (e.g. for model comparison); default: the two-step efficient
    weights Ω(θ̂) (``n_steps`` re-evaluations after a first fit with diagonal weights ν̂⁴·m/M). ``grid`` and
    ``memo`` (:func:`starting_values`) let the fits of one selection share work; neither changes the result.
    """
    return _fit_spec(spec, est, omega, method, grid, n_steps, memo)[0]


def _fit_spec(spec: ModelSpec, est, omega, method, grid, n_steps, memo):
    """:func:`fit_spec` and the weighting covariance Ω of the fit."""
    theta, p_mat, om, m, lo, hi, status = _fit_theta(spec, est, omega, method, grid, n_steps, memo)
    j = len(est.m)
    mask = spec_mask(spec)
    idx = np.flatnonzero(mask)
    r = np.asarray(p_mat @ (est.nu2 - np.asarray(model_wv(spec, theta, m))[:j]))  # P(ν̂ − ν(θ)) at the J scales
    d = np.asarray(full_wv_jacobian(expand(spec, theta), mask, m))[:j, idx]
    pd = p_mat @ d
    # parameters pinned at a bound carry no information (their standard error is reported as infinite)
    at_bound = (theta <= lo + 1e-6) | (theta >= hi - 1e-6)
    free = ~at_bound
    cov = np.zeros((len(theta), len(theta)))
    bread = np.linalg.pinv(pd[:, free].T @ pd[:, free])
    if method == "gmwm":
        cov[np.ix_(free, free)] = bread
    else:  # sandwich with the model's Ω
        meat = pd[:, free].T @ p_mat @ om @ p_mat.T @ pd[:, free]
        cov[np.ix_(free, free)] = bread @ meat @ bread
    cov[at_bound, at_bound] = np.inf
    objective = float(r @ r)
    dof = j - spec.n_params
    p_value = float(tails.chi2_sf(objective, dof)) if dof > 0 and method == "gmwm" else None
    info = {
        "model": spec.label(),
        "objective": objective,
        "dof": dof,
        "p_value": p_value,
        "pinned": [k for k, b in zip(spec.names, at_bound) if b],
        "selection": [],
        "wavelet_variance": est.estimator(),
    }
    if est.efficiency is not None and spec.drift:
        info["notes"] = ["robust wavelet variance with a rate ramp: the M-estimate assumes zero-mean coefficients"]
    converged, iters = status
    reason = "" if converged else f"Levenberg-Marquardt stopped at its iteration limit ({iters}) before converging"
    band = (float(est.taus_s[0]), float(est.taus_s[-1]))
    return to_noise_spec(spec, theta, cov, est.dt, method, info, converged, reason, band), om


def _fit_theta(spec: ModelSpec, est: WaveletVariance, omega, method: str, grid, n_steps: int, memo):
    """The minimisation of :func:`fit_spec`: (θ̂ compact, P, Ω, padded m, lower and upper bounds of θ, (converged,
    iterations) of the last Levenberg–Marquardt run)."""
    j = len(est.m)
    jp = padded_length(j)
    m = pad(est.m, jp, 1.0)  # padding: m = 1, ν̂ = 0, zero rows of P (no weight)
    nu = pad(est.nu2, jp, 0.0)
    counts = pad(est.counts, jp, float(np.max(est.counts)))
    grid = grid or _Grid(est.m)

    def padp(p):
        out = np.zeros((jp, jp))
        out[:j, :j] = p
        return out

    def omega_at(th):
        om = np.asarray(model_covariance(th, mask, m, counts, grid.f, grid.w, grid.factors))[:j, :j]
        d = robust_scaling(th, mask, est)
        return om * np.outer(d, d)

    lo, hi = _bounds(spec, est.m, est.nu2)
    if spec.n_params > len(est.m):
        raise NoiseModelError(f"model {spec.label()} has {spec.n_params} parameters for {len(est.m)} scales")
    diag = np.diag(est.nu2**2 * est.m / est.counts / (est.efficiency or 1.0))
    if method == "avlr":
        p_mat = np.diag(1.0 / est.nu2)
    elif method == "gmwm":
        p_mat = whitening_matrix(diag if omega is None else omega)
    else:
        raise NoiseModelError(f"method must be 'gmwm' or 'avlr', got {method!r}")
    mask = spec_mask(spec)
    idx = np.flatnonzero(mask)
    lo_f = _scatter(idx, lo)
    hi_f = _scatter(idx, hi)
    theta = expand(spec, starting_values(spec, est.m, est.nu2, p_mat, memo))
    theta, _, ok, it = levenberg_marquardt(theta, mask, nu, m, padp(p_mat), lo_f, hi_f)
    om = omega
    if method == "gmwm" and omega is None:
        for _ in range(n_steps):
            om = omega_at(theta)
            p_mat = whitening_matrix(om)
            theta, _, ok, it = levenberg_marquardt(theta, mask, nu, m, padp(p_mat), lo_f, hi_f)
    if om is None or method == "avlr":
        om = omega_at(theta)
    return np.asarray(theta)[idx], p_mat, om, m, lo, hi, (bool(ok), int(it))


def gm_sweep(m, omega) -> float:
    """V of the Davies cost of a Gauss–Markov component (:func:`~gyrojax.noise.gmwm_select.gm_sweep`) at the
    half-widths ``m`` (samples) with the reference weights ``omega`` (Ω_ref, (deg/h)⁴): beside the white,
    quantization, random-walk and flicker-floor columns, T over :func:`gm_tau_limits`; V in radians."""
    lin = ModelSpec(white=True, quantization=True, random_walk=True, n_gm=0, flicker=True)
    return sel.gm_sweep(m, whitening_matrix(omega), _basis(lin, m, []), gm_tau_limits(m))


def select_model(est: WaveletVariance, candidates=DEFAULT_CANDIDATES, method: str = "gmwm") -> NoiseSpec:
    """The identified model selection (module doc, :mod:`gyrojax.noise.gmwm_select`): the sensor filter's short
    scales dropped (:func:`~gyrojax.noise.gmwm_select.short_scale_limit`), every candidate fitted with the weights
    Ω of the largest, the admissible one of least Q + Σ cost (:func:`~gyrojax.noise.gmwm_select.cost_of`) that
    passes its J test with its own efficient weights (:func:`~gyrojax.noise.gmwm_select.ranked`; refitted by AVLR
    when asked). ``info["penalty"]`` holds the costs (:func:`~gyrojax.noise.gmwm_select.costs`),
    ``info["selection"]`` lists every
    candidate's objective, criterion, rejection and (where tested) own-weight J-test p-value ``j_test_p``,
    ``info["j_test"]`` says when no identified candidate passes (the least-criterion one is kept),
    ``info["tau_min_s"]`` the shortest τ fitted and ``info["short_scales"]`` why shorter ones were dropped.
    Candidates with more parameters than scales are skipped."""
    k, why = sel.short_scale_limit(est)
    if k:
        est = replace(est, m=est.m[k:], nu2=est.nu2[k:], counts=est.counts[k:])
    cands = [c for c in candidates if c.n_params < len(est.m)]
    if not cands:
        raise NoiseModelError(f"{len(est.m)} scales are too few for any candidate model")
    grid = _Grid(est.m)
    memo: dict = {}
    largest = max(cands, key=lambda c: c.n_params)
    _, ref_omega = _fit_spec(largest, est, None, "gmwm", grid, 2, memo)
    cost = sel.costs(gm_sweep(est.m, ref_omega))
    rows = [sel.table_row(c, _fit_spec(c, est, ref_omega, "gmwm", grid, 2, memo)[0], cost) for c in cands]
    order = sel.ranked(rows)
    for i in order:  # the adequacy gate (gmwm_select module doc)
        out = fit_spec(cands[i], est, grid=grid, memo=memo)
        rows[i]["j_test_p"] = out.info["p_value"]
        if sel.passes_j_test(out):
            break
    else:
        i = order[0]
        out = fit_spec(cands[i], est, grid=grid, memo=memo)
    gate = "" if sel.passes_j_test(out) else f"no identified candidate passes the J test at {sel.J_TEST_LEVEL:g}"
    if method != "gmwm":
        out = fit_spec(cands[i], est, method=method, grid=grid, memo=memo)
    out.info.update(
        selection=rows,
        penalty=cost,
        j_test=gate or None,
        tau_min_s=float(est.m[0] * est.dt),
        short_scales=why,
        rejected=sel.rejection(out) or None,
    )
    return out


def fit_gmwm(
    segments, dt: float, model="auto", method: str = "gmwm", robust: bool = False, efficiency=rwv.DEFAULT_EFFICIENCY
) -> NoiseSpec:
    """GMWM (or AVLR) noise model of rate series (deg/h) sampled every ``dt`` s.

    ``model``: ``"auto"`` (identified selection among :data:`DEFAULT_CANDIDATES`), a label such as ``"white+gm+rw"``,
    a :class:`ModelSpec` or a list of them (selection among those). ``robust``: the robust GMWM (Guerrier et al.
    2016): the biweight M-estimate of the wavelet variance of Gaussian efficiency ``efficiency``
    (:mod:`gyrojax.noise.robust_wv`), weighted by its own covariance.
    """
    return fit_wv(WaveletVariance.of(segments, dt, robust=robust, efficiency=efficiency), model, method)


def fit_wv(est: WaveletVariance, model="auto", method: str = "gmwm") -> NoiseSpec:
    """:func:`fit_gmwm` on a given wavelet variance (e.g. :meth:`WaveletVariance.from_allan_table`)."""
    if isinstance(model, str) and model != "auto":
        model = ModelSpec.parse(model)
    if isinstance(model, ModelSpec):
        return fit_spec(model, est, method=method)
    return select_model(est, DEFAULT_CANDIDATES if model == "auto" else tuple(model), method=method)
