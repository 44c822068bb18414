"""Allan variance analysis of random drift (IEEE Std 952-1997, annex C; NIST SP 1065).

**Overlapping Allan variance.** A rate series y_k (deg/h) sampled every τ0 s integrates to the angle
θ_0 = 0, θ_{k+1} = θ_k + (y_k − ȳ)·τ0 (deg/h·s). For τ = m·τ0 the overlapping estimate is

    σ²(τ) = Σ_{i=0}^{M−1} (θ_{i+2m} − 2θ_{i+m} + θ_i)² / (2 τ² M),    M = n + 1 − 2m,

(NIST SP 1065 eq. 11), O(n) per τ from the cumulative sum; it equals ``allantools.oadev`` on frequency data.

**Confidence intervals.** σ̂²·ν/σ² is approximately χ²(ν) with the equivalent degrees of freedom ν of the
overlapping estimator; ν follows the simple approximations of NIST SP 1065 Table 5 (Lesage–Audoin,
Howe–Allan–Barnes) for the noise type of each τ, identified from the local log-log slope of σ²(τ).

**Noise model**: the IEEE 952 annex C terms of :class:`~gyrojax.noise.spec.NoiseSpec` (its module table).
The fit is a weighted non-negative least squares on the variance scale, weights ν/(2σ⁴) from the χ² law
(iterated with the model's σ² in place of the noisy estimate); terms that never carry a given fraction of
the model, or are not significant, are dropped and the rest refitted. The fit is a
:class:`~gyrojax.noise.spec.NoiseSpec`; its ``term_adev`` gives each term's own Allan curve (the GMWM-style view).

Command line: ``gyrojax noise RECORD... [--json] [--plot PNG]`` on static records (their rate series by
:func:`gyrojax.data.static.static_rate_segments`); this module works on arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize

from gyrojax import tails
from gyrojax.errors import GyrojaxError
from gyrojax.noise.spec import LINEAR, UNITS, NoiseSpec, gauss_markov_avar, term_basis
from gyrojax.optimize import minimize_scalar

ONE_SIGMA = math.erf(1.0 / math.sqrt(2.0))
"""Confidence level of ±1σ (0.6827)."""

TERMS = LINEAR
"""The IEEE 952 terms fitted by :func:`fit_noise_model` (:data:`gyrojax.noise.spec.LINEAR`)."""


TERM_ALPHA = {"quantization": 2, "white": 0, "bias_instability": -1, "random_walk": -2, "rate_ramp": -2}
"""Rate-PSD exponent α of each term (S ∝ f^α; quantisation is white angle noise)."""


class AllanError(GyrojaxError, ValueError):
    """Bad input to the Allan analysis (too few samples, non-uniform sampling, moving table, ...)."""


# ---- overlapping Allan variance ---------------------------------------------------------------------------------


def angle_series(rate, tau0):
    """θ_0 = 0, θ_{k+1} = θ_k + (y_k − ȳ)τ0: the integrated rate (deg/h·s), length n + 1 (mean removed).

    numpy in, numpy out (one sequential cumulative sum, as allantools); JAX arrays or tracers in, JAX out."""
    if isinstance(rate, np.ndarray) and not _traced(tau0):
        out = np.empty(rate.shape[0] + 1)
        out[0] = 0.0
        step = np.asarray(rate, dtype=np.float64) - np.mean(rate)
        step *= tau0
        np.cumsum(step, out=out[1:])
        return out
    rate = jnp.asarray(rate, dtype=jnp.float64)
    return jnp.concatenate([jnp.zeros(1), jnp.cumsum((rate - jnp.mean(rate)) * tau0)])


def _traced(*xs) -> bool:
    return any(isinstance(x, jax.core.Tracer) for x in xs)


@jax.jit
def _second_difference_sums(theta, ms):
    """For each m: (Σ_i (θ_{i+2m} − 2θ_{i+m} + θ_i)², M = max(len(θ) − 2m, 0)); fixed shapes, O(n) per m."""
    n1 = theta.shape[0]
    idx = jnp.arange(n1)

    def one(m):
        count = jnp.maximum(n1 - 2 * m, 0)
        valid = idx < count
        d = theta[jnp.minimum(idx + 2 * m, n1 - 1)] - 2.0 * theta[jnp.minimum(idx + m, n1 - 1)] + theta
        return jnp.sum(jnp.where(valid, d * d, 0.0)), count

    return jax.lax.map(one, ms)


def second_difference_sums(theta: np.ndarray, ms) -> tuple[np.ndarray, np.ndarray]:
    """numpy twin of the compiled sums: for each m, Σ_{i<M} (θ_{i+2m} − 2θ_{i+m} + θ_i)² and M = max(len(θ) − 2m, 0).

    Three in-place passes over one reused buffer and a pairwise sum per m (no allocation per m, no BLAS threads):
    the host path of :func:`overlapping_avar` for concrete arrays.
    """
    theta = np.asarray(theta, dtype=np.float64)
    ms = np.asarray(ms, dtype=np.int64)
    n1 = theta.shape[0]
    sums = np.zeros(len(ms))
    counts = np.maximum(n1 - 2 * ms, 0)
    buf = np.empty(int(counts.max(initial=0)))
    for k, m in enumerate(ms.tolist()):
        count = n1 - 2 * m
        if count <= 0:
            continue
        d = buf[:count]
        np.subtract(theta[2 * m :], theta[m : n1 - m], out=d)  # θ_{i+2m} − θ_{i+m}
        d -= theta[m : n1 - m]
        d += theta[:count]
        np.square(d, out=d)
        sums[k] = d.sum()
    return sums, counts


def overlapping_avar(rate, tau0, m_list):
    """Overlapping Allan variance ((deg/h)²) and the number of second differences M at τ = m·τ0.

    ``rate`` (n,) deg/h; ``tau0`` s; ``m_list`` integers ≥ 1 (M = n + 1 − 2m must be ≥ 1). A numpy ``rate``
    runs on the host (:func:`second_difference_sums`, numpy results); a JAX array or a tracer (inside ``jax.jit``)
    runs the compiled loop (JAX results). Both agree to rounding (~1e-15 relative).
    """
    if isinstance(rate, np.ndarray) and not _traced(tau0, m_list):
        ms = np.asarray(m_list, dtype=np.int64).reshape(-1)
        s, count = second_difference_sums(angle_series(rate, tau0), ms)
        tau = ms * tau0
        return s / (2.0 * tau * tau * np.maximum(count, 1)), count
    ms = jnp.asarray(m_list, dtype=jnp.int64)
    s, count = _second_difference_sums(angle_series(rate, tau0), ms)
    tau = ms * tau0
    return s / (2.0 * tau * tau * jnp.maximum(count, 1)), count


def overlapping_adev(rate, tau0, m_list):
    """Overlapping Allan deviation (deg/h) of a rate series (deg/h) sampled at ``tau0`` s, at τ = m·τ0."""
    avar, _ = overlapping_avar(rate, tau0, m_list)
    return np.sqrt(avar) if isinstance(avar, np.ndarray) else jnp.sqrt(avar)


def default_m_list(n: int, per_decade: int = 10, max_fraction: float = 1.0 / 3.0) -> np.ndarray:
    """Log-spaced averaging factors 1 ≤ m ≤ n·max_fraction, ``per_decade`` per decade, unique integers."""
    m_max = max(1, int(n * max_fraction))
    k = int(math.floor(per_decade * math.log10(m_max))) + 1
    return np.unique(np.round(np.logspace(0, math.log10(m_max), max(k, 1))).astype(np.int64))


# ---- equivalent degrees of freedom and confidence intervals -----------------------------------------------------

ALPHA_OF_SLOPE = {-2: 2, -1: 0, 0: -1, 1: -2, 2: -2}
"""Power-law exponent α of the rate PSD (S ∝ f^α) for each integer slope μ of σ²(τ) ∝ τ^μ (μ = −α − 1 for
α ≤ 1; quantisation is white angle noise, α = 2; a rate ramp takes the random-walk formula)."""


def edf_simple(n_phase, m, alpha):
    """Equivalent degrees of freedom of the overlapping Allan variance (NIST SP 1065 Table 5).

    ``n_phase`` angle samples (n + 1 for n rates), averaging factor ``m``, noise exponent ``alpha`` ∈ {2, 1, 0,
    −1, −2}. Elementwise over numpy arrays.
    """
    N = np.asarray(n_phase, dtype=float)
    m = np.asarray(m, dtype=float)
    alpha = np.asarray(alpha)
    N, m, alpha = np.broadcast_arrays(N, m, alpha)
    with np.errstate(all="ignore"):
        wpm = (N + 1) * (N - 2 * m) / (2 * (N - m))
        fpm = np.exp(np.sqrt(np.log((N - 1) / (2 * m)) * np.log((2 * m + 1) * (N - 1) / 4)))
        wfm = (3 * (N - 1) / (2 * m) - 2 * (N - 2) / N) * (4 * m * m / (4 * m * m + 5))
        ffm = np.where(m == 1, 2 * (N - 2) / (2.3 * N - 4.9), 5 * N * N / (4 * m * (N + 3 * m)))
        rwfm = (N - 2) / m * ((N - 1) ** 2 - 3 * m * (N - 1) + 4 * m * m) / (N - 3) ** 2
    out = np.select([alpha == 2, alpha == 1, alpha == 0, alpha == -1, alpha == -2], [wpm, fpm, wfm, ffm, rwfm], N - 1)
    return out


def local_slope(taus, avar, half_width_decades: float = 0.4) -> np.ndarray:
    """Slope d ln σ² / d ln τ (dimensionless) at each τ, by a straight-line fit over ±``half_width_decades``.

    ``taus`` in s, ``avar`` in any units (the slope does not depend on them).
    """
    lt, lv = np.log10(taus), np.log10(np.maximum(avar, 1e-300))
    out = np.zeros(len(lt))
    for i in range(len(lt)):
        sel = np.abs(lt - lt[i]) <= half_width_decades
        if sel.sum() < 2:
            sel = np.argsort(np.abs(lt - lt[i]))[:2]
        x, y = lt[sel], lv[sel]
        out[i] = np.polyfit(x, y, 1)[0] if np.ptp(x) > 0 else 0.0
    return out


def noise_alpha(taus, avar) -> np.ndarray:
    """Dominant power-law noise exponent α at each τ, from the rounded local slope μ of σ²(τ), μ ≥ −1.

    Slopes below −1 (quantisation) are taken as white rate noise (α = 0): a random dip of σ² at a long τ must
    not be read as white angle noise, whose EDF does not fall with m (the white-rate EDF is the conservative
    choice there). :func:`analyze` refines α from the fitted model.
    """
    mu = np.clip(np.round(local_slope(taus, avar)), -1, 2).astype(int)
    return np.array([ALPHA_OF_SLOPE[int(u)] for u in mu])


def confidence_interval(adev, edf, ci: float = ONE_SIGMA):
    """Chi-square interval of an Allan deviation with ``edf`` degrees of freedom (NIST SP 1065 eq. 45).

    σ²_low = ν σ̂² / χ²_{(1+ci)/2}(ν),  σ²_high = ν σ̂² / χ²_{(1−ci)/2}(ν); returns (low, high) deviations.
    """
    adev, edf = np.asarray(adev, float), np.maximum(np.asarray(edf, float), 1e-3)
    lo_q, hi_q = (1.0 - ci) / 2.0, (1.0 + ci) / 2.0
    low = adev * np.sqrt(edf / tails.chi2_ppf(hi_q, edf))
    high = adev * np.sqrt(edf / tails.chi2_ppf(lo_q, edf))
    return low, high


@dataclass
class AllanResult:
    """Overlapping Allan deviation with its confidence interval (deviations in deg/h, τ in s).

    ``m`` averaging factors, ``count`` second differences used, ``lengths`` the samples of each pooled segment,
    ``alpha`` the noise exponent assumed for the EDF at each τ.
    """

    taus_s: np.ndarray
    adev: np.ndarray
    low: np.ndarray
    high: np.ndarray
    edf: np.ndarray
    alpha: np.ndarray
    m: np.ndarray
    count: np.ndarray
    lengths: tuple
    ci: float = ONE_SIGMA

    @property
    def avar(self) -> np.ndarray:
        """Allan variance σ²(τ), (deg/h)²."""
        return self.adev**2

    def with_alpha(self, alpha) -> "AllanResult":
        """The same estimate with the degrees of freedom and intervals recomputed for noise exponents ``alpha``."""
        alpha = np.broadcast_to(np.asarray(alpha, dtype=int), self.taus_s.shape).copy()
        edf = pooled_edf(self.lengths, self.m, alpha)
        low, high = confidence_interval(self.adev, edf, self.ci)
        return replace(self, low=low, high=high, edf=edf, alpha=alpha)


def pooled_edf(lengths, m, alpha) -> np.ndarray:
    """EDF of the pooled estimate: the sum over segments (n samples each, long enough for m) of the Table 5
    values; at least 1."""
    m = np.asarray(m)
    edf = np.zeros(len(m))
    for n in lengths:
        ok = 2 * m <= n - 1
        edf[ok] += edf_simple(n + 1, m[ok], np.asarray(alpha)[ok])
    return np.maximum(edf, 1.0)


def allan(segments, tau0: float, m_list=None, ci: float = ONE_SIGMA, alpha=None) -> AllanResult:
    """Overlapping Allan deviation of one rate series or of several independent ones (deg/h, sampled at τ0 s).

    Several segments (e.g. records, or the continuous pieces of one record) are pooled: σ²(τ) = Σ_j S_j /
    (2τ² Σ_j M_j) over the segments long enough for that τ, and their degrees of freedom add. ``alpha``: the
    noise exponent of each τ for the EDF (default: identified from the local slope, :func:`noise_alpha`).
    """
    if isinstance(segments, (np.ndarray, jnp.ndarray)) and np.ndim(segments) == 1:
        segments = [segments]
    segments = [np.asarray(s, dtype=float) for s in segments]
    if not segments or tau0 <= 0 or not np.isfinite(tau0):
        raise AllanError(f"need at least one rate series and tau0 > 0 (got {len(segments)} series, tau0={tau0})")
    for j, s in enumerate(segments):
        if s.ndim != 1 or not np.all(np.isfinite(s)):
            raise AllanError(f"rate series {j} must be a finite 1-D array")
    n_max = max(len(s) for s in segments)
    if n_max < 4:
        raise AllanError(f"need at least 4 samples for an Allan deviation, got {n_max}")
    m = default_m_list(n_max) if m_list is None else np.unique(np.asarray(m_list, dtype=np.int64))
    if m.size == 0 or m.min() < 1:
        raise AllanError("averaging factors m must be integers >= 1")
    m = m[2 * m <= n_max - 1]
    if m.size == 0:
        raise AllanError(f"no averaging factor fits in {n_max} samples (need 2m <= n - 1)")
    sums = np.zeros(len(m))
    counts = np.zeros(len(m))
    for s in segments:
        ok = 2 * m <= len(s) - 1
        if not ok.any():
            continue
        avar_j, c_j = overlapping_avar(s, tau0, m[ok])
        c_j = np.asarray(c_j, dtype=float)
        sums[ok] += np.asarray(avar_j) * 2.0 * (m[ok] * tau0) ** 2 * c_j
        counts[ok] += c_j
    taus = m * tau0
    avar = sums / (2.0 * taus**2 * counts)
    level = max(float(np.max(np.abs(s))) for s in segments)
    if not np.sqrt(np.max(avar)) > 1e-12 * level:
        raise AllanError("the Allan variance is zero at every tau (to rounding): the rate series is constant")
    adev = np.sqrt(avar)
    out = AllanResult(
        taus, adev, adev, adev, np.ones(len(m)), np.zeros(len(m), int), m, counts, tuple(len(s) for s in segments), ci
    )
    return out.with_alpha(noise_alpha(taus, avar) if alpha is None else alpha)


# ---- noise model ------------------------------------------------------------------------------------------------


def dominant_alpha(spec: NoiseSpec, taus) -> np.ndarray:
    """Noise exponent α of the term that carries most of the model σ² of ``spec`` at each τ (s), for the EDF."""
    curves = spec.term_avar(taus)
    if not curves:
        return np.zeros(np.shape(taus), int)
    names = list(curves)
    dom = np.argmax(np.stack([curves[k] for k in names]), axis=0)
    out = np.zeros(np.shape(taus), int)
    for i, k in enumerate(names):
        if k.startswith("gm"):
            mu = np.clip(np.round(local_slope(taus, curves[k])), -1, 2).astype(int)
            a = np.array([ALPHA_OF_SLOPE[int(u)] for u in mu])
        else:
            a = TERM_ALPHA[k]
        out = np.where(dom == i, a, out)
    return out


def terms_json(spec: NoiseSpec) -> dict:
    """The ``terms`` object of ``gyrojax noise --json``: value and unit of each named term (0 if dropped)."""
    out = {
        k: {"value": getattr(spec, k), "unit": UNITS[k]}
        for k in ("white", "bias_instability", "random_walk", "quantization")
    }
    gm = list(spec.gauss_markov[0]) if spec.gauss_markov else None
    out["gauss_markov"] = {"value": gm, "unit": [UNITS["sigma"], UNITS["tau"]]}
    return out


def _wnnls(basis, avar, edf, n_iter=6):
    """Weighted NNLS of σ² on the columns of ``basis`` with weights ν/(2 σ_model⁴), iterated; (coef, cov, sse)."""
    scale = np.linalg.norm(basis, axis=0)
    scale[scale == 0] = 1.0
    A = basis / scale
    model = avar.copy()
    for _ in range(n_iter):
        w = np.sqrt(edf / 2.0) / np.maximum(model, 1e-3 * np.maximum(avar, avar.max() * 1e-12))
        c, _ = optimize.nnls(A * w[:, None], avar * w)
        new = A @ c
        if np.allclose(new, model, rtol=1e-6):
            break
        model = np.where(new > 0, new, avar)
    Aw = A * w[:, None]
    r = (avar - A @ c) * w
    try:
        cov = np.linalg.pinv(Aw.T @ Aw) / scale[:, None] / scale[None, :]
    except np.linalg.LinAlgError:
        cov = np.full((len(c), len(c)), np.inf)
    return c / scale, cov, float(r @ r)


def fit_noise_model(
    taus, avar, edf, terms=TERMS, gauss_markov: bool = False, min_fraction: float = 0.1, min_snr: float = 3.0
) -> NoiseSpec:
    """Fit the IEEE 952 terms to an Allan variance (weighted NNLS on σ², weights from the EDF).

        ``taus`` in s, ``avar`` in (deg/h)², ``edf`` dimensionless; returns a :class:`NoiseSpec` (``method``
    "ieee952") whose covariance holds the linear terms and the Gauss–Markov σ (T is read off a grid: no standard
    error), and whose status says whether the bounded search for T converged.

        ``terms``: linear terms to try (default all five). ``gauss_markov``: also fit a Gauss–Markov term (σ, T),
        T searched on a log grid over the τ range, then refined. Model selection: the weakest term is dropped
        (and the rest refitted) while some term's share of the model σ² never reaches ``min_fraction`` at any τ,
        or its σ² contribution never rises ``min_snr`` times above the standard error of the estimate,
        σ²_model·√(2/ν), at any τ (so the last few τ, with ν ≈ 1–3, cannot admit a term on their own).
    """
    taus, avar, edf = (np.asarray(a, float) for a in (taus, avar, edf))
    if taus.shape != avar.shape or taus.shape != edf.shape or taus.size < 2:
        raise AllanError("taus, avar and edf must be 1-D arrays of the same length >= 2")
    if not (np.all(np.isfinite(avar)) and np.all(avar >= 0) and np.any(avar > 0) and np.all(edf > 0)):
        raise AllanError("avar must be finite, >= 0 and not all zero; edf must be > 0")
    names = [t for t in terms]
    for t in names:
        if t not in TERMS:
            raise AllanError(f"unknown noise term {t!r}; valid: {', '.join(TERMS)} (and gauss_markov=True)")
    use_gm = bool(gauss_markov)
    gm_grid = np.geomspace(taus.min() / 2.0, taus.max() * 2.0, 24)

    status: list = []  # (converged, message) of the bounded search for T of the last solve (the returned model)

    def solve(names, use_gm):
        status.clear()
        cols = [term_basis(t, taus) for t in names]
        if not use_gm:
            c, cov, sse = _wnnls(np.stack(cols, axis=1), avar, edf)
            return c, cov, sse, None

        def for_t(log_t):
            B = np.stack([*cols, gauss_markov_avar(taus, 1.0, math.exp(log_t))], axis=1)
            return _wnnls(B, avar, edf)

        sses = [for_t(math.log(t))[2] for t in gm_grid]
        k = int(np.argmin(sses))
        lo, hi = math.log(gm_grid[max(k - 1, 0)]), math.log(gm_grid[min(k + 1, len(gm_grid) - 1)])
        res = minimize_scalar(lambda lt: for_t(lt)[2], lo, hi, what="the bounded search for the Gauss–Markov T")
        status.append((res.converged, res.reason))
        t_best = math.exp(float(res.x)) if res.value <= sses[k] else gm_grid[k]
        c, cov, sse = for_t(math.log(t_best))
        return c[:-1], cov, sse, (math.sqrt(max(c[-1], 0.0)), t_best)

    while True:
        c, cov, sse, gm = solve(names, use_gm)
        contrib = [c[i] * term_basis(t, taus) for i, t in enumerate(names)]
        if gm is not None:
            contrib.append(gauss_markov_avar(taus, *gm))
        total = np.maximum(sum(contrib), 1e-300)
        share = [float(np.max(ci / total)) for ci in contrib]
        snr = [float(np.max(ci / (total * np.sqrt(2.0 / edf)))) for ci in contrib]
        weak = [i for i in range(len(contrib)) if share[i] < min_fraction or snr[i] < min_snr]
        if not weak or len(contrib) == 1:
            break
        worst = min(weak, key=lambda i: share[i])
        if worst == len(names):
            use_gm = False
        else:
            names.pop(worst)
    values = {t: math.sqrt(max(c[i], 0.0)) for i, t in enumerate(names)}
    # natural-unit covariance by the delta method: ∂√c/∂c = 1/(2√c); the GM σ likewise from its σ² column
    cov_names = list(names) + (["gm1_sigma"] if gm is not None else [])
    vals = np.array([values[t] for t in names] + ([gm[0]] if gm is not None else []))
    with np.errstate(divide="ignore"):
        d = np.where(vals > 0, 1.0 / (2.0 * vals), np.inf)
    cov_nat = np.where(np.outer(d, d) == np.inf, np.inf, cov[: len(vals), : len(vals)] * np.outer(d, d))
    ok = all(st for st, _ in status)
    reason = "" if ok else status[0][1]
    return NoiseSpec(
        **values,
        gauss_markov=(gm,) if gm is not None else (),
        method="ieee952",
        cov=cov_nat,
        cov_names=cov_names,
        converged=ok,
        reason=reason,
    )


def analyze(segments, tau0: float, m_list=None, gauss_markov: bool = False, **fit_kw):
    """Allan deviation and noise-model fit of rate series (deg/h) at τ0 s: returns (AllanResult, NoiseSpec).

    The fit runs twice: first with the EDF of the slope-identified noise types, then with those of the noise
    type the first fit finds dominant at each τ (the returned intervals use the latter).
    """
    return refine(allan(segments, tau0, m_list), gauss_markov=gauss_markov, **fit_kw)


def refine(res: AllanResult, gauss_markov: bool = False, **fit_kw):
    """The two fits of :func:`analyze` on an Allan deviation already estimated: (AllanResult with the EDF of the
    noise type the first fit finds dominant at each τ, the IEEE 952 term fit with those EDF)."""
    fit = fit_noise_model(res.taus_s, res.avar, res.edf, gauss_markov=gauss_markov, **fit_kw)
    res = res.with_alpha(dominant_alpha(fit, res.taus_s))
    return res, fit_noise_model(res.taus_s, res.avar, res.edf, gauss_markov=gauss_markov, **fit_kw)


# ---- the command line's JSON ------------------------------------------------------------------------------------


def noise_json(res: AllanResult, fit: NoiseSpec) -> dict:
    """The JSON object printed by ``gyrojax noise --json``."""
    return {
        "taus_s": [float(x) for x in res.taus_s],
        "adev_deg_per_h": [float(x) for x in res.adev],
        "adev_low": [float(x) for x in res.low],
        "adev_high": [float(x) for x in res.high],
        "terms": terms_json(fit),
    }
