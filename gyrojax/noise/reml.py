"""White + first-order Gauss–Markov noise estimation as jitted JAX functions with exact derivatives.

A residual series r (n,) with regressors X (n, p) is modelled as r = Xβ + g + w: w white of variance σ_w², g a
first-order Gauss–Markov process of stationary variance σ_g² and correlation time τ (s), decaying by
φ_k = exp(−Δt_k/τ) between samples Δt_k apart (irregular steps and gaps allowed; a row where time does not increase
starts an independent series). The Kalman filter's normalised innovations whiten r and X exactly (Harvey 1989 §3.4;
the state-space form of the GM drift of IEEE 952 annex C), so that with ẽ the whitened GLS residual and S_k the
innovation variances

    −2 log L_P = Σ log S_k + |ẽ|²                                  (profile likelihood, β at its GLS estimate)
    −2 log L_R = Σ log S_k + |ẽ|² + log det(X̃ᵀX̃)                   (REML, Patterson & Thompson 1971)

(without the 2π terms). Both are one jitted function of u = (log τ, log σ_g², log σ_w²): the filter's two
recursions are two-level ``lax.scan`` s (about 2√N sequential steps), β is profiled out by the p×p normal equations
in normalised columns (Cholesky), and the minimum is found by a trust-region quasi-Newton method on the exact
gradient (reverse mode) from the best of a small grid of correlation times around the caller's start (a moment
estimate or a previous fit). The REML information of the Satterthwaite degrees of freedom is the Hessian by central
differences of that exact gradient (:func:`reml_hessian`; tested against ``jax.hessian``).

Shapes are padded to buckets (rows to m·2^k with 4 ≤ m < 8, columns to 4 or a multiple of 8) so that records of
similar length and models of similar size reuse one compiled function: padded rows pass through the filter
unchanged and carry no log S; each padded column is a unit vector on a padded row, orthogonal to everything else,
so it adds nothing to |ẽ|² or to log det.

Collinear regressors (the diagnosis' per-record offset beside a constant D_F column) are rank-safe: whitening is
invertible, so the column space of X̃ is that of X, and the columns kept are those independent of the columns
before them (|R_kk| of a QR of the normalised X above :data:`RANK_TOL`), which gives log det over the estimable
directions exactly as a QR of X̃ would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.optimize import Solution, difference_curvature, minimize
from gyrojax.runtime.kept import Kept
from gyrojax.runtime.threads import parallel_map

RANK_TOL = 1e-7
"""A regressor whose normalised component orthogonal to the previous regressors is below this is not estimated."""
TAU_FLOOR_STEPS = 0.05
"""Lower bound of τ in sample steps: a Gauss–Markov process faster than this is white noise to the filter."""
VAR_SPAN = 1e12
"""Variances are searched within [total/VAR_SPAN, total·1e4], total the residual's variance."""


