"""Coloured-noise handling: an autoregressive noise model per record, estimated from residuals, and the
whitening filter that turns least squares into generalised least squares, so verdicts stay honest in coloured noise.

Gyro random drift is coloured (Gauss–Markov, bias instability, rate random walk). A residual series r_t inside one
continuous segment is modelled as AR(p):  r_t = Σ_i φ_i r_{t−i} + e_t,  e_t white with variance s².
The order p is chosen by BIC from the pooled within-segment autocovariance (Yule–Walker by the Levinson–Durbin
recursion of :mod:`gyrojax.noise.randomdrift`). Applying 1 − Σ φ_i B^i to the measurements and regressors of each
segment, and dividing by s, gives a system whose errors are white with unit variance, so that standard errors and
score tests stay honest (Hu ch. 4 §4-55 onwards treats random drift as AR/ARMA series in the same spirit).

Every noise model here is a :class:`~gyrojax.noise.spec.NoiseSpec` with ``dt_s`` the residual's sample interval (its
per-sample variances are those of the residual's unit squared: (deg/h)² for gyros, g² for accelerometers): white +
one Gauss–Markov term (``method`` "reml"), whitened exactly by the Kalman filter of
:func:`gyrojax.noise.reml.whiten_scan`, or an AR(p) colour of the white term (``method`` "ar").
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from gyrojax.optimize import minimize_scalar

from . import reml
from .randomdrift import levinson_durbin, segment_autocovariance_sums, yule_walker_cov
from .spec import NoiseSpec

P_MAX = 20
TAU_SPAN_FRACTION = 8.0
"""In the diagnosis, Gauss–Markov correlation times are capped at the record span / 8: structure slower than that
cannot be told from a deterministic trend within the record, and is left to ``bias_trend`` (and the diagnosis)
rather than to noise."""
FIT_TAU_SPAN_FRACTION = 1.0
"""In the fit (:func:`gyrojax.inference.identify.fit`), τ may reach the record span: the noise model is then pooled
over the
records of the campaign and its REML sees the scatter of the position means too, so slow drift is estimated rather
than assumed away (with the diagnosis' cap, 8-position standard errors under GM drift of τ = 300 s in 10-min
positions came out 2.5× too small)."""


def segment_bounds(labels: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) index pairs of the runs of equal, non-negative labels (−1 marks an excluded entry)."""
    out = []
    n = len(labels)
    if n == 0:
        return out
    change = np.flatnonzero(np.diff(labels) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [n]])
    for s, e in zip(starts, ends):
        if labels[s] >= 0:
            out.append((int(s), int(e)))
    return out


def pooled_autocovariance(r: np.ndarray, bounds, max_lag: int) -> tuple[np.ndarray, int]:
    """Autocovariance γ_0..γ_maxlag of ``r`` pooled over segments (lagged products never cross a segment): the
    per-segment sums of :func:`gyrojax.noise.randomdrift.segment_autocovariance_sums`, over all samples."""
    acc, n_tot = segment_autocovariance_sums(r, bounds, max_lag)
    return acc / max(n_tot, 1), n_tot


def _white(s2: float, dt_s: float, method: str = "ar") -> NoiseSpec:
    """White noise of per-sample variance ``s2`` at ``dt_s`` s."""
    return NoiseSpec.from_sample_variances(s2, dt_s, method=method)


