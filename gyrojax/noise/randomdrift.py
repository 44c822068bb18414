"""Random-drift processing of Hu ch. 4: FFT correlation functions and AR/ARMA time-series models.

**Correlation by FFT** (Hu 4-55 to 4-63). For x_0 … x_{N−1} with the mean removed, the ordinary estimate
r(p) = (1/N) Σ_{j=0}^{N−1−p} x_{j+p} x_j (4-61) is the inverse DFT of |A(k)|² of the sequence zero-padded to
at least 2N points (so the circular sum of 4-55 has nothing to wrap into); without padding the inverse DFT gives
the circular r^c(p) = (1/N) Σ_j x_{(j+p) mod N} x_j (4-55, 4-56), and r^c(p) = r(p) + r(N − p) (4-63).

**Linear stationary models** (Hu 4-102 to 4-126; sign convention of the book):
AR(p)  x̃_t = φ_1 x̃_{t−1} + … + φ_p x̃_{t−p} + a_t               (4-110, 4-111)
ARMA   x̃_t − Σ φ_i x̃_{t−i} = a_t − θ_1 a_{t−1} − … − θ_q a_{t−q} (4-122)
with a_t white of variance σ_a². The book's AR estimation equations are lost from the seed (4-113 to 4-119
are missing, see the digest); AR models here are fitted by the Yule–Walker equations Σ_j φ_j r(|i − j|) = r(i),
i = 1…p, solved for every order at once by the Levinson–Durbin recursion (which also gives the partial
autocorrelations). ARMA models use the Hannan–Rissanen two-stage regression (a long AR gives the innovations,
then x_t is regressed on its own lags and the lagged innovations). Orders are chosen by
AIC = N ln σ̂_a² + 2k or BIC = N ln σ̂_a² + k ln N, k = p + q.

Fitted models are :class:`~gyrojax.noise.spec.NoiseSpec` (``method`` "ar"): ``ar`` = φ, ``ma`` = θ, the white term
the innovation a_t (variance ``white_variance`` per sample), the mean and sample count in ``info``.

An AR(1) with step Δt is a sampled Gauss–Markov process (conventions §6 ``gauss_markov``):
φ = exp(−Δt/T), σ² = σ_a²/(1 − φ²).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.errors import GyrojaxError
from gyrojax.noise.spec import NoiseSpec


class RandomDriftError(GyrojaxError, ValueError):
    """Bad input to the time-series analysis (too short, non-finite, impossible order)."""


def _check(x, min_len=3):
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < min_len or not np.all(np.isfinite(x)):
        raise RandomDriftError(f"need a finite 1-D series of at least {min_len} samples, got shape {x.shape}")
    return x


def _nfft(n: int) -> int:
    return 1 << (2 * n - 1).bit_length()


# ---- correlation functions (Hu 4-55 to 4-63) --------------------------------------------------------------------


def autocovariance(x, max_lag: int | None = None, demean: bool = True):
    """r(p) = (1/N) Σ_{j=0}^{N−1−p} x̃_{j+p} x̃_j for p = 0 … max_lag (default N − 1), by FFT (Hu 4-61).

    Steps of Hu §2: remove the mean, pad with ≥ N zeros, DFT, |A|², inverse DFT, keep the first lags.
    """
    x = _check(x, 2)
    n = x.shape[0]
    max_lag = n - 1 if max_lag is None else int(max_lag)
    if not 0 <= max_lag < n:
        raise RandomDriftError(f"max_lag must be in [0, {n - 1}], got {max_lag}")
    return lagged_sums(x - np.mean(x) if demean else x, max_lag) / n


def lagged_sums(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Σ_{j=0}^{N−1−p} x_{j+p} x_j for p = 0 … max_lag (zero beyond N − 1): the inverse DFT of |A(k)|² of ``x``
    zero-padded to at least 2N points (Hu 4-61, without the 1/N)."""
    n = len(x)
    f = np.fft.rfft(x, _nfft(n))
    ac = np.fft.irfft(f * np.conj(f), _nfft(n))
    out = np.zeros(max_lag + 1)
    k = min(max_lag + 1, n)
    out[:k] = ac[:k]
    return out


