"""Coloured-noise handling: an autoregressive noise model per record, estimated from residuals, and the
whitening filter that turns least squares into generalised least squares (DESIGN principle 7).

Gyro random drift is coloured (Gauss–Markov, bias instability, rate random walk). A residual series r_t inside one
continuous segment is modelled as AR(p):  r_t = Σ_i φ_i r_{t−i} + e_t,  e_t white with variance s².
The order p is chosen by BIC from the pooled within-segment autocovariance (Yule–Walker, Levinson recursion via
``scipy.linalg.solve_toeplitz``). Applying 1 − Σ φ_i B^i to the measurements and regressors of each segment, and
dividing by s, gives a system whose errors are white with unit variance, so that standard errors and score tests
stay honest (Hu ch. 4 §4-55 onwards treats random drift as AR/ARMA series in the same spirit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_toeplitz
from scipy.signal import lfilter

from . import reml

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


@dataclass(frozen=True)
class ARNoise:
    """AR(p) noise model of one record's residuals: coefficients φ (p,), innovation std s, residual std σ."""

    phi: np.ndarray
    innovation_std: float
    std: float

    @property
    def order(self) -> int:
        """The AR order p (0: white noise)."""
        return len(self.phi)

    @property
    def variance_ratio(self) -> float:
        """σ²/s²: how much of the residual variance the colour explains (1 for white)."""
        return (self.std / self.innovation_std) ** 2 if self.innovation_std > 0 else 1.0


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
    """Autocovariance γ_0..γ_maxlag of ``r`` pooled over segments (lagged products never cross a segment)."""
    acc = np.zeros(max_lag + 1)
    n_tot = 0
    for s, e in bounds:
        x = r[s:e]
        m = len(x)
        n_tot += m
        if m == 0:
            continue
        nfft = 1 << int(np.ceil(np.log2(2 * m)))
        f = np.fft.rfft(x, nfft)
        ac = np.fft.irfft(f * np.conj(f), nfft)[: max_lag + 1]
        k = min(max_lag + 1, m)
        acc[:k] += ac[:k]
    return acc / max(n_tot, 1), n_tot