def bucket_rows(n: int) -> int:
    """Smallest m·2^k ≥ n with 4 ≤ m < 8 (at most 25 % padding; four sizes per octave), at least 16."""
    n = max(int(n), 16)
    k = max(n.bit_length() - 3, 0)
    return -(-n // (1 << k)) << k


def bucket_cols(p: int) -> int:
    """Columns padded to 4, or beyond 4 to a multiple of 8: the filter's cost grows with its columns, and a model of
    a few terms with a per-record offset fits in 4."""
    return 4 if p <= 4 else -(-int(p) // 8) * 8


def independent_columns(design: np.ndarray, tol: float = RANK_TOL) -> np.ndarray:
    """Indices of the columns of ``design`` (n, p) independent of the columns before them (QR of the column-normalised
    matrix; |R_kk| ≤ ``tol`` marks a column in the span of the previous ones, or a zero column)."""
    if design.shape[1] == 0:
        return np.zeros(0, dtype=int)
    norms = np.sqrt(np.einsum("ij,ij->j", design, design))
    live = norms > 0
    z = design[:, live] / norms[live]
    if z.shape[1] == 0:
        return np.zeros(0, dtype=int)
    d = np.abs(np.diag(np.linalg.qr(z, mode="r")))
    return np.flatnonzero(live)[d > tol]


@dataclass(frozen=True)
class Series:
    """A residual and its regressors prepared for the jitted likelihood (rows with label ≥ 0 only, padded).

    ``x`` (N, 1 + P): column 0 the residual (its unit, e.g. deg/h), then the independent regressors scaled to unit
    norm and the padding columns; ``dt`` (N,) steps (s); ``restart`` (N,) rows that start a series; ``mask`` (N,) real
    rows. ``norms`` the regressors' column norms; ``logdet_const`` = 2 Σ log(norms) restores log det(X̃ᵀX̃) of the
    unscaled regressors.
    """

    x: np.ndarray
    dt: np.ndarray
    restart: np.ndarray
    mask: np.ndarray
    logdet_const: float
    n: int
    rank: int
    tau_max: float
    dt0: float
    var0: float
    norms: np.ndarray
    readout: object = None  # (σ_q², Δ s) of a servo record's angle readout (:func:`readout_scan`), or None

    @cached_property
    def arrays(self):
        """The array arguments of the jitted functions, placed on the device once: a search evaluates the
        likelihood dozens of times on the same arrays, and numpy arguments would be copied to the device at every
        call (the values are the same)."""
        return tuple(jax.device_put((self.x, self.dt, self.restart, self.mask)))


def series_restarts(times: np.ndarray) -> np.ndarray:
    """Rows where an independent series starts: the first row, or ``times`` (s) not increasing (stacked records)."""
    out = np.zeros(len(times), dtype=bool)
    if len(times):
        out[0] = True
        out[1:] = np.diff(times) <= 0
    return out


def sample_interval(times: np.ndarray) -> float:
    """The median step (s) of ``times`` within its series (steps that are not positive start a series), 1 without
    one."""
    steps = np.diff(np.asarray(times, float))
    steps = steps[steps > 0]
    dt0 = float(np.median(steps)) if steps.size else 1.0
    return dt0 if dt0 > 0 else 1.0


def longest_span(times: np.ndarray, restart: np.ndarray) -> float:
    """Longest time span (s) of the independent series in ``times`` (each starts where ``restart`` is set)."""
    if not len(times):
        return 1.0
    starts = np.flatnonzero(restart)
    ends = np.append(starts[1:], len(times))
    return float(max(np.ptp(times[s:e]) for s, e in zip(starts, ends))) or 1.0


def prepare(
    r, design, labels, times, tau_span_fraction: float, select: bool = True, readout_var: float = 0.0
) -> Series:
    """A :class:`Series` of the rows with ``labels`` ≥ 0 of ``r`` (n,), ``design`` (n, p) or None and ``times`` (s);
    τ capped at the longest series' span / ``tau_span_fraction``. ``select=False`` keeps every column (for
    :func:`whitened_gram`; the likelihood needs the independent ones). ``readout_var`` σ_q² > 0: the increments also
    carry a servo readout's white angle noise (:func:`readout_scan`; Δ the median step)."""
    ok = np.asarray(labels) >= 0
    r = np.asarray(r, dtype=float)[ok]
    t = np.asarray(times, dtype=float)[ok]
    n = len(r)
    j = np.zeros((n, 0)) if design is None else np.asarray(design, dtype=float)[ok]
    if select:
        j = j[:, independent_columns(j)]
    norms = np.sqrt(np.einsum("ij,ij->j", j, j)) if j.shape[1] else np.zeros(0)
    norms = np.where(norms > 0, norms, 1.0)
    j = j / norms if j.shape[1] else j
    p = j.shape[1]
    pb = bucket_cols(p)
    nb = bucket_rows(n + pb - p)
    x = np.zeros((nb, 1 + pb))
    x[:n, 0] = r
    x[:n, 1 : 1 + p] = j
    for k in range(pb - p):  # padding column k: a unit vector on padded row n + k
        x[n + k, 1 + p + k] = 1.0
    restart = np.ones(nb, dtype=bool)
    restart[:n] = series_restarts(t)
    dt = np.ones(nb)
    dt[:n] = np.diff(t, prepend=t[0] if n else 0.0)
    mask = np.zeros(nb, dtype=bool)
    mask[:n] = True
    steps = np.diff(t)[~restart[1:n]] if n > 1 else np.zeros(0)
    dt0 = float(np.median(steps)) if steps.size else 1.0
    dt0 = dt0 if dt0 > 0 else 1.0
    tau_max = max(longest_span(t, restart[:n]) / tau_span_fraction, 1e-9)
    var0 = float(np.var(r)) if n else 1.0
    readout = jnp.asarray([readout_var, dt0], dtype=jnp.float64) if readout_var > 0 else None
    return Series(
        x,
        dt,
        restart,
        mask,
        float(2.0 * np.sum(np.log(norms))),
        n,
        p,
        tau_max,
        dt0,
        var0 if var0 > 0 else 1.0,
        norms,
        readout,
    )


# ---- the jitted likelihood ----------------------------------------------------------------------------------------


def block_length(n: int) -> int:
    """Block length L (a power of two dividing ``n``, about √n) of the two-level scans."""
    k = (n & -n).bit_length() - 1  # n = odd · 2^k
    return 1 << min(k, max(int(round(math.log2(max(n, 1)) / 2)), 0))


def _apply(mat, p):
    a, b, c, d = mat
    return (a * p + b) / (c * p + d)


@jax.custom_jvp
def mobius_prefix(mats, p0):
    """P_k = M_k ∘ … ∘ M_1 (p0) for linear-fractional maps M_k: P ↦ (a P + b)/(c P + d) with entries ≥ 0, ``mats``
    four (N,) arrays. Two-level scan: compositions inside blocks of L steps (sequential in L, vectorised over the
    blocks), then the value at each block end (sequential over the blocks), then every value (elementwise)."""
    n = mats[0].shape[0]
    ell = block_length(n)
    blocks = [m.reshape(n // ell, ell).T for m in mats]  # (L, B)

    def compose(carry, m):
        a1, b1, c1, d1 = carry
        a2, b2, c2, d2 = m
        a, b = a2 * a1 + b2 * c1, a2 * b1 + b2 * d1
        c, d = c2 * a1 + d2 * c1, c2 * b1 + d2 * d1
        norm = a + b + c + d  # the map is projective: normalise against overflow
        out = (a / norm, b / norm, c / norm, d / norm)
        return out, out

    one = jnp.ones(n // ell, dtype=mats[0].dtype)
    zero = jnp.zeros_like(one)
    _, local = jax.lax.scan(compose, (one, zero, zero, one), tuple(blocks))  # each (L, B)
    total = tuple(m[-1] for m in local)

    def across(p, m):
        return _apply(m, p), p

    _, p_in = jax.lax.scan(across, p0, total)  # value entering each block (B,)
    return _apply(local, p_in[None, :]).T.reshape(n)


@jax.custom_jvp
def affine_prefix(coef, drive):
    """x_k = coef_k x_{k−1} + drive_k from x_0 = 0, ``coef`` (N,), ``drive`` (N, m): two-level scan as
    :func:`mobius_prefix`."""
    n, m = drive.shape
    ell = block_length(n)
    nb = n // ell
    cb = coef.reshape(nb, ell).T  # (L, B)
    db = drive.reshape(nb, ell, m).transpose(1, 0, 2)  # (L, B, m)

    def inner(carry, inp):
        a_acc, x_acc = carry
        a, d = inp
        a_acc = a * a_acc
        x_acc = a[:, None] * x_acc + d
        return (a_acc, x_acc), (a_acc, x_acc)

    init = (jnp.ones(nb, dtype=drive.dtype), jnp.zeros((nb, m), dtype=drive.dtype))
    _, (a_loc, x_loc) = jax.lax.scan(inner, init, (cb, db))

    def across(x, inp):
        a, xl = inp
        return a * x + xl, x

    _, x_in = jax.lax.scan(across, jnp.zeros(m, dtype=drive.dtype), (a_loc[-1][:, None], x_loc[-1]))  # (B, m)
    full = x_loc + a_loc[:, :, None] * x_in[None, :, :]  # (L, B, m)
    return full.transpose(1, 0, 2).reshape(n, m)


def _shift(x, first):
    """x_{k−1} (``first`` at k = 0)."""
    return jnp.concatenate([jnp.broadcast_to(first, (1,) + x.shape[1:]).astype(x.dtype), x[:-1]], axis=0)


@affine_prefix.defjvp
def _affine_prefix_jvp(primals, tangents):
    # the tangent obeys the same recursion: dx_k = coef_k dx_{k−1} + (dcoef_k x_{k−1} + ddrive_k), so derivatives of
    # any order reuse this two-level scan instead of differentiating through its internals (fast to compile)
    coef, drive = primals
    dcoef, ddrive = tangents
    x = affine_prefix(coef, drive)
    return x, affine_prefix(coef, ddrive + dcoef[:, None] * _shift(x, 0.0))


@mobius_prefix.defjvp
def _mobius_prefix_jvp(primals, tangents):
    # dP_k = M_k'(P_{k−1}) dP_{k−1} + (∂M_k/∂entries)(P_{k−1}) · dentries: an affine recursion
    (a, b, c, d), p0 = primals
    (da, db, dc, dd), dp0 = tangents
    p = mobius_prefix((a, b, c, d), p0)
    prev = _shift(p, p0)
    den = c * prev + d
    num = a * prev + b
    slope = (a * d - b * c) / (den * den)
    drive = (da * prev + db) / den - num * (dc * prev + dd) / (den * den)
    drive = drive.at[0].add(slope[0] * dp0)
    return p, affine_prefix(slope, drive[:, None])[:, 0]


def readout_scan(theta, readout, x, dt, restart, mask):
    """:func:`whiten_scan` with the angle readout's white noise of a servo record (Hu 5-51: the Inductosyn's
    quantisation and electrical error) beside the rate noise: exact GLS whitening of

        y_k = g_k + w_k + ε_{k+1} − ε_k,

    y_k the interval's mean rate, g the Gauss–Markov rate (σ_g², τ), w the white rate noise (σ_w²) and ε_k = e_k/Δ
    the readout error e_k of the angle read at the interval's start over the sample interval Δ (variance σ_q², the
    residual's unit squared: (deg/h)² when e is in arcsec and Δ in s, since 1 arcsec/s = 1 deg/h). Successive
    increments share a read angle, so the readout alone makes them MA(1) with lag-1 correlation −σ_q²/(σ_w² + 2σ_q²);
    a Gauss–Markov model of the rate would read that as colour.

    ``readout`` = (σ_q², Δ in s): a row more than 1.5 Δ after the previous one reads a fresh angle (the interval
    between them was dropped, e.g. across segments); a restart row starts everything afresh. The filter carries
    (g_k, ε_k) and a 2×2 covariance; ε_{k+1} enters fresh with each row and is the ε of the next (a sequential
    ``lax.scan``). Masked rows pass through unchanged with log S = 0.
    """
    tau, g, w = theta[0], theta[1], theta[2]
    q, step = readout[0], readout[1]
    phi = jnp.where(restart, 0.0, jnp.exp(-jnp.where(restart, 0.0, dt) / tau))
    fresh = restart | (dt > 1.5 * step)

    def one(carry, inp):
        mg, me, pgg, pge, pee = carry
        z, ph, rs, fr, ok = inp
        # predict: the Gauss–Markov rate decays; a restart (φ = 0) or a fresh angle forgets the readout error
        mg_p, pgg_p, pge_p = ph * mg, ph * ph * pgg + g * (1.0 - ph * ph), ph * pge
        me_p = jnp.where(fr, 0.0, me)
        pee_p = jnp.where(fr, q, pee)
        pge_p = jnp.where(fr, 0.0, pge_p)
        # measurement z = g − ε_k + ε_{k+1} + w, ε_{k+1} fresh (variance q)
        hp = pgg_p - pge_p  # Cov(g, z)
        s = pgg_p - 2.0 * pge_p + pee_p + q + w
        nu = z - (mg_p - me_p)
        mg_n = mg_p + (hp / s) * nu
        me_n = (q / s) * nu  # ε_{k+1} given z: the next row's ε_k
        new = (mg_n, me_n, pgg_p - hp * hp / s, -hp * q / s, q - q * q / s)
        out = nu / jnp.sqrt(s)
        keep = (mg, me, pgg, pge, pee)
        carry = tuple(jnp.where(ok, a, b) for a, b in zip(new, keep))
        return carry, (jnp.where(ok, out, z), jnp.where(ok, jnp.log(s), 0.0))

    m = x.shape[1]
    zero = jnp.zeros(m, dtype=x.dtype)
    init = (zero, zero, jnp.asarray(g, dtype=x.dtype), jnp.asarray(0.0, dtype=x.dtype), jnp.asarray(q, dtype=x.dtype))
    _, (out, logs) = jax.lax.scan(one, init, (x, phi, restart, fresh, mask))
    return out, logs


def whiten_scan(theta, x, dt, restart, mask, readout=None):
    """Normalised Kalman innovations of every column of ``x`` (N, m) and log S (N,) under white (σ_w²) + GM (σ_g², τ);
    ``theta`` = (τ s, σ_g², σ_w²) in x's unit squared (exact GLS whitening). A restart row starts an independent
    series (φ = 0); masked rows pass through unchanged with log S = 0.

    Both recursions of the filter are prefix compositions evaluated by two-level scans (about 2√N sequential steps,
    vectorised otherwise; cheap to differentiate in forward mode): the filtered GM variance
    P_k = (φ_k² P_{k−1} + q_k) σ_w² / S_k, S_k = φ_k² P_{k−1} + q_k + σ_w², q_k = σ_g²(1 − φ_k²), is a linear-fractional
    map of P_{k−1}; the filtered state x̂_k = φ_k (σ_w²/S_k) x̂_{k−1} + K_k z_k, K_k = 1 − σ_w²/S_k, an affine one.

    ``readout`` = (σ_q², Δ s): a servo record's angle readout noise as well (:func:`readout_scan`).
    """
    if readout is not None:
        return readout_scan(theta, readout, x, dt, restart, mask)
    tau, g, w = theta[0], theta[1], theta[2]
    # a restart's step (negative where stacked records restart their clocks) must not reach exp: its derivative would
    # overflow there and turn the reverse-mode gradient into NaN through the unselected branch of the where
    phi = jnp.where(restart, 0.0, jnp.exp(-jnp.where(restart, 0.0, dt) / tau))
    f2 = phi * phi
    q = g * (1.0 - f2)
    one, zero = jnp.ones_like(phi), jnp.zeros_like(phi)
    mats = (
        jnp.where(mask, w * f2, one),
        jnp.where(mask, w * q, zero),
        jnp.where(mask, f2, zero),
        jnp.where(mask, q + w, one),
    )
    p0 = jnp.asarray(g, dtype=x.dtype)
    p_post = mobius_prefix(mats, p0)
    p_prev = jnp.concatenate([p0[None], p_post[:-1]])
    pp = f2 * p_prev + q  # predicted GM variance (φ = 0: a fresh, independent start)
    s = pp + w
    coef = jnp.where(mask, phi * w / s, one)
    drive = jnp.where(mask[:, None], (pp / s)[:, None] * x, 0.0)
    filt = affine_prefix(coef, drive)
    prev = jnp.concatenate([jnp.zeros((1, x.shape[1]), dtype=x.dtype), filt[:-1]], axis=0)
    out = jnp.where(mask[:, None], (x - phi[:, None] * prev) / jnp.sqrt(s)[:, None], x)
    return out, jnp.where(mask, jnp.log(s), 0.0)


def gram_scan(theta, x, dt, restart, mask, readout=None):
    """(X̃ᵀX̃ of the whitened columns of ``x`` (m, m), Σ log S) under ``theta`` (and ``readout``, :func:`whiten_scan`)."""
    out, logs = whiten_scan(theta, x, dt, restart, mask, readout)
    return out.T @ out, jnp.sum(logs)


def likelihood_terms(theta, x, dt, restart, mask, readout=None):
    """(Σ log S_k, |ẽ|², log det(X̃ᵀX̃) of the normalised columns, X̃ᵀX̃ (P, P) of the normalised, padded columns),
    dimensionless, under ``theta`` = (τ in s, σ_g², σ_w² in the residual's unit squared); ``dt`` the sample steps in
    s; ``readout`` as :func:`whiten_scan`. The Gram matrix rides along (the likelihood computes it anyway), so that
    :func:`whitened_gram` needs no compiled function of its own."""
    gram, logs = gram_scan(theta, x, dt, restart, mask, readout)
    a, b, rr = gram[1:, 1:], gram[1:, 0], gram[0, 0]
    sc = jnp.sqrt(jnp.diag(a))
    chol = jnp.linalg.cholesky(a / jnp.outer(sc, sc))
    z = jax.scipy.linalg.solve_triangular(chol, b / sc, lower=True)
    quad = rr - z @ z
    logdet = 2.0 * jnp.sum(jnp.log(jnp.diag(chol))) + 2.0 * jnp.sum(jnp.log(sc))
    return logs, quad, logdet, a


def objective(u, x, dt, restart, mask, reml, readout=None):
    """−2 log L (profile, ``reml`` = 0) or −2 log L_R (``reml`` = 1) at u = (log τ, log σ_g², log σ_w²), without
    the 2π terms and the constant of the column scaling (dimensionless; τ in s, ``dt`` in s); ``readout`` the fixed
    (σ_q², Δ) or None (:func:`whiten_scan`)."""
    logs, quad, logdet, _ = likelihood_terms(jnp.exp(u), x, dt, restart, mask, readout)
    return logs + quad + reml * logdet


# compiled, and kept across processes per shape (gyrojax.runtime.kept: a fresh process neither traces nor compiles them)
value_and_grad = Kept("value_and_grad", jax.jit(jax.value_and_grad(objective)))
whiten_jit = Kept("whiten_scan", jax.jit(whiten_scan))
"""The compiled :func:`whiten_scan` (the one Kalman whitening filter, :func:`gyrojax.noise.whiten.kalman_whiten`)."""
likelihood_terms_jit = Kept("likelihood_terms", jax.jit(likelihood_terms))
HESSIAN_STEP = 1e-4
"""Step in u of the central differences of the exact gradient (and of X̃ᵀX̃) that give the curvature: the truncation
error is ~1e-8 relative, and the compiled first-order functions are reused instead of tracing second-order ones
(about a second per shape in every fresh process)."""


# ---- the minimiser ------------------------------------------------------------------------------------------------


def neg2_loglik(s: Series, theta, reml: bool) -> float:
    """−2 log L_R (``reml``) or −2 log L_P of the series under ``theta`` = (τ s, σ_g², σ_w²) (σ_g² may be 0: white)."""
    th = np.asarray(theta, dtype=float)
    logs, quad, logdet, _ = likelihood_terms_jit(th, *s.arrays, s.readout)
    # summed on the host (the same double additions, without dispatching an XLA add of two device scalars)
    return float(logs) + float(quad) + (float(logdet) + s.logdet_const if reml else 0.0)


def _bounds(s: Series):
    lo = np.array([math.log(TAU_FLOOR_STEPS * s.dt0), math.log(s.var0 / VAR_SPAN), math.log(s.var0 / VAR_SPAN)])
    hi = np.array([math.log(s.tau_max), math.log(s.var0 * 1e4), math.log(s.var0 * 1e4)])
    return lo, np.maximum(hi, lo)


def minimise(s: Series, u0, reml: bool, max_iter: int = 80, ftol: float = 1e-10) -> Solution:
    """Minimise −2 log L (REML when ``reml``, without the column-scaling constant) from ``u0`` within the bounds of
    ``s`` (τ ≤ τ_max), by the one minimiser (:func:`gyrojax.optimize.minimize`) on the exact gradient (reverse mode
    through the filter), its curvature started from differences of that gradient at ``u0`` (three evaluations side
    by side; the Hessian's own compiled function is kept for where the curvature itself is the result). Returns the
    :class:`~gyrojax.optimize.Solution` in u = log(τ, σ_g², σ_w²)."""
    lo, hi = _bounds(s)
    arrays = s.arrays
    c = 1.0 if reml else 0.0

    def vg(u):
        return value_and_grad(u, *arrays, c, s.readout)

    u = np.clip(np.asarray(u0, dtype=float), lo, hi)
    f, g = vg(u)
    g = np.asarray(g)
    steps = np.where(u + 1e-3 <= hi, 1e-3, -1e-3)
    grads = parallel_map(lambda k: np.asarray(vg(u + steps[k] * np.eye(3)[k])[1]), range(3))
    curvature = difference_curvature(grads, u, g, steps)
    return minimize(vg, u, lo, hi, curvature, max_iter, ftol, "REML search", first=(f, g))


def grid(s: Series, start, coarse: bool):
    """Starts in u for the search: τ on a geometric grid from 2Δt to τ_max (and the start's τ), each with a few
    splits of the start's total variance, and the start itself."""
    tau0, g0, w0 = start
    total = max(g0 + w0, 1e-300)
    n_tau, fractions = (4, (0.03, 0.2)) if coarse else (6, (0.02, 0.3))
    taus = [min(tau0, s.tau_max)] + list(np.geomspace(max(2 * s.dt0, 1e-9), s.tau_max, n_tau))
    cands = [np.log([t, v * total, (1 - v) * total]) for t in taus for v in fractions]
    cands.append(np.log([min(tau0, s.tau_max), max(g0, 1e-300), max(w0, 1e-300)]))
    return np.array(cands)


def values(s: Series, us, reml: bool) -> np.ndarray:
    """−2 log L (without the column-scaling constant) at each row of ``us`` (k, 3), by the compiled likelihood terms
    (forward only: a quarter of the value-and-gradient's time, and the function :func:`neg2_loglik` compiles for the
    same shapes anyway; faster than a vmapped batch on a CPU). Every point is dispatched before the
    first is read back, so the device never waits for the host between them. ``us`` in the units of
    :func:`neg2_loglik`'s noise parameters."""
    c = 1.0 if reml else 0.0
    arrays = s.arrays

    def one(u):
        logs, quad, logdet, _ = likelihood_terms_jit(np.exp(np.asarray(u, dtype=float)), *arrays, s.readout)
        return float(logs) + float(quad) + c * float(logdet)

    return np.array(parallel_map(one, us))


def fit(s: Series, start, reml: bool = True, coarse: bool = False) -> Solution:
    """Maximum (restricted) likelihood white + Gauss–Markov parameters of a series: :func:`minimise` from the best
    point of :func:`grid` (the likelihood in τ has local minima on short records), which includes
    ``start`` = (τ s, σ_g², σ_w²) (a moment estimate or a previous fit). Returns the search's
    :class:`~gyrojax.optimize.Solution` with ``x`` = (τ, σ_g², σ_w²) and ``value`` −2 log L (with the column-scaling
    constant under REML)."""
    lo, hi = _bounds(s)
    cands = np.clip(grid(s, start, coarse), lo, hi)
    vals = values(s, cands, reml)
    vals = np.where(np.isfinite(vals), vals, np.inf)
    sol = minimise(s, cands[int(np.argmin(vals))], reml)
    return replace(sol, x=np.exp(sol.x), value=sol.value + (s.logdet_const if reml else 0.0))


def reml_hessian(s: Series, theta, step: float = HESSIAN_STEP) -> np.ndarray:
    """Hessian (3, 3) of −2 log L_R in u = log(τ, σ_g², σ_w²) at ``theta`` = (τ s, σ_g², σ_w²): central differences
    of the exact gradient (:data:`HESSIAN_STEP`), symmetrised."""
    u = np.log(np.asarray(theta, dtype=float))
    points = [u + sign * e for e in np.eye(3) * step for sign in (1.0, -1.0)]
    g = parallel_map(lambda v: np.asarray(value_and_grad(v, *s.arrays, 1.0, s.readout)[1]), points)
    h = np.column_stack([(g[2 * k] - g[2 * k + 1]) / (2.0 * step) for k in range(3)])
    return 0.5 * (h + h.T)


def whitened_gram(s: Series, theta, step: float = HESSIAN_STEP):
    """X̃ᵀX̃ (p, p) of the whitened regressors of ``s`` in their own units and its derivatives (p, p, 3) in
    u = log(τ, σ_g², σ_w²) at ``theta`` = (τ s, σ_g², σ_w²) (central differences of the Gram matrix of the compiled
    :func:`likelihood_terms`, :data:`HESSIAN_STEP`)."""
    u = np.log(np.asarray(theta, dtype=float))
    p, d = s.rank, s.norms
    scale = np.outer(d, d)
    points = [u] + [u + sign * e for e in np.eye(3) * step for sign in (1.0, -1.0)]
    g = parallel_map(lambda v: np.asarray(likelihood_terms_jit(np.exp(v), *s.arrays, s.readout)[3])[:p, :p], points)
    a = g[0] * scale
    da = np.stack([(g[1 + 2 * k] - g[2 + 2 * k]) / (2.0 * step) for k in range(3)], axis=-1)
    return a, da * scale[:, :, None]