def segment_autocovariance_sums(r: np.ndarray, bounds, max_lag: int) -> tuple[np.ndarray, int]:
    """Σ over the segments [s, e) of ``bounds`` of :func:`lagged_sums` of ``r[s:e]`` (lagged products never cross a
    segment; the mean is not removed) and the number of samples."""
    acc = np.zeros(max_lag + 1)
    n_tot = 0
    for s, e in bounds:
        if e > s:
            acc += lagged_sums(np.asarray(r[s:e], float), max_lag)
            n_tot += e - s
    return acc, n_tot


@partial(jax.jit, static_argnums=2)
def _spectrum_corr(x, y, nfft):
    return jnp.fft.irfft(jnp.conj(jnp.fft.rfft(x, nfft)) * jnp.fft.rfft(y, nfft), nfft)


def autocorrelation(x, max_lag: int | None = None):
    """ρ(p) = r(p)/r(0): the normalised autocorrelation function (mean removed)."""
    r = autocovariance(x, max_lag)
    return r / r[0]


def circular_autocovariance(x, demean: bool = True):
    """r^c(p) = (1/N) Σ_j x̃_{(j+p) mod N} x̃_j, p = 0 … N − 1: the inverse DFT of |A(k)|² without padding
    (Hu 4-55, 4-56). Symmetric, r^c(p) = r^c(N − p) (4-60), and r^c(p) = r(p) + r(N − p) (4-63)."""
    x = jnp.asarray(_check(x, 2))
    if demean:
        x = x - jnp.mean(x)
    n = x.shape[0]
    return jnp.fft.irfft(jnp.abs(jnp.fft.rfft(x)) ** 2, n) / n


def cross_covariance(x, y, max_lag: int | None = None, demean: bool = True):
    """r_xy(p) = (1/N) Σ_{j=0}^{N−1−p} x̃_j ỹ_{j+p}, p = 0 … max_lag, by zero-padded FFT (Hu §2, "analogously")."""
    x, y = jnp.asarray(_check(x, 2)), jnp.asarray(_check(y, 2))
    if x.shape != y.shape:
        raise RandomDriftError(f"x and y must have the same length, got {x.shape[0]} and {y.shape[0]}")
    n = x.shape[0]
    max_lag = n - 1 if max_lag is None else int(max_lag)
    if demean:
        x, y = x - jnp.mean(x), y - jnp.mean(y)
    return _spectrum_corr(x, y, _nfft(n))[: max_lag + 1] / n


# ---- AR models: Yule–Walker by Levinson–Durbin -------------------------------------------------------------------


def levinson_durbin(r, order: int):
    """Solve the Yule–Walker equations for orders 1 … ``order`` from autocovariances r(0) … r(order).

    Returns (phis, sigma2, pacf): ``phis[p-1]`` the AR(p) coefficients (length p), ``sigma2[p]`` the innovation
    variance of AR(p) (sigma2[0] = r(0)), ``pacf[p-1]`` the partial autocorrelation φ_pp. The loop runs over
    orders (small), not samples.
    """
    r = np.asarray(r, dtype=float)
    if order < 1 or r.size < order + 1:
        raise RandomDriftError(f"need r(0) … r({order}) for order {order}, got {r.size} values")
    if not r[0] > 0:
        raise RandomDriftError("r(0) must be positive (a constant series has no AR model)")
    phi = np.zeros(0)
    sig = [r[0]]
    phis, pacf = [], []
    for p in range(1, order + 1):
        k = (r[p] - phi @ r[1:p][::-1]) / sig[-1]
        phi = np.concatenate([phi - k * phi[::-1], [k]])
        sig.append(sig[-1] * (1.0 - k * k))
        phis.append(phi.copy())
        pacf.append(k)
    return phis, np.array(sig), np.array(pacf)