def fit_ar(r: np.ndarray, labels: np.ndarray, p_max: int = P_MAX) -> ARNoise:
    """AR noise model of the residual ``r`` by Yule–Walker, order by BIC (0 means white)."""
    bounds = segment_bounds(labels)
    lens = [e - s for s, e in bounds]
    if not lens:
        return ARNoise(np.zeros(0), 1.0, 1.0)
    p_max = int(max(0, min(p_max, min(lens) // 4, sum(lens) // 50)))
    gamma, n = pooled_autocovariance(r, bounds, p_max)
    var = float(gamma[0])
    if var <= 0 or not np.isfinite(var):
        return ARNoise(np.zeros(0), 0.0, 0.0)
    best = (np.log(var), np.zeros(0), var)  # BIC of the white model (up to constants)
    best_bic = n * np.log(var)
    for p in range(1, p_max + 1):
        try:
            phi = solve_toeplitz(gamma[:p], gamma[1 : p + 1])
        except np.linalg.LinAlgError:
            break
        s2 = var - float(phi @ gamma[1 : p + 1])
        if not s2 > 0:
            break
        # stationarity: all roots of 1 − Σ φ_i z^i outside the unit circle
        if p and np.any(np.abs(np.roots(np.concatenate([[1.0], -phi]))) >= 1.0):
            break
        bic = n * np.log(s2) + p * np.log(n)
        if bic < best_bic - 1e-9:
            best_bic, best = bic, (np.log(s2), phi, s2)
    _, phi, s2 = best
    return ARNoise(np.asarray(phi, dtype=float), float(np.sqrt(s2)), float(np.sqrt(var)))


def whiten(x: np.ndarray, labels: np.ndarray, noise, times: np.ndarray | None = None):
    """Apply the whitening filter (1 − Σ φ_i B^i)/s to ``x`` (n,) or (n, p) inside each segment.

    Returns the whitened rows and the indices kept: the first p entries of each segment (whose filter would
    reach before the segment) are dropped.
    """
    x = np.asarray(x, dtype=float)
    if isinstance(noise, GMNoise):
        if times is None:
            raise ValueError("whitening under a Gauss–Markov model needs the measurement times")
        keep = np.flatnonzero(labels >= 0)
        w, _ = kalman_whiten(x[keep], times[keep], noise, reml.series_restarts(times[keep]))
        return w, keep
    p = noise.order
    b = np.concatenate([[1.0], -noise.phi]) / (noise.innovation_std if noise.innovation_std > 0 else 1.0)
    rows, keep = [], []
    for s, e in segment_bounds(labels):
        if e - s <= p:
            continue
        seg = x[s:e]
        y = lfilter(b, [1.0], seg, axis=0)
        rows.append(y[p:])
        keep.append(np.arange(s + p, e))
    if not rows:
        shape = (0,) + x.shape[1:]
        return np.zeros(shape), np.zeros(0, dtype=int)
    return np.concatenate(rows, axis=0), np.concatenate(keep)


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


@dataclass(frozen=True)
class GMNoise:
    """White noise (variance ``white_var``) plus a first-order Gauss–Markov process of stationary variance
    ``gm_var`` and correlation time ``tau_s`` (s). Whitened exactly by the Kalman filter's normalised innovations,
    across the gaps between segments (the drift stays correlated while the table moves).

    Variances are in the residual's unit squared ((deg/h)² for gyros, g² for accelerometers); between samples Δt
    apart the GM state decays by φ = exp(−Δt/τ). ``readout_var`` (servo records): the variance σ_q² of the angle
    readout's white error over the sample interval, e/Δ, which differences into the increments
    (:func:`gyrojax.noise.reml.readout_scan`; it is known, not fitted: :mod:`gyrojax.noise.readout`).
    """

    tau_s: float
    gm_var: float
    white_var: float
    readout_var: float = 0.0

    order = "gm"

    @property
    def std(self) -> float:
        """Stationary std of the residual, √(σ_g² + σ_w²), in the residual's unit."""
        return float(np.sqrt(self.gm_var + self.white_var))

    @property
    def innovation_std(self) -> float:
        """Steady-state innovation std for a unit step (the white-equivalent level)."""
        return float(np.sqrt(self.white_var + self.gm_var * (1 - np.exp(-2.0 / max(self.tau_s, 1e-300)))))

    @property
    def variance_ratio(self) -> float:
        """σ²/s² as for :class:`ARNoise` (dimensionless; 1 for white noise)."""
        return self.std**2 / self.innovation_std**2


def _kalman_scan(x, phi, white_var, gm_var):
    """Normalised innovations of x (n, m) and log S (n,) for a GM(φ_k)+white model; φ_k = 0 restarts."""
    import jax
    import jax.numpy as jnp

    def step(carry, inp):
        pred, p_pred = carry
        z, ph = inp
        # propagate from the previous sample (φ = 0: a fresh, independent start)
        p_pred = ph * ph * p_pred + gm_var * (1.0 - ph * ph)
        pred = ph * pred
        s = p_pred + white_var
        k = p_pred / s
        nu = z - pred
        out = nu / jnp.sqrt(s)
        pred = pred + k * nu
        p_pred = (1.0 - k) * p_pred
        return (pred, p_pred), (out, jnp.log(s))

    m = x.shape[1]
    (_, _), (w, logs) = jax.lax.scan(step, (jnp.zeros(m), jnp.asarray(gm_var)), (x, phi))
    return w, logs


_kalman_jit = None


def kalman_whiten(x: np.ndarray, times: np.ndarray, nz: GMNoise, restart: np.ndarray | None = None):
    """Exact GLS whitening under ``nz``: (whitened x, dimensionless; log S, S the innovation variance in x's unit
    squared). ``times`` (s) give φ_k = exp(−Δt_k/τ); ``restart`` marks rows that start a new series."""
    import jax

    global _kalman_jit
    if _kalman_jit is None:
        _kalman_jit = jax.jit(_kalman_scan)
    x = np.asarray(x, dtype=float)
    x2 = x[:, None] if x.ndim == 1 else x
    if nz.readout_var > 0:
        return _readout_whiten(x, x2, times, nz, restart)
    dt = np.diff(times, prepend=times[0] if len(times) else 0.0)
    phi = np.exp(-np.clip(dt, 0.0, None) / nz.tau_s)
    bad = dt <= 0
    if restart is not None:
        bad |= restart
    phi[bad] = 0.0
    w, logs = _kalman_jit(x2, phi, nz.white_var, nz.gm_var)
    w = np.asarray(w)
    return (w[:, 0] if x.ndim == 1 else w), np.asarray(logs)


def _readout_whiten(x, x2, times, nz: GMNoise, restart):
    """:func:`kalman_whiten` with the servo readout's noise (:func:`gyrojax.noise.reml.readout_scan`), rows and
    columns padded to the likelihood's buckets so that one compiled filter serves records of similar length."""
    import jax

    global _readout_jit
    if _readout_jit is None:
        _readout_jit = jax.jit(reml.readout_scan)
    n, m = x2.shape
    nb, mb = reml.bucket_rows(n), reml.bucket_cols(m)
    dt = np.ones(nb)
    dt[:n] = np.diff(times, prepend=times[0] if n else 0.0)
    rs = np.ones(nb, dtype=bool)
    rs[:n] = dt[:n] <= 0
    if n:
        rs[0] = True
    if restart is not None:
        rs[:n] |= np.asarray(restart, dtype=bool)
    steps = dt[1:n][~rs[1:n]]
    step = float(np.median(steps)) if steps.size else 1.0
    mask = np.zeros(nb, dtype=bool)
    mask[:n] = True
    xp = np.zeros((nb, mb))
    xp[:n, :m] = x2
    theta = np.array([nz.tau_s, nz.gm_var, nz.white_var])
    w, logs = _readout_jit(theta, np.array([nz.readout_var, step]), xp, dt, rs, mask)
    w, logs = np.asarray(w)[:n, :m], np.asarray(logs)[:n]
    return (w[:, 0] if x.ndim == 1 else w), logs


_readout_jit = None


def gm_loglik(r: np.ndarray, labels: np.ndarray, times: np.ndarray, nz: GMNoise) -> tuple[float, int]:
    """Exact Gaussian −2 log-likelihood (without the 2π term) of r under ``nz``, and the sample count.

    ``r`` and ``nz`` in the same units (e.g. deg/h and (deg/h)²), ``times`` in s, ``labels`` −1 for excluded rows.
    """
    ok = labels >= 0
    w, logs = kalman_whiten(r[ok], times[ok], nz, reml.series_restarts(times[ok]))
    return float(np.sum(logs) + w @ w), int(ok.sum())


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
    # collinear columns (the diagnosis' nuisance offsets): QR as before, the determinant over the independent columns
    q, rr = np.linalg.qr(jw)
    d = np.abs(np.diag(rr))
    keep = d > 1e-12 * max(d.max(), 1e-300)
    return rw - q @ (q.T @ rw), float(2.0 * np.sum(np.log(d[keep])))


def gm_reml(r: np.ndarray, design: np.ndarray, labels: np.ndarray, times: np.ndarray, nz: GMNoise) -> float:
    """Restricted −2 log-likelihood of r under ``nz`` with the regressors ``design`` (n, p) estimated by GLS:
    Σ log S_k + |ẽ|² + log det(J̃ᵀJ̃), with ẽ the whitened GLS residual and J̃ the whitened regressors.

    ``r`` and ``nz`` in the same units (as :func:`gm_loglik`), ``times`` in s.
    """
    ok = labels >= 0
    x = np.column_stack([r[ok], design[ok]])
    w, logs = kalman_whiten(x, times[ok], nz, reml.series_restarts(times[ok]))
    e, logdet = gls_residual(w[:, 0], w[:, 1:])
    return float(np.sum(logs) + e @ e + logdet)


def gm_profile(r: np.ndarray, design: np.ndarray, labels: np.ndarray, times: np.ndarray, nz: GMNoise) -> float:
    """Profile −2 log-likelihood (without 2π) of r under ``nz`` with ``design`` estimated by GLS: Σ log S_k + |ẽ|².

    ``r`` and ``nz`` in the same units (as :func:`gm_loglik`), ``times`` in s.
    """
    ok = labels >= 0
    x = np.column_stack([r[ok], design[ok]])
    w, logs = kalman_whiten(x, times[ok], nz, reml.series_restarts(times[ok]))
    e, _ = gls_residual(w[:, 0], w[:, 1:])
    return float(np.sum(logs) + e @ e)


def fit_gm(
    r: np.ndarray,
    labels: np.ndarray,
    times: np.ndarray,
    max_lag: int = 2000,
    design: np.ndarray | None = None,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    neutral_start: bool = False,
    start: GMNoise | None = None,
    readout_var: float = 0.0,
) -> GMNoise | None:
    """White + Gauss–Markov model from the pooled autocovariance: γ_0 = σ_w² + σ_g², γ_k = σ_g² φ^k (k ≥ 1),
    φ = exp(−Δt/τ) at the median step Δt (s, from ``times``), then refined by maximum likelihood (REML when
    ``design`` is given), τ capped at the span / ``tau_span_fraction`` (span: the longest series; stacked series
    restart where time goes back). None when no segment has 8 samples, the residual is zero, or the
    autocovariance gives no admissible split (0 < σ_g² < γ_0) — unless ``neutral_start``, when the likelihood then
    starts from a neutral split instead (the fit's choice; the diagnosis keeps such residuals for its candidates).
    Variances in the unit of ``r`` squared. ``start``: a previous fit of a closely related residual (the diagnosis'
    rounds) to start from instead of the moment estimate. ``readout_var``: a servo readout's known angle noise
    (:class:`GMNoise`), beside which the rate noise is fitted.
    """
    from scipy.optimize import minimize_scalar

    bounds = segment_bounds(labels)
    lens = [e - s for s, e in bounds]
    if not lens or max(lens) < 8:
        return None
    if start is not None and start.gm_var > 0 and start.white_var > 0:
        return _gm_mle(r, labels, times, start, design, False, tau_span_fraction, readout_var)
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

    sol = minimize_scalar(loss, bounds=(np.log(1e-7), np.log(0.999)), method="bounded")
    phi = float(1.0 - np.exp(sol.x))
    a = amp(phi)
    if 0 < a < g0:
        start = GMNoise(-dt0 / np.log(phi), a, g0 - a)
    elif neutral_start:  # no admissible split by moments: let the likelihood decide from a neutral one
        start = GMNoise(10 * dt0, 0.1 * g0, 0.9 * g0)
    else:
        return None
    return _gm_mle(r, labels, times, start, design, tau_span_fraction=tau_span_fraction, readout_var=readout_var)


def _gm_mle(
    r,
    labels,
    times,
    start: GMNoise,
    design=None,
    grid: bool = True,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    readout_var: float = 0.0,
) -> GMNoise:
    """Refine a white + Gauss–Markov model by maximising the exact (Kalman) likelihood — restricted (REML) when the
    regressors of the fit are given, so that the drift the fitted coefficients absorbed is not lost from σ_g².

    The autocovariance fit inside short segments underestimates τ when τ is comparable to a segment; the
    likelihood sees the correlation across the gaps between segments too. Jitted JAX likelihood with exact
    derivatives, minimised by quasi-Newton from the best of a grid of starts (:func:`gyrojax.noise.reml.fit`);
    ``grid=False`` uses a coarser grid around ``start`` (a previous fit of a closely related residual).
    """
    series = reml.prepare(r, design, labels, times, tau_span_fraction, readout_var=readout_var)
    theta, *_ = reml.fit(series, (start.tau_s, start.gm_var, start.white_var), reml=design is not None, coarse=not grid)
    return GMNoise(min(float(theta[0]), series.tau_max), float(theta[1]), float(theta[2]), readout_var)


def fit_noise(
    r: np.ndarray,
    labels: np.ndarray,
    times: np.ndarray,
    p_max: int = P_MAX,
    design: np.ndarray | None = None,
    tau_span_fraction: float = TAU_SPAN_FRACTION,
    neutral_start: bool = False,
    prefer_gm: bool = False,
    start: GMNoise | None = None,
    readout_var: float = 0.0,
):
    """The noise model of a residual: white + Gauss–Markov (maximum likelihood), unless an AR(p ≥ 1) model is
    better by BIC.

    White noise is never preferred to the GM model it is nested in: a Gauss–Markov drift too weak per sample for a
    model-selection criterion to notice can still dominate the error of a coefficient that depends on slow
    differences (position means), so dropping it would understate standard errors. When the drift is absent the
    likelihood drives its variance to ~0 and nothing is lost.

    ``prefer_gm``: the GM model whenever it can be fitted (the fit's choice: an AR(2–3) preferred by BIC to GM drift
    on a 2-hour servo record understated the long-run variance, ±2σ coverage 0.90 against 0.967 with GM).

    ``r`` in its own unit (deg/h for gyro residuals, g for accelerometers), ``times`` in s, ``design`` (n, p) the fit's
    regressors; ``start`` as for :func:`fit_gm`. Returns an :class:`ARNoise` or a :class:`GMNoise`.

    ``readout_var`` > 0 (a servo record's known angle readout noise, :class:`GMNoise`): always the white +
    Gauss–Markov rate beside it, which an AR model of the increments cannot hold.
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
    ar = fit_ar(r, labels, p_max)
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