def fit_ar(r: np.ndarray, labels: np.ndarray, dt_s: float, p_max: int = P_MAX) -> NoiseSpec:
    """AR noise model of the residual ``r`` by Yule–Walker, order by BIC (0 means white); ``dt_s`` the sample
    interval (s) of the spec's per-sample innovation variance."""
    bounds = segment_bounds(labels)
    lens = [e - s for s, e in bounds]
    if not lens:
        return _white(1.0, dt_s)
    p_max = int(max(0, min(p_max, min(lens) // 4, sum(lens) // 50)))
    gamma, n = pooled_autocovariance(r, bounds, p_max)
    var = float(gamma[0])
    if var <= 0 or not np.isfinite(var):
        return _white(0.0, dt_s)
    best = (np.zeros(0), var)  # the white model
    best_bic = n * np.log(var)  # BIC up to constants
    phis, sig, pacf = levinson_durbin(gamma, p_max) if p_max else ([], [var], [])
    for p in range(1, p_max + 1):
        phi, s2 = phis[p - 1], float(sig[p])
        if not s2 > 0 or abs(pacf[p - 1]) >= 1.0:  # stationary: every partial autocorrelation inside (−1, 1)
            break
        bic = n * np.log(s2) + p * np.log(n)
        if bic < best_bic - 1e-9:
            best_bic, best = bic, (phi, s2)
    phi, s2 = best
    spec = NoiseSpec.from_sample_variances(s2, dt_s, ar=tuple(float(x) for x in phi), method="ar")
    cov = yule_walker_cov(gamma, len(phi), s2, n)
    return replace(spec, cov=cov, cov_names=tuple(f"ar{i + 1}" for i in range(len(phi))))


def whiten(x: np.ndarray, labels: np.ndarray, noise, times: np.ndarray | None = None):
    """Apply the whitening filter (1 − Σ φ_i B^i)/s to ``x`` (n,) or (n, p) inside each segment.

    Returns the whitened rows and the indices kept: the first p entries of each segment (whose filter would
    reach before the segment) are dropped.
    """
    x = np.asarray(x, dtype=float)
    if noise.gauss_markov or noise.readout_var > 0:
        if times is None:
            raise ValueError("whitening under a Gauss–Markov model needs the measurement times")
        keep = np.flatnonzero(labels >= 0)
        w, _ = kalman_whiten(x[keep], times[keep], noise, reml.series_restarts(times[keep]))
        return w, keep
    p = len(noise.ar)
    s = noise.innovation_std
    b = np.concatenate([[1.0], -np.asarray(noise.ar)]) / (s if s > 0 else 1.0)
    rows, keep = [], []
    for s, e in segment_bounds(labels):
        if e - s <= p:
            continue
        rows.append(fir_past_start(b, x[s:e]))
        keep.append(np.arange(s + p, e))
    if not rows:
        shape = (0,) + x.shape[1:]
        return np.zeros(shape), np.zeros(0, dtype=int)
    return np.concatenate(rows, axis=0), np.concatenate(keep)


def fir_past_start(b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """y_t = Σ_k b_k x_{t−k} (k = 0…p) for the rows t ≥ p of ``x`` (n,) or (n, m), whose filter lies inside it: the
    rows of ``scipy.signal.lfilter(b, [1], x, axis=0)[p:]``, summed in its order (direct form II transposed:
    b_0 x_t + (b_1 x_{t−1} + (… + b_p x_{t−p}))), so equal to its last bit (test), without importing scipy.signal."""
    p, n = len(b) - 1, len(x)
    acc = b[p] * x[: n - p]
    for k in range(p - 1, -1, -1):
        acc = b[k] * x[p - k : n - k] + acc
    return acc


def first_difference_std(r: np.ndarray, labels: np.ndarray) -> float:
    """High-frequency noise level: std of r from successive differences inside segments, √(mean Δr²/2), in the
    units of r (deg/h for gyro residuals, g for accelerometers).

    Equals σ for white noise; ignores slow structure (drifts, Gauss–Markov with long τ).
    """
    acc, n = 0.0, 0
    for s, e in segment_bounds(labels):
        d = np.diff(r[s:e])
        acc += float(d @ d)
        n += len(d)
    return float(np.sqrt(acc / (2 * n))) if n else float(np.std(r))


# ---- white + first-order Gauss–Markov: exact whitening by the Kalman filter ------------------------------------

WHITEN_COLUMNS = 8
"""Columns :func:`kalman_whiten` filters per compiled call (a shape per row bucket, whatever the width)."""


def kalman_whiten(x: np.ndarray, times: np.ndarray, nz: NoiseSpec, restart: np.ndarray | None = None):
    """Exact GLS whitening under ``nz`` by the Kalman filter of :func:`gyrojax.noise.reml.whiten_scan`: (whitened x,
    dimensionless; log S, S the innovation variance in x's unit squared). ``times`` (s) give φ_k = exp(−Δt_k/τ);
    ``restart`` marks rows that start a new series (as does a step that is not positive). A servo readout's noise
    (``nz.readout_var`` > 0) enters the filter too (:func:`gyrojax.noise.reml.readout_scan`, Δ the median step)."""
    x = np.asarray(x, dtype=float)
    x2 = x[:, None] if x.ndim == 1 else x
    n = len(x2)
    dt = np.diff(times, prepend=times[0] if len(times) else 0.0)
    bad = dt <= 0
    if restart is not None:
        bad |= restart
    nb = reml.bucket_rows(n)  # padded rows (masked) pass through: a few compiled shapes for every length
    # columns padded too (a single series excepted) and filtered WHITEN_COLUMNS at a time: each column is filtered
    # on its own, so neither the padding nor the chunks change a bit of the others, and one compiled shape per row
    # bucket serves a fit's few columns, a model grown by an effect and a diagnosis' dozens of shapes alike
    width = 1 if x2.shape[1] == 1 else WHITEN_COLUMNS
    mb = -(-x2.shape[1] // width) * width
    xp = np.zeros((nb, mb))
    xp[:n, : x2.shape[1]] = x2
    dtp, rp, mp = np.ones(nb), np.ones(nb, dtype=bool), np.zeros(nb, dtype=bool)
    dtp[:n], rp[:n], mp[:n] = np.where(bad, 1.0, dt), bad, True
    steps = dt[~bad]
    readout = nz.whitening_readout(float(np.median(steps)) if steps.size else 1.0)
    readout = None if readout is None else np.asarray(readout, float)
    theta = np.asarray(nz.whitening_theta(), float)
    # every chunk dispatched before the first is read back (log S is the same in each: it is the filter's alone)
    parts = [reml.whiten_jit(theta, xp[:, k : k + width], dtp, rp, mp, readout) for k in range(0, mb, width)]
    w = np.concatenate([np.asarray(p[0]) for p in parts], axis=1)[:n, : x2.shape[1]]
    return (w[:, 0] if x.ndim == 1 else w), np.asarray(parts[0][1])[:n]


def gm_loglik(r: np.ndarray, labels: np.ndarray, times: np.ndarray, nz: NoiseSpec) -> tuple[float, int]:
    """Exact Gaussian −2 log-likelihood (without the 2π term) of r under ``nz``, and the sample count
    (:func:`gyrojax.noise.reml.neg2_loglik` without regressors).

    ``r`` and ``nz`` in the same units (e.g. deg/h and (deg/h)² per sample), ``times`` in s, ``labels`` −1 for
    excluded rows.
    """
    return gm_profile(r, None, labels, times, nz), int((np.asarray(labels) >= 0).sum())


GLS_RANK_TOL = 1e-13
"""Directions of the normalised normal matrix with eigenvalue below this fraction of the largest are not estimated."""


def gls_residual(rw: np.ndarray, jw: np.ndarray) -> tuple[np.ndarray, float]:
    """Whitened GLS residual ẽ = r̃ − J̃β̂ and log det(J̃ᵀJ̃) over the estimable directions.

    By the p×p normal equations in normalised columns (eigen-decomposition): dozens of times cheaper than a QR of the
    n×p matrix, and the likelihood is evaluated hundreds of times per noise fit. Columns that are collinear (an
    eigenvalue below :data:`GLS_RANK_TOL` of the largest) go by QR, whose diagonal names the independent ones. ``rw``
    (n,) in whitened units (dimensionless), ``jw`` (n, p) in whitened units per coefficient unit.
    """
    if jw.shape[1] == 0:
        return rw, 0.0
    sc = np.sqrt(np.einsum("ij,ij->j", jw, jw))
    live = sc > 0
    if not live.any():
        return rw, 0.0
    z = jw[:, live] / sc[live]
    ev, vec = np.linalg.eigh(z.T @ z)
    if ev.min() > GLS_RANK_TOL * max(float(ev.max()), 1e-300):
        e = rw - z @ (vec @ ((vec.T @ (z.T @ rw)) / ev))
        return e, float(np.sum(np.log(ev)) + 2.0 * np.sum(np.log(sc[live])))
    # collinear columns (the diagnosis' nuisance offsets): the QR's residual, the determinant over the independent
    # columns
    q, rr = np.linalg.qr(jw)
    d = np.abs(np.diag(rr))
    keep = d > 1e-12 * max(d.max(), 1e-300)
    return rw - q @ (q.T @ rw), float(2.0 * np.sum(np.log(d[keep])))


def gm_reml(r: np.ndarray, design: np.ndarray | None, labels: np.ndarray, times: np.ndarray, nz: NoiseSpec) -> float:
    """Restricted −2 log-likelihood of r under ``nz`` with the regressors ``design`` (n, p) estimated by GLS:
    Σ log S_k + |ẽ|² + log det(J̃ᵀJ̃), with ẽ the whitened GLS residual and J̃ the whitened regressors (the one REML
    objective, :func:`gyrojax.noise.reml.neg2_loglik`).

    ``r`` and ``nz`` in the same units (as :func:`gm_loglik`), ``times`` in s.
    """
    series = reml.prepare(r, design, labels, times, 1.0, readout_var=nz.readout_var)
    return reml.neg2_loglik(series, nz.whitening_theta(), True)


def gm_profile(r: np.ndarray, design: np.ndarray | None, labels: np.ndarray, times: np.ndarray, nz: NoiseSpec) -> float:
    """Profile −2 log-likelihood (without 2π) of r under ``nz`` with ``design`` estimated by GLS: Σ log S_k + |ẽ|².

    ``r`` and ``nz`` in the same units (as :func:`gm_loglik`), ``times`` in s.
    """
    series = reml.prepare(r, design, labels, times, 1.0, readout_var=nz.readout_var)
    return reml.neg2_loglik(series, nz.whitening_theta(), False)


def fit_gm(
    r: np.ndarray,
    labels: np.ndarray,
    times: np.ndarray,
    max_lag: int = 2000,
    design: np.ndarray | None = None,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    neutral_start: bool = False,
    start: NoiseSpec | None = None,
    readout_var: float = 0.0,
) -> NoiseSpec | None:
    """White + Gauss–Markov model from the pooled autocovariance: γ_0 = σ_w² + σ_g², γ_k = σ_g² φ^k (k ≥ 1),
    φ = exp(−Δt/τ) at the median step Δt (s, from ``times``), then refined by maximum likelihood (REML when
    ``design`` is given), τ capped at the span / ``tau_span_fraction`` (span: the longest series; stacked series
    restart where time goes back). None when no segment has 8 samples, the residual is zero, or the
    autocovariance gives no admissible split (0 < σ_g² < γ_0) — unless ``neutral_start``, when the likelihood then
    starts from a neutral split instead (the fit's choice; the diagnosis keeps such residuals for its candidates).
    Variances in the unit of ``r`` squared. ``start``: a previous fit of a closely related residual (the diagnosis'
    rounds) to start from instead of the moment estimate. ``readout_var``: a servo readout's known angle noise
    (:attr:`NoiseSpec.readout_var`), beside which the rate noise is fitted.
    """
    bounds = segment_bounds(labels)
    lens = [e - s for s, e in bounds]
    if not lens or max(lens) < 8:
        return None
    if start is not None and start.gm_variance > 0 and start.white_variance > 0:
        theta0 = start.whitening_theta()
        return _gm_mle(r, labels, times, theta0, design, False, tau_span_fraction, readout_var)
    dt0 = float(np.median(np.diff(times))) if len(times) > 1 else 1.0
    if not dt0 > 0:
        dt0 = 1.0
    lag = int(min(max_lag, max(lens) // 2))
    gamma, _ = pooled_autocovariance(r, bounds, lag)
    g0 = gamma[0]
    if g0 <= 0:
        return None
    if readout_var > 0:  # the readout's MA(1) is no part of the rate's autocovariance
        gamma[0] -= 2.0 * readout_var
        gamma[1] += readout_var
        g0 = max(gamma[0], 1e-3 * (gamma[0] + 2.0 * readout_var))
    k = np.arange(1, lag + 1)
    g = gamma[1:]

    def amp(phi):
        w = phi**k
        return float(g @ w / max(w @ w, 1e-300))

    def loss(u):
        phi = 1.0 - np.exp(u)
        return float(np.sum((g - amp(phi) * phi**k) ** 2))

    sol = minimize_scalar(loss, np.log(1e-7), np.log(0.999), what="the moment fit of φ")
    phi = float(1.0 - np.exp(sol.x))
    a = amp(phi)
    if 0 < a < g0:
        theta0 = (-dt0 / np.log(phi), a, g0 - a)
    elif neutral_start:  # no admissible split by moments: let the likelihood decide from a neutral one
        theta0 = (10 * dt0, 0.1 * g0, 0.9 * g0)
    else:
        return None
    return _gm_mle(r, labels, times, theta0, design, tau_span_fraction=tau_span_fraction, readout_var=readout_var)


def _gm_mle(
    r,
    labels,
    times,
    start: tuple,
    design=None,
    grid: bool = True,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    readout_var: float = 0.0,
) -> NoiseSpec:
    """Refine a white + Gauss–Markov model by maximising the exact (Kalman) likelihood — restricted (REML) when the
    regressors of the fit are given, so that the drift the fitted coefficients absorbed is not lost from σ_g².

    The autocovariance fit inside short segments underestimates τ when τ is comparable to a segment; the
    likelihood sees the correlation across the gaps between segments too. Jitted JAX likelihood with exact
    derivatives, minimised by quasi-Newton from the best of a grid of starts (:func:`gyrojax.noise.reml.fit`);
    ``grid=False`` uses a coarser grid around ``start`` = (τ s, σ_g², σ_w²) (a previous fit of a closely related
    residual). The spec's ``dt_s`` is the median step of the series; its status is that of the search. ``readout_var``
    (:func:`fit_gm`) is carried into the spec.
    """
    series = reml.prepare(r, design, labels, times, tau_span_fraction, readout_var=readout_var)
    sol = reml.fit(series, start, reml=design is not None, coarse=not grid)
    theta = sol.x
    tau = min(float(theta[0]), series.tau_max)
    gm = [(float(theta[1]), tau)]
    spec = NoiseSpec.from_sample_variances(float(theta[2]), series.dt0, gm, method="reml", readout_var=readout_var)
    return spec.with_status(sol.converged, sol.reason)


def with_reml_covariance(nz: NoiseSpec, r, design, labels, times, tau_span_fraction: float) -> NoiseSpec:
    """``nz`` (white + Gauss–Markov, fitted by REML to ``r`` with ``design``) with the covariance of its natural
    parameters (N, σ, T): 2H⁻¹ in u = log(τ, σ_g², σ_w²) (H the Hessian of −2 log L_R,
    :func:`gyrojax.noise.reml.reml_hessian`), by the delta method (∂N/∂u_w = N/2, ∂σ/∂u_g = σ/2, ∂T/∂u_τ = T). A T at
    its cap is pinned (infinite variance); a non-finite curvature leaves every variance infinite. ``times`` in s, τ
    capped at the longest series' span (s) / ``tau_span_fraction``; N in deg/√h, σ deg/h, T s (the residual's unit in
    place of deg/h for accelerometers)."""
    if not nz.gauss_markov or nz.gm_variance <= 0 or nz.white_variance <= 0:
        return nz
    series = reml.prepare(r, design, labels, times, tau_span_fraction, readout_var=nz.readout_var)
    theta = nz.whitening_theta()
    free = [1, 2] if theta[0] >= 0.999 * series.tau_max else [0, 1, 2]
    cov_u = np.full((3, 3), 0.0)
    np.fill_diagonal(cov_u, np.inf)
    cu_free = reml_curvature_covariance(series, theta, free)
    if cu_free is not None:
        cov_u[np.ix_(free, free)] = cu_free
    g = _delta_factors(nz)
    cu = cov_u[np.ix_(_U_ORDER, _U_ORDER)]
    with np.errstate(invalid="ignore"):
        cov = np.where(np.isfinite(cu), cu * np.outer(g, g), np.inf)
    cov[~np.isfinite(cu) & ~np.eye(3, dtype=bool)] = 0.0
    return replace(nz, cov=cov, cov_names=REML_COV_NAMES)


REML_COV_NAMES = ("white", "gm1_sigma", "gm1_tau")
"""The natural parameters (N, σ, T) of :func:`with_reml_covariance`'s covariance, in its order."""

_U_ORDER = [2, 1, 0]
"""u = (log τ, log σ_g², log σ_w²) reordered as the natural (white, gm1_sigma, gm1_tau), and back."""


def _delta_factors(nz: NoiseSpec) -> np.ndarray:
    """∂(N, σ, T)/∂(u_w, u_g, u_τ) on the diagonal: (N/2, σ/2, T), the delta method of :func:`with_reml_covariance`."""
    (sigma, tau), n = nz.gauss_markov[0], nz.white
    return np.array([n / 2.0, sigma / 2.0, tau])


def reml_curvature_covariance(series, theta, free) -> np.ndarray | None:
    """2H⁻¹ over the ``free`` entries of u = log(τ, σ_g², σ_w²), H the Hessian of −2 log L_R at ``theta``
    (:func:`gyrojax.noise.reml.reml_hessian`; information = H / 2), its eigenvalues floored at 1e-9 of the largest;
    None when the curvature is not finite."""
    hess = reml.reml_hessian(series, theta)[np.ix_(free, free)]
    if not np.all(np.isfinite(hess)):
        return None
    w, vec = np.linalg.eigh(0.5 * (hess + hess.T))
    w = np.maximum(w, 1e-9 * max(float(w.max()), 1e-300))
    return 2.0 * (vec / w) @ vec.T


def reml_u_covariance(nz: NoiseSpec) -> np.ndarray | None:
    """The covariance 2H⁻¹ (3, 3) in u = log(τ, σ_g², σ_w²) that :func:`with_reml_covariance` computed and stored in
    natural units, recovered by undoing its delta method (rounding only; a pinned or unknown entry stays infinite),
    so that its users (the Satterthwaite degrees of freedom, :func:`gyrojax.inference.noisefit.satterthwaite_dof`)
    need not evaluate the REML curvature again. None when ``nz`` carries no such covariance."""
    if tuple(nz.cov_names) != REML_COV_NAMES or not nz.gauss_markov:
        return None
    g = _delta_factors(nz)
    if not np.all(np.isfinite(g) & (g > 0)):
        return None
    c = np.asarray(nz.cov, dtype=float)
    with np.errstate(invalid="ignore"):
        return (c / np.outer(g, g))[np.ix_(_U_ORDER, _U_ORDER)]


def fit_noise(
    r: np.ndarray,
    labels: np.ndarray,
    times: np.ndarray,
    p_max: int = P_MAX,
    design: np.ndarray | None = None,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    neutral_start: bool = False,
    prefer_gm: bool = False,
    start: NoiseSpec | None = None,
    readout_var: float = 0.0,
) -> NoiseSpec:
    """The noise model of a residual: white + Gauss–Markov (maximum likelihood), unless an AR(p ≥ 1) model is
    better by BIC.

    White noise is never preferred to the GM model it is nested in: a Gauss–Markov drift too weak per sample for a
    model-selection criterion to notice can still dominate the error of a coefficient that depends on slow
    differences (position means), so dropping it would understate standard errors. When the drift is absent the
    likelihood drives its variance to ~0 and nothing is lost.

    ``prefer_gm``: the GM model whenever it can be fitted (the fit's choice: an AR(2–3) preferred by BIC to GM drift
    on a 2-hour servo record understated the long-run variance, ±2σ coverage 0.90 against 0.967 with GM).

    ``r`` in its own unit (deg/h for gyro residuals, g for accelerometers), ``times`` in s, ``design`` (n, p) the fit's
    regressors; ``start`` as for :func:`fit_gm`. Returns a :class:`NoiseSpec`: white + Gauss–Markov or AR.

    ``readout_var`` > 0 (a servo record's known angle readout noise, :attr:`NoiseSpec.readout_var`): always the
    white + Gauss–Markov rate beside it, which an AR model of the increments cannot hold.
    """
    gm = fit_gm(
        r,
        labels,
        times,
        design=design,
        tau_span_fraction=tau_span_fraction,
        neutral_start=neutral_start or readout_var > 0,
        start=start,
        readout_var=readout_var,
    )
    if (prefer_gm or readout_var > 0) and gm is not None:
        return gm
    ar = fit_ar(r, labels, reml.sample_interval(np.asarray(times, float)[np.asarray(labels) >= 0]), p_max)
    if gm is None or ar.innovation_std <= 0:
        return ar
    if ar.order == 0:
        return gm
    w, keep = whiten(r, labels, ar)
    n = int((labels >= 0).sum())
    n_ar = max(len(keep), 1)
    m2_ar = (n_ar * np.log(ar.innovation_std**2) + float(w @ w)) * (n / n_ar)
    bic_ar = m2_ar + ar.order * np.log(n)
    m2_gm, n = gm_loglik(r, labels, times, gm)
    bic_gm = m2_gm + 3 * np.log(n)
    return gm if bic_gm < bic_ar else ar