def yule_walker_cov(r, p: int, sigma2: float, n: int) -> np.ndarray:
    """Asymptotic covariance σ_a² Γ_p⁻¹ / N of the Yule–Walker AR(p) coefficients (Γ_p the p×p Toeplitz matrix of the
    autocovariances ``r`` r(0) … r(p − 1); Brockwell & Davis §8.1), dimensionless."""
    if p == 0:
        return np.zeros((0, 0))
    r = np.asarray(r, float)
    gam = r[np.abs(np.subtract.outer(np.arange(p), np.arange(p)))]
    return sigma2 * np.linalg.inv(gam) / n


def arma_spec(phi, theta, sigma2: float, mean: float, n: int, dt_s: float = 1.0) -> NoiseSpec:
    """The :class:`NoiseSpec` of x̃_t − Σ φ_i x̃_{t−i} = a_t − Σ θ_j a_{t−j} (Hu 4-122), Var a = ``sigma2`` per sample
    of ``dt_s`` s (the series' unit squared); the mean and the ``n`` samples fitted in ``info``."""
    spec = NoiseSpec.from_sample_variances(sigma2, dt_s, method="ar", info={"mean": float(mean), "n": int(n)})
    return replace(spec, ar=tuple(float(x) for x in phi), ma=tuple(float(x) for x in theta))


def information(m: NoiseSpec, criterion: str = "bic") -> float:
    """AIC = N ln σ̂² + 2k, BIC = N ln σ̂² + k ln N, k = p + q, of an AR/ARMA spec of this module."""
    if criterion not in ("aic", "bic"):
        raise RandomDriftError(f"criterion must be 'aic' or 'bic', got {criterion!r}")
    n = m.info["n"]
    k = len(m.ar) + len(m.ma)
    pen = 2.0 if criterion == "aic" else math.log(n)
    return n * math.log(m.white_variance) + k * pen


def model_autocovariance(m: NoiseSpec, max_lag: int) -> np.ndarray:
    """Theoretical autocovariance λ_0 … λ_max_lag (Hu 4-106) of an AR/ARMA spec from the ψ weights of the model."""
    n_psi = max(2000, 50 * (max_lag + 1))
    psi = np.zeros(n_psi)
    psi[0] = 1.0
    for j in range(1, n_psi):
        acc = -m.ma[j - 1] if j <= len(m.ma) else 0.0
        for i, f in enumerate(m.ar, start=1):
            if j - i >= 0:
                acc += f * psi[j - i]
        psi[j] = acc
    return np.array([m.white_variance * psi[: n_psi - k] @ psi[k:] for k in range(max_lag + 1)])


def fit_ar(x, order: int, dt_s: float = 1.0) -> NoiseSpec:
    """AR(``order``) by Yule–Walker (sample autocovariances by FFT, Levinson–Durbin); ``dt_s`` the sample interval
    the innovation variance refers to."""
    x = _check(x, order + 2)
    if order == 0:
        return arma_spec((), (), float(np.var(x)), float(np.mean(x)), len(x), dt_s)
    r = np.asarray(autocovariance(x, order))
    phis, sig, _ = levinson_durbin(r, order)
    return _yule_walker_spec(r, phis[-1], float(sig[order]), float(np.mean(x)), len(x), dt_s)


def _yule_walker_spec(r, phi, sigma2: float, mean: float, n: int, dt_s: float = 1.0) -> NoiseSpec:
    """:func:`arma_spec` of a Yule–Walker AR(p) with the covariance of its coefficients (:func:`yule_walker_cov`)."""
    spec = arma_spec(phi, (), sigma2, mean, n, dt_s)
    p = len(phi)
    return replace(spec, cov=yule_walker_cov(r, p, sigma2, n), cov_names=tuple(f"ar{i + 1}" for i in range(p)))


def select_ar(x, max_order: int = 10, criterion: str = "bic"):
    """AR model of the order (0 … max_order) that minimises AIC or BIC; returns (model, {order: criterion})."""
    x = _check(x, max_order + 2)
    r = np.asarray(autocovariance(x, max_order))
    phis, sig, _ = levinson_durbin(r, max_order)
    mean = float(np.mean(x))
    models = [arma_spec((), (), float(sig[0]), mean, len(x))]
    models += [_yule_walker_spec(r, phis[p - 1], float(sig[p]), mean, len(x)) for p in range(1, max_order + 1)]
    table = {p: information(m, criterion) for p, m in enumerate(models)}
    return models[min(table, key=table.get)], table


def _lags(v, k, start):
    """Columns v_{t−1} … v_{t−k} for t = start … len(v) − 1."""
    return (
        np.stack([v[start - i : len(v) - i] for i in range(1, k + 1)], axis=1) if k else np.zeros((len(v) - start, 0))
    )


def fit_arma(x, p: int, q: int, long_order: int | None = None) -> NoiseSpec:
    """ARMA(p, q) by Hannan–Rissanen: a long AR(L) gives innovation estimates â_t, then least squares of
    x̃_t on x̃_{t−1…t−p} and −â_{t−1…t−q}. L defaults to max(p + q, ⌈10 log10 N⌉)."""
    x = _check(x, 10 * (p + q + 2))
    if q == 0:
        return fit_ar(x, p)
    xc = x - x.mean()
    n = len(x)
    L = long_order or max(p + q, int(math.ceil(10 * math.log10(n))))
    long = fit_ar(xc, L)
    a = np.zeros(n)
    a[L:] = xc[L:] - _lags(xc, L, L) @ np.asarray(long.ar)
    start = L + max(p, q)
    X = np.concatenate([_lags(xc, p, start), -_lags(a, q, start)], axis=1)
    coef, *_ = np.linalg.lstsq(X, xc[start:], rcond=None)
    resid = xc[start:] - X @ coef
    return arma_spec(coef[:p], coef[p:], float(resid @ resid / len(resid)), float(x.mean()), len(resid))


def select_arma(x, max_p: int = 3, max_q: int = 2, criterion: str = "bic"):
    """ARMA(p, q), 0 ≤ p ≤ max_p, 0 ≤ q ≤ max_q, minimising AIC/BIC over a common sample (the one the
    Hannan–Rissanen regression of the largest orders uses); returns (model, {(p, q): criterion})."""
    x = _check(x, 10 * (max_p + max_q + 2))
    n = len(x)
    L = max(max_p + max_q, int(math.ceil(10 * math.log10(n))))
    table, models = {}, {}
    for p in range(max_p + 1):
        for q in range(max_q + 1):
            m = fit_arma(x, p, q, long_order=L) if q else fit_ar(x, p)
            models[(p, q)] = m
            # the same effective sample size for every candidate, so the criteria compare
            table[(p, q)] = information(replace(m, info={**m.info, "n": n - L - max(max_p, max_q)}), criterion)
    best = min(table, key=table.get)
    return models[best], table


def ar1_to_gauss_markov(phi: float, sigma2: float, dt_s: float) -> tuple[float, float]:
    """(σ, T) of the Gauss–Markov process sampled every ``dt_s`` s as AR(1) (φ, σ_a²): T = −Δt/ln φ,
    σ = √(σ_a²/(1 − φ²)). Units of σ are those of the series (deg/h for drift)."""
    if not 0.0 < phi < 1.0:
        raise RandomDriftError(f"an AR(1) is a Gauss–Markov process only for 0 < phi < 1, got {phi}")
    return math.sqrt(sigma2 / (1.0 - phi * phi)), -dt_s / math.log(phi)
