"""Latent-process noise models fitted by the generalized method of wavelet moments (GMWM).

A rate series (deg/h, sample interval Δt s) is modelled as a sum of independent latent processes with exact Haar
wavelet variance (:mod:`gyrojax.noise.wavelet`): white noise, angle quantization, rate random walk, rate ramp and one or
more first-order Gauss–Markov (AR1) processes — the latter also stand for flicker over a band and for the sensor's
own output filter. The Allan variance of the model is twice its wavelet variance at the same τ.

**Estimation** (Guerrier, Skaloud, Stebler & Victoria-Feser 2013): θ̂ = argmin (ν̂ − ν(θ))ᵀ Ω⁻¹ (ν̂ − ν(θ)) over
the empirical Haar wavelet variances ν̂ at the dyadic scales m = 1, 2, 4, … (m ≤ n/8), with Ω the asymptotic
covariance of ν̂ (:func:`gyrojax.noise.wavelet.wv_covariance`) evaluated under the model (two-step efficient GMM: a
first fit with diagonal weights, then Ω(θ̂), refit, Ω(θ̂) again, refit). θ are the logarithms of the latent
parameters (variances, AR1 rate a = Δt/T), so every parameter stays positive; the minimisation is
Levenberg–Marquardt in JAX with the exact Jacobian (``jax.jacfwd``), started from a weighted NNLS of the
variances on a grid of correlation times (the model is linear in the variances once the T are fixed).

**Uncertainty.** Cov(θ̂) = (DᵀΩ⁻¹D)⁻¹, D = ∂ν/∂θ at θ̂ (efficient GMM); natural parameters (N, K, Q, σ, T, …)
by the delta method. The quadratic form Q(θ̂) is asymptotically χ²(J − p) under the model (Hansen's J test):
its p-value is the model's adequacy test at the dyadic scales.

**Model selection.** Among candidate sums (default :data:`DEFAULT_CANDIDATES`), the one of least
WIC = Q(θ̂) + 2p, every candidate weighed with the Ω of the largest one — the information criterion of the GMWM
literature (Guerrier et al.'s WIC estimates the optimism by 2·tr(…), which is 2p under efficient weights).

**AVLR** (Allan-variance linear regression, Guerrier et al. 2016) is the same fit with relative least-squares
weights diag(1/ν̂²) instead of Ω⁻¹; its covariance is the sandwich with the model's Ω. The IEEE 952 read-off
stays :func:`gyrojax.noise.allan.fit_noise_model`.

Natural units (IEEE 952 / CONVENTIONS §6): white N deg/√h (per-sample variance (60N)²/Δt), quantization Q arcsec
(rate = Δe/Δt, 1 arcsec/s = 1 deg/h), random walk K deg/h/√h (per-step variance K²Δt/3600), drift R deg/h/h
(per-sample increment RΔt/3600), Gauss–Markov σ deg/h and T s.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import lru_cache, partial

import jax
import jax.numpy as jnp
import numpy as np
from scipy import optimize, stats

from gyrojax.errors import GyrojaxError
from gyrojax.noise import wavelet as wv
from gyrojax.units import SECONDS_PER_HOUR

BI_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""Allan deviation floor per unit bias instability B (IEEE 952 C.1: σ_min = 0.664 B)."""


class NoiseModelError(GyrojaxError, ValueError):
    """A noise model that cannot be fitted, read or used as asked."""


# ---- model specification ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelSpec:
    """Which latent processes a noise model sums: white, quantization, random walk, drift, ``n_gm`` AR1s."""

    white: bool = True
    quantization: bool = False
    random_walk: bool = False
    drift: bool = False
    n_gm: int = 1

    def label(self) -> str:
        """E.g. ``white+2gm+rw``."""
        parts = [k for k, on in (("white", self.white), ("quant", self.quantization)) if on]
        if self.n_gm:
            parts.append("gm" if self.n_gm == 1 else f"{self.n_gm}gm")
        parts += [k for k, on in (("rw", self.random_walk), ("drift", self.drift)) if on]
        return "+".join(parts)

    @classmethod
    def parse(cls, text: str) -> "ModelSpec":
        """``white+gm+rw``, ``white+2gm``, ``quant+white+3gm+rw+drift`` (any order)."""
        kw = {"white": False, "quantization": False, "random_walk": False, "drift": False, "n_gm": 0}
        for tok in (t.strip().lower() for t in text.split("+")):
            if tok == "white":
                kw["white"] = True
            elif tok in ("quant", "quantization"):
                kw["quantization"] = True
            elif tok in ("rw", "random_walk"):
                kw["random_walk"] = True
            elif tok in ("drift", "ramp"):
                kw["drift"] = True
            elif tok.endswith("gm") and (tok[:-2] == "" or tok[:-2].isdigit()):
                kw["n_gm"] += int(tok[:-2] or 1)
            else:
                raise NoiseModelError(
                    f"noise model {text!r}: unknown part {tok!r} (use white, quant, Ngm, rw, drift joined by '+')"
                )
        spec = cls(**kw)
        if spec.n_params == 0:
            raise NoiseModelError(f"noise model {text!r} has no process")
        return spec

    @property
    def names(self) -> tuple:
        """Names of the log-parameters, in the order of θ."""
        out = [k for k, on in (("white", self.white), ("quantization", self.quantization)) if on]
        out += [k for k, on in (("random_walk", self.random_walk), ("drift", self.drift)) if on]
        for i in range(self.n_gm):
            out += [f"gm{i + 1}_var", f"gm{i + 1}_rate"]
        return tuple(out)

    @property
    def n_params(self) -> int:
        """Number of log-parameters θ (two per Gauss–Markov process, one per other process)."""
        return len(self.names)


DEFAULT_CANDIDATES = tuple(
    ModelSpec(white=True, quantization=q, random_walk=rw, n_gm=k)
    for q in (False, True)
    for k in (0, 1, 2, 3)
    for rw in (False, True)
)
"""Candidate sums tried by :func:`select_model`: white, optional quantization, 0–3 AR1s, optional random walk."""


G_MAX = 3
"""Most AR1 processes in one model."""

FULL_NAMES = ("white", "quantization", "random_walk", "drift") + tuple(
    x for i in range(G_MAX) for x in (f"gm{i + 1}_var", f"gm{i + 1}_rate")
)
"""Layout of the full log-parameter vector used by the compiled solver (inactive entries masked)."""


def spec_mask(spec: ModelSpec) -> np.ndarray:
    """Boolean mask of the active entries of the full layout :data:`FULL_NAMES`."""
    if spec.n_gm > G_MAX:
        raise NoiseModelError(f"at most {G_MAX} Gauss-Markov processes, got {spec.n_gm}")
    return np.array(_mask_tuple(spec))


@lru_cache(maxsize=256)
def _mask_tuple(spec: ModelSpec) -> tuple:
    names = spec.names
    return tuple(name in names for name in FULL_NAMES)


def expand(spec: ModelSpec, theta):
    """Full log-parameter vector (zeros where inactive) from the compact θ of ``spec``: numpy for concrete θ (no
    device round trip), JAX under tracing (e.g. inside ``jax.jacfwd``)."""
    mask = spec_mask(spec)
    if isinstance(theta, jax.core.Tracer):
        e = np.eye(len(FULL_NAMES))[:, mask]  # (10, p) selection matrix
        return jnp.asarray(e) @ jnp.asarray(theta, dtype=jnp.float64)
    out = np.zeros(len(FULL_NAMES))
    out[mask] = np.asarray(theta, dtype=np.float64)
    return out


@jax.jit
def _full_adev(theta, mask, m):
    return jnp.sqrt(2.0 * full_wv(theta, mask, m))


_full_adev_jacobian = jax.jit(jax.jacfwd(_full_adev))


@jax.jit
def _full_components(theta, mask, m):
    e = jnp.exp(theta)
    m = jnp.asarray(m, dtype=jnp.float64)
    comps = [
        wv.wv_white(m, e[0]),
        wv.wv_quantization(m, e[1]),
        wv.wv_random_walk(m, e[2]),
        wv.wv_drift(m, e[3]),
    ] + [wv.wv_gauss_markov(m, e[4 + 2 * i], e[5 + 2 * i]) for i in range(G_MAX)]
    gm_on = [mask[4 + 2 * i] for i in range(G_MAX)]
    on = [mask[0], mask[1], mask[2], mask[3], *gm_on]
    return [jnp.where(o, c, 0.0) for o, c in zip(on, comps)]


@jax.jit
def full_wv(theta, mask, m):
    """ν²(m) ((deg/h)²) of the model given by the full log-parameters and the mask (:data:`FULL_NAMES`)."""
    return sum(_full_components(theta, mask, m))


def full_spectrum(theta, mask, f):
    """Per-sample spectrum S(f) of the stochastic part of the model ((deg/h)² per cycle/sample; drift has none)."""
    e = jnp.exp(theta)
    parts = [
        jnp.where(mask[0], wv.spectrum_white(f, e[0]), 0.0),
        jnp.where(mask[1], wv.spectrum_quantization(f, e[1]), 0.0),
        jnp.where(mask[2], wv.spectrum_random_walk(f, e[2]), 0.0),
    ] + [jnp.where(mask[4 + 2 * i], wv.spectrum_gauss_markov(f, e[4 + 2 * i], e[5 + 2 * i]), 0.0) for i in range(G_MAX)]
    return sum(parts)


full_wv_jacobian = jax.jit(jax.jacfwd(full_wv))
"""∂ν²/∂θ (J, 10) of :func:`full_wv`, compiled."""


def component_wv(spec: ModelSpec, theta, m) -> dict:
    """Each process's Haar wavelet variance ((deg/h)²) at half-widths ``m`` (samples); GMs as ``gm1``, ``gm2``…"""
    comps = _full_components(expand(spec, theta), spec_mask(spec), m)
    names = ["white", "quantization", "random_walk", "drift"] + [f"gm{i + 1}" for i in range(G_MAX)]
    on = [spec.white, spec.quantization, spec.random_walk, spec.drift] + [i < spec.n_gm for i in range(G_MAX)]
    return {k: c for k, c, o in zip(names, comps, on) if o}


def model_wv(spec: ModelSpec, theta, m):
    """ν²(m) of the model, (deg/h)²: the sum of :func:`component_wv`."""
    return full_wv(expand(spec, theta), spec_mask(spec), m)


def latent_parameters(spec: ModelSpec, theta):
    """Latent per-sample parameters from the compact log-parameters θ: a dict with ``white`` s², ``quantization``
    q², ``random_walk`` g², ``drift`` w² ((deg/h)², module :mod:`gyrojax.noise.wavelet` table; 1 when the process is
    absent) and ``gm_var`` ((deg/h)²), ``gm_rate`` (a = Δt/T, dimensionless) arrays of the AR1 processes."""
    e = jnp.exp(expand(spec, theta))
    out = {k: e[i] for i, k in enumerate(("white", "quantization", "random_walk", "drift"))}
    out["gm_var"] = e[4::2][: spec.n_gm]
    out["gm_rate"] = e[5::2][: spec.n_gm]
    return out


def natural_names(spec: ModelSpec) -> tuple[tuple, tuple]:
    """Names and units of the natural parameters of ``spec``, in the order of :func:`natural_parameters`."""
    names, units = [], []
    for k, unit in (
        ("white", "deg/sqrt(h)"),
        ("quantization", "arcsec"),
        ("random_walk", "deg/h/sqrt(h)"),
        ("drift", "deg/h/h"),
    ):
        if getattr(spec, k):
            names.append(k)
            units.append(unit)
    for i in range(spec.n_gm):
        names += [f"gm{i + 1}_sigma", f"gm{i + 1}_tau"]
        units += ["deg/h", "s"]
    return tuple(names), tuple(units)


def natural_parameters(spec: ModelSpec, theta, dt):
    """Natural parameters (module table units: deg/√h, arcsec, deg/h/√h, deg/h/h, deg/h and s) as a flat array,
    with their names and units (:func:`natural_names`); ``dt`` the sample interval in s."""
    p = latent_parameters(spec, theta)
    vals = []
    if spec.white:
        vals.append(jnp.sqrt(p["white"] * dt) / 60.0)
    if spec.quantization:
        vals.append(jnp.sqrt(p["quantization"]) * dt)
    if spec.random_walk:
        vals.append(jnp.sqrt(p["random_walk"] * SECONDS_PER_HOUR / dt))
    if spec.drift:
        vals.append(jnp.sqrt(p["drift"]) * SECONDS_PER_HOUR / dt)
    for i in range(spec.n_gm):
        vals += [jnp.sqrt(p["gm_var"][i]), dt / p["gm_rate"][i]]
    return (jnp.stack(vals), *natural_names(spec))


@partial(jax.jit, static_argnums=(0,))
def _natural_and_jacobian(spec, theta, dt):
    fn = lambda th: natural_parameters(spec, th, dt)[0]  # noqa: E731
    return fn(theta), jax.jacfwd(fn)(theta)


def theta_from_natural(spec: ModelSpec, values: dict, dt: float) -> np.ndarray:
    """Log-parameters θ from natural parameters (keys as :func:`natural_parameters` names, in its units), for
    series sampled every ``dt`` s."""
    th = []
    if spec.white:
        th.append(math.log((60.0 * values["white"]) ** 2 / dt))
    if spec.quantization:
        th.append(math.log((values["quantization"] / dt) ** 2))
    if spec.random_walk:
        th.append(math.log(values["random_walk"] ** 2 * dt / SECONDS_PER_HOUR))
    if spec.drift:
        th.append(math.log((values["drift"] * dt / SECONDS_PER_HOUR) ** 2))
    for i in range(spec.n_gm):
        th += [math.log(values[f"gm{i + 1}_sigma"] ** 2), math.log(dt / values[f"gm{i + 1}_tau"])]
    return np.asarray(th)


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
    model). Returns (θ̂, cost). A step is taken only when it lowers the cost; the damping λ falls by 3 after a
    success and rises by 4 after a failure; the loop ends after ``n_iter`` iterations, or when an accepted step
    lowers the cost by less than 1e-12 of it, or when λ exceeds 1e12 (no step lowers it any more).
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
    _, th, c, _, _ = jax.lax.while_loop(more, body, init)
    return th, c


@jax.jit
def model_covariance(theta, mask, m, counts, f, w, factors):
    """Ω(θ): covariance of the Haar wavelet variance estimates under the model (:func:`wavelet.wv_covariance`),
    full log-parameters θ and mask as :func:`levenberg_marquardt`; ``factors`` from :func:`wavelet.gain_factors`."""
    return wv.wv_covariance(m, counts, full_spectrum(theta, mask, f), f, w, factors)


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
    for a in rates:
        cols.append(_gm_column(tuple(m), float(a)))
    return np.stack(cols, axis=1)


@lru_cache(maxsize=4096)
def _gm_column(m: tuple, a: float) -> np.ndarray:
    """ν²(m) of a unit-variance AR1 of rate ``a`` (cached: the starting-value grid repeats across candidates)."""
    mp = _pad(m, padded_length(len(m)), 1.0)
    return np.asarray(wv.wv_gauss_markov(mp, 1.0, a))[: len(m)]


def _nnls(basis, nu_hat, p_mat):
    a = p_mat @ basis
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    c, rn = optimize.nnls(a / scale, p_mat @ nu_hat, maxiter=50 * basis.shape[1])
    return c / scale, rn * rn


def _bounds(spec: ModelSpec, m, nu_hat, n_samples):
    """Box for θ: each variance between 1e-10 and 1e4 times the value that explains ν̂ on its own at its most
    constraining scale; AR1 rates a = Δt/T with T from 0.05 samples to 100·n samples."""
    lo, hi = [], []
    unit = _basis(ModelSpec(white=True, quantization=True, random_walk=True, drift=True, n_gm=0), m, [])
    lin = ("white", "quantization", "random_walk", "drift")
    full = {k: float(np.min(nu_hat / unit[:, i])) for i, k in enumerate(lin)}
    for k in ("white", "quantization", "random_walk", "drift"):
        if getattr(spec, k):
            lo.append(math.log(full[k] * 1e-10))
            hi.append(math.log(full[k] * 1e4))
    gm_full = float(np.max(nu_hat)) / 0.2  # an AR1 peaks at ν² ≈ 0.19 s²
    for _ in range(spec.n_gm):
        lo += [math.log(gm_full * 1e-10), math.log(1.0 / (100.0 * n_samples))]
        hi += [math.log(gm_full * 1e4), math.log(20.0)]
    return np.asarray(lo), np.asarray(hi)


def starting_values(spec: ModelSpec, m, nu_hat, p_mat, n_samples, memo: dict | None = None) -> np.ndarray:
    """θ₀: the AR1 correlation times T (in samples, dimensionless) chosen greedily on a log grid, each new one
    with the earlier ones fixed; the variances ((deg/h)²) by weighted NNLS for those T; a variance the NNLS sets to
    zero starts at 1e-6 of its scale.

    ``memo``: a dict shared by the fits of one model selection; each greedy step is a function of the linear
    processes, the rates already chosen and the data (m, ν̂, P), so candidates that share them reuse it."""
    m = np.asarray(m, float)
    grid = np.geomspace(0.3, 4.0 * m.max(), 28)  # T in samples
    data_key = (m.tobytes(), np.asarray(nu_hat, float).tobytes(), np.asarray(p_mat, float).tobytes())
    rates: list[float] = []
    for _ in range(spec.n_gm):
        key = (data_key, spec.white, spec.quantization, spec.random_walk, spec.drift, tuple(rates))
        if memo is not None and key in memo:
            rates.append(memo[key])
            continue
        best = None
        for t in grid:
            if any(abs(math.log(t * r)) < 0.2 for r in rates):
                continue
            sub = ModelSpec(spec.white, spec.quantization, spec.random_walk, spec.drift, len(rates) + 1)
            c, sse = _nnls(_basis(sub, m, [*rates, 1.0 / t]), nu_hat, p_mat)
            if best is None or sse < best[0]:
                best = (sse, 1.0 / t)
        if memo is not None:
            memo[key] = best[1]
        rates.append(best[1])
    c, _ = _nnls(_basis(spec, m, rates), nu_hat, p_mat)
    lo, hi = _bounds(spec, m, nu_hat, n_samples)
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


@dataclass
class WaveletVariance:
    """Empirical Haar wavelet variance ν̂² ((deg/h)²) at half-widths ``m`` (samples), ``counts`` coefficients,
    of ``n_samples`` samples every ``dt`` s."""

    m: np.ndarray
    nu2: np.ndarray
    counts: np.ndarray
    dt: float
    n_samples: int

    @classmethod
    def of(cls, segments, dt: float, m=None) -> "WaveletVariance":
        """Estimate at the dyadic scales (default, :func:`wavelet.dyadic_m` of the longest segment) or at ``m``."""
        if isinstance(segments, (np.ndarray, jnp.ndarray)) and np.ndim(segments) == 1:
            segments = [segments]
        n = max(len(s) for s in segments)
        if n < 16:
            raise NoiseModelError(f"a GMWM fit needs at least 16 samples, got {n}")
        m = wv.dyadic_m(n) if m is None else np.asarray(m, dtype=np.int64)
        nu2, cnt = wv.haar_wv(segments, m)
        ok = cnt > 0
        return cls(m[ok], nu2[ok], cnt[ok], float(dt), int(sum(len(s) for s in segments)))

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


@dataclass
class NoiseModel:
    """A fitted latent-process noise model: ``spec``, log-parameters ``theta`` and their covariance, for series
    sampled every ``dt`` s; natural parameters with standard errors in :meth:`parameters`."""

    spec: ModelSpec
    theta: np.ndarray
    cov: np.ndarray
    dt: float
    method: str = "gmwm"
    wv: WaveletVariance | None = None
    omega: np.ndarray | None = None
    objective: float = float("nan")
    selection: list = field(default_factory=list)

    # -- values
    @property
    def cov_finite(self) -> np.ndarray:
        """Cov(θ̂) with the rows/columns of parameters pinned at a bound set to 0 (they are held fixed)."""
        return np.where(np.isfinite(self.cov), self.cov, 0.0)

    @property
    def pinned(self) -> list:
        """Names of the log-parameters pinned at a bound of the search box (no standard error)."""
        return [k for k, v in zip(self.spec.names, np.diag(self.cov)) if not np.isfinite(v)]

    def parameters(self) -> dict:
        """{name: {"value", "std", "unit", "ci95"}} of the natural parameters: standard error by the delta method
        from Cov(θ̂), 95 % interval from the normal interval of the log-parameter (better coverage for the skewed
        distributions of variances and correlation times)."""
        vals, jac = (np.asarray(a) for a in _natural_and_jacobian(self.spec, np.asarray(self.theta, float), self.dt))
        inf = ~np.isfinite(np.diag(self.cov))
        cov = self.cov_finite
        std = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, cov, jac), 0.0))
        std[inf] = np.inf  # natural parameter i depends on θ_i (and, for none, on a pinned θ_j, j ≠ i)
        names, units = natural_names(self.spec)
        # 95 % interval from the log-parameter (every natural parameter is a power of e^θ_i): value·e^{±1.96 s/value}
        out = {}
        for k, v, s, u in zip(names, vals, std, units):
            r = math.exp(1.96 * s / v) if v > 0 and np.isfinite(s) and s / v < 300 else float("inf")
            ci = [float(v / r), float(v * r)] if np.isfinite(r) else None
            out[k] = {"value": float(v), "std": float(s) if np.isfinite(s) else None, "unit": u, "ci95": ci}
        return out

    def avar(self, taus_s):
        """Model Allan variance, (deg/h)², at ``taus_s`` (s): 2ν²(τ/Δt)."""
        m = np.asarray(taus_s, float) / self.dt
        mp = _pad(m.ravel(), padded_length(m.size), 1.0)
        out = np.asarray(full_wv(expand(self.spec, self.theta), spec_mask(self.spec), mp))
        return 2.0 * out[: m.size].reshape(m.shape)

    def adev(self, taus_s):
        """Model Allan deviation, deg/h."""
        return np.sqrt(self.avar(taus_s))

    def adev_std(self, taus_s):
        """Standard error of the model Allan deviation at ``taus_s`` (delta method), deg/h."""
        jac = self._adev_jacobian(taus_s)
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, self.cov_finite, jac), 0.0))

    def _adev_jacobian(self, taus_s) -> np.ndarray:
        """∂σ_model(τ)/∂θ, (len(taus), p), compiled once for every model (full layout, masked)."""
        m = np.asarray(taus_s, float).ravel() / self.dt
        mp = _pad(m, padded_length(m.size), 1.0)
        mask = spec_mask(self.spec)
        return np.asarray(_full_adev_jacobian(expand(self.spec, self.theta), mask, mp))[: m.size, mask]

    def term_adev(self, taus_s) -> dict:
        """Each process's own Allan deviation (deg/h) at ``taus_s``."""
        comp = component_wv(self.spec, np.asarray(self.theta, float), np.asarray(taus_s, float) / self.dt)
        return {k: np.sqrt(2.0 * np.asarray(v)) for k, v in comp.items()}

    @property
    def p_value(self) -> float:
        """P-value of the J test: Q(θ̂) against χ²(J − p) (nan without spare scales)."""
        if self.wv is None:
            return float("nan")
        dof = len(self.wv.m) - self.spec.n_params
        return float(stats.chi2.sf(self.objective, dof)) if dof > 0 and self.method == "gmwm" else float("nan")

    # -- derived IEEE 952 figures
    def derived(self, tau_min: float, tau_max: float, slope_tol: float = 0.1) -> dict:
        """ARW, bias instability (flicker floor) and RRW read off the model's ADEV between ``tau_min`` and
        ``tau_max`` s, each with its standard error and the τ where it was read (``None`` with the reason when
        the model has no range of that slope).

        ARW N = σ(τ)√τ/60 at the shortest τ where the log-log slope is within ``slope_tol`` of −½ (a Gauss–Markov
        process far beyond its correlation time is white too, so the shortest such τ is the sensor's ARW);
        RRW K = σ(τ)√(3·3600/τ) where it is closest to +½ (within ``slope_tol``); bias instability
        B = σ_min/0.664 at an interior minimum of σ(τ).
        """
        tt = np.geomspace(tau_min, tau_max, 400)
        lt = np.log(tt)
        ad = self.adev(tt)
        slope = np.gradient(np.log(ad), lt)
        out = {}

        def read(name, idx, factor, unit):
            t = float(tt[idx])
            g = self._adev_jacobian([t])[0] * factor
            out[name] = {
                "value": float(self.adev([t])[0] * factor),
                "std": float(math.sqrt(max(g @ self.cov_finite @ g, 0.0))),
                "unit": unit,
                "tau_s": t,
            }

        near = np.flatnonzero(np.abs(slope + 0.5) <= slope_tol)
        i = int(near[0]) if near.size else int(np.argmin(np.abs(slope + 0.5)))  # the shortest white-like τ
        if abs(slope[i] + 0.5) <= slope_tol:
            read("arw", i, math.sqrt(tt[i]) / 60.0, "deg/sqrt(h)")
        else:
            out["arw"] = {"value": None, "reason": f"no range of slope -1/2 (closest {slope[i]:.2f})"}
        i = int(np.argmin(ad))
        if 0 < i < len(tt) - 1:
            read("bias_instability", i, 1.0 / BI_FACTOR, "deg/h")
        else:
            out["bias_instability"] = {"value": None, "reason": "the model's ADEV has no minimum inside the τ range"}
        i = int(np.argmin(np.abs(slope - 0.5)))
        if abs(slope[i] - 0.5) <= slope_tol:
            read("rrw", i, math.sqrt(3.0 * SECONDS_PER_HOUR / tt[i]), "deg/h/sqrt(h)")
        else:
            out["rrw"] = {"value": None, "reason": f"no range of slope +1/2 (closest {slope[i]:.2f})"}
        return out

    # -- use elsewhere
    def whitening_model(self, dt: float):
        """The :class:`gyrojax.noise.whiten.GMNoise` of this model for series sampled every ``dt`` s (white + one
        Gauss–Markov; a model with random walk, quantization, drift or several AR1s cannot be whitened so)."""
        from gyrojax.noise.whiten import GMNoise

        self._require_white_gm("a GLS fit")
        par = self.parameters()
        white_var = (60.0 * par["white"]["value"]) ** 2 / dt if self.spec.white else 0.0
        if self.spec.n_gm == 0:
            return GMNoise(1.0, 0.0, white_var)
        return GMNoise(par["gm1_tau"]["value"], par["gm1_sigma"]["value"] ** 2, white_var)

    def noise_dict(self) -> dict:
        """The noise dict of :mod:`gyrojax.noise.processes` (truth files, Monte Carlo studies): white, quantization,
        random walk and at most one Gauss–Markov process."""
        if self.spec.n_gm > 1 or self.spec.drift:
            raise NoiseModelError(
                f"noise model {self.spec.label()}: a noise dict holds at most one Gauss-Markov process and no drift; "
                "refit with e.g. --model white+gm+rw"
            )
        par = self.parameters()
        out = {k: par[k]["value"] for k in ("white", "quantization", "random_walk") if k in par}
        if self.spec.n_gm:
            out["gauss_markov"] = (par["gm1_sigma"]["value"], par["gm1_tau"]["value"])
        return out

    def white_gm(self) -> tuple:
        """(ARW N deg/√h, (σ deg/h, T s) or None): the white + one Gauss–Markov description used by
        :class:`gyrojax.planning.optimal.Noise` (the design criteria)."""
        self._require_white_gm("the design criteria")
        par = self.parameters()
        gm = (par["gm1_sigma"]["value"], par["gm1_tau"]["value"]) if self.spec.n_gm else None
        return (par["white"]["value"] if self.spec.white else 0.0), gm

    def _require_white_gm(self, what: str):
        extra = [k for k in ("quantization", "random_walk", "drift") if getattr(self.spec, k)]
        if self.spec.n_gm > 1:
            extra.append(f"{self.spec.n_gm} Gauss-Markov processes")
        if extra:
            raise NoiseModelError(
                f"noise model {self.spec.label()}: {what} takes white + one Gauss-Markov process, not "
                f"{', '.join(extra)}; refit with gyrojax noise --model white+gm"
            )

    # -- JSON
    def to_json(self) -> dict:
        """The ``model`` object of ``gyrojax noise --json`` (readable by :func:`load_noise_model`)."""
        return {
            "method": self.method,
            "spec": self.spec.label(),
            "dt_s": self.dt,
            "parameters": self.parameters(),
            "theta": [float(x) for x in self.theta],
            "theta_cov": [[float(x) for x in row] for row in self.cov_finite],
            "pinned": self.pinned,
            "objective": float(self.objective),
            "dof": (len(self.wv.m) - self.spec.n_params) if self.wv is not None else None,
            "p_value": self.p_value,
            "selection": self.selection,
        }

    @classmethod
    def from_json(cls, d: dict, where: str = "noise model") -> "NoiseModel":
        """The model of a :meth:`to_json` object; :class:`NoiseModelError` naming ``where`` when it is not one."""
        try:
            spec = ModelSpec.parse(d["spec"])
            theta = np.asarray(d["theta"], float)
            cov = np.asarray(d["theta_cov"], float)
            dt = float(d["dt_s"])
        except (KeyError, TypeError, ValueError) as e:
            raise NoiseModelError(f"{where}: not a gyrojax noise model ({type(e).__name__}: {e})") from None
        if theta.shape != (spec.n_params,) or cov.shape != (spec.n_params,) * 2 or not dt > 0:
            raise NoiseModelError(f"{where}: theta/theta_cov do not match the model {spec.label()}")
        if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(cov))):
            raise NoiseModelError(f"{where}: theta and theta_cov must be finite")
        for k in d.get("pinned", []):
            if k in spec.names:
                i = spec.names.index(k)
                cov[i, :] = cov[:, i] = 0.0
                cov[i, i] = np.inf
        return cls(spec, theta, cov, dt, method=str(d.get("method", "gmwm")), objective=float(d.get("objective", 0)))


def load_noise_model(path) -> NoiseModel:
    """Read a noise model from a ``gyrojax noise --json`` output (its ``model`` key) or a bare model object."""
    from pathlib import Path

    p = Path(path)
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise NoiseModelError(f"{p}: no such noise-model file") from None
    except json.JSONDecodeError as e:
        raise NoiseModelError(f"{p}: not JSON ({e.msg} at line {e.lineno})") from None
    if isinstance(d, dict) and "model" in d:
        d = d["model"]
    if not isinstance(d, dict):
        raise NoiseModelError(f"{p}: expected a JSON object with key 'model'")
    return NoiseModel.from_json(d, where=str(p))


GRID_POINTS = 4000
"""Points of the frequency grid of the covariance integrals (400 per decade or more for m ≤ 10⁷)."""


def padded_length(j: int) -> int:
    """Length the arrays of ``j`` scales or taus are padded to: the compiled solver, covariance and Jacobians see a
    few shapes only (32, 64, …), so they compile once for every data length (padding rows carry zero weight)."""
    return max(32, 1 << (int(j) - 1).bit_length())


def _pad(x, length: int, fill: float):
    x = np.asarray(x, float)
    return np.concatenate([x, np.full(length - len(x), fill)])


class _Grid:
    """Frequency grid and Haar gain factors for the covariance Ω at the (padded) half-widths of one estimate."""

    def __init__(self, m):
        jp = padded_length(len(m))
        self.f, self.w = wv.frequency_grid(np.max(m), n_points=GRID_POINTS)
        self.factors = wv.gain_factors(_pad(m, jp, 1.0), self.f)


def covariance_at(spec: ModelSpec, theta, m, counts) -> np.ndarray:
    """Ω (J, J), (deg/h)⁴: covariance of Haar wavelet variance estimates at half-widths ``m`` (samples) with
    ``counts`` coefficients each, under the model ``spec`` with log-parameters ``theta``."""
    j = len(m)
    jp = padded_length(j)
    grid = _Grid(np.asarray(m))
    mp = _pad(m, jp, 1.0)
    cp = _pad(counts, jp, float(np.max(counts)))
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
) -> NoiseModel:
    """Fit one model by GMWM (``method='gmwm'``) or AVLR (``'avlr'``) to the wavelet variance ``est``.

    ``omega``: a fixed weighting covariance (e.g. for model comparison); default: the two-step efficient
    weights Ω(θ̂) (``n_steps`` re-evaluations after a first fit with diagonal weights ν̂⁴·m/M). ``grid`` and
    ``memo`` (:func:`starting_values`) let the fits of one selection share work; neither changes the result.
    """
    theta, p_mat, om, m, lo, hi = _fit_theta(spec, est, omega, method, grid, n_steps, memo)
    j = len(est.m)
    mask = spec_mask(spec)
    idx = np.flatnonzero(mask)
    r = _weighted_residual(spec, theta, est, p_mat, m)
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
    return NoiseModel(spec, theta, cov, est.dt, method, est, om, float(r @ r))


def _weighted_residual(spec: ModelSpec, theta, est: WaveletVariance, p_mat, m_padded) -> np.ndarray:
    """P(ν̂ − ν(θ)) at the J scales of ``est`` (``m_padded`` the padded half-widths of the compiled ν)."""
    return np.asarray(p_mat @ (est.nu2 - np.asarray(model_wv(spec, theta, m_padded))[: len(est.m)]))


def _fit_theta(spec: ModelSpec, est: WaveletVariance, omega, method: str, grid, n_steps: int, memo):
    """The minimisation of :func:`fit_spec`: (θ̂ compact, P, Ω, padded m, lower and upper bounds of θ)."""
    j = len(est.m)
    jp = padded_length(j)
    m = _pad(est.m, jp, 1.0)  # padding: m = 1, ν̂ = 0, zero rows of P (no weight)
    nu = _pad(est.nu2, jp, 0.0)
    counts = _pad(est.counts, jp, float(np.max(est.counts)))
    grid = grid or _Grid(est.m)

    def padp(p):
        out = np.zeros((jp, jp))
        out[:j, :j] = p
        return out

    def omega_at(th):
        return np.asarray(model_covariance(th, mask, m, counts, grid.f, grid.w, grid.factors))[:j, :j]

    lo, hi = _bounds(spec, est.m, est.nu2, est.n_samples)
    if spec.n_params > len(est.m):
        raise NoiseModelError(f"model {spec.label()} has {spec.n_params} parameters for {len(est.m)} scales")
    diag = np.diag(est.nu2**2 * est.m / est.counts)
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
    theta = expand(spec, starting_values(spec, est.m, est.nu2, p_mat, est.n_samples, memo))
    theta, _ = levenberg_marquardt(theta, mask, nu, m, padp(p_mat), lo_f, hi_f)
    om = omega
    if method == "gmwm" and omega is None:
        for _ in range(n_steps):
            om = omega_at(theta)
            p_mat = whitening_matrix(om)
            theta, _ = levenberg_marquardt(theta, mask, nu, m, padp(p_mat), lo_f, hi_f)
    if om is None or method == "avlr":
        om = omega_at(theta)
    return np.asarray(theta)[idx], p_mat, om, m, lo, hi


def select_model(est: WaveletVariance, candidates=DEFAULT_CANDIDATES, method: str = "gmwm") -> NoiseModel:
    """Fit every candidate and return the one of least WIC = Q(θ̂; Ω_ref) + 2p (module doc), refitted with its own
    efficient weights; ``selection`` lists every candidate's criterion. Candidates with more parameters than
    scales are skipped."""
    cands = [c for c in candidates if c.n_params < len(est.m)]
    if not cands:
        raise NoiseModelError(f"{len(est.m)} scales are too few for any candidate model")
    grid = _Grid(est.m)
    memo: dict = {}
    largest = max(cands, key=lambda c: c.n_params)
    ref = fit_spec(largest, est, method="gmwm", grid=grid, memo=memo)
    rows = []
    for c in cands:  # only the criterion of each candidate is needed: no Jacobian, no covariance
        theta, p_mat, _, m, _, _ = _fit_theta(c, est, ref.omega, "gmwm", grid, 2, memo)
        r = _weighted_residual(c, theta, est, p_mat, m)
        objective = float(r @ r)
        rows.append({"model": c.label(), "objective": objective, "wic": objective + 2 * c.n_params})
    best = min(range(len(cands)), key=lambda i: rows[i]["wic"])
    out = fit_spec(cands[best], est, method=method, grid=grid, memo=memo)
    out.selection = rows
    return out


def fit_gmwm(segments, dt: float, model="auto", method: str = "gmwm") -> NoiseModel:
    """GMWM (or AVLR) noise model of rate series (deg/h) sampled every ``dt`` s.

    ``model``: ``"auto"`` (selection by WIC among :data:`DEFAULT_CANDIDATES`), a label such as ``"white+gm+rw"``,
    a :class:`ModelSpec` or a list of them (selection among those).
    """
    return fit_wv(WaveletVariance.of(segments, dt), model, method)


def fit_wv(est: WaveletVariance, model="auto", method: str = "gmwm") -> NoiseModel:
    """:func:`fit_gmwm` on a given wavelet variance (e.g. :meth:`WaveletVariance.from_allan_table`)."""
    if isinstance(model, str) and model != "auto":
        model = ModelSpec.parse(model)
    if isinstance(model, ModelSpec):
        return fit_spec(model, est, method=method)
    return select_model(est, DEFAULT_CANDIDATES if model == "auto" else tuple(model), method=method)


# ---- adequacy --------------------------------------------------------------------------------------------------


def adequacy(taus_s, adev, low, high, model_adev, min_tau_s: float = 0.0, max_half_width: float = 0.15) -> dict:
    """Per-τ check of a model's ADEV against the empirical confidence interval [low, high] (deg/h).

    Returns ``inside`` (per τ), ``ratio`` model/empirical, the τ outside, and the largest |ratio − 1| over the τ
    ≥ ``min_tau_s`` whose interval half-width (relative) is under ``max_half_width`` (the well-measured τ).
    """
    taus_s, adev, low, high, model_adev = (np.asarray(a, float) for a in (taus_s, adev, low, high, model_adev))
    inside = (model_adev >= low) & (model_adev <= high)
    ratio = model_adev / adev
    half = (high - low) / (2.0 * adev)
    good = (taus_s >= min_tau_s) & (half < max_half_width)
    worst = float(np.max(np.abs(ratio[good] - 1.0))) if good.any() else float("nan")
    return {
        "inside": [bool(x) for x in inside],
        "ratio": [float(x) for x in ratio],
        "n_outside": int((~inside).sum()),
        "taus_outside_s": [float(t) for t in taus_s[~inside]],
        "max_rel_deviation_well_measured": worst,
    }


# ---- the report of ``gyrojax noise`` ---------------------------------------------------------------------------

ADEQUACY_CI = 0.95
"""Confidence level of the empirical band the model's ADEV is checked against."""


def noise_report(
    segments, tau0: float, m_list=None, method: str = "gmwm", model: str = "auto", notes=(), gauss_markov: bool = False
):
    """Everything ``gyrojax noise --json`` prints, as a dict, plus the (AllanResult, NoiseFit, NoiseModel).

    The empirical ADEV with ±1σ intervals and the IEEE 952 read-off (:mod:`gyrojax.noise.allan`), the model's
    ADEV at the same τ with its standard error, the per-τ check against the empirical 95 % band
    (:func:`adequacy`, :func:`verdict_line`), the derived ARW / bias instability / RRW and the model itself.

    ``segments`` rate series (deg/h) at ``tau0`` s; ``m_list`` averaging factors (default log-spaced).
    """
    from gyrojax.noise import allan as allan_mod

    res, ieee = allan_mod.analyze(segments, tau0, m_list, gauss_markov=gauss_markov)
    nm = None
    if method in ("gmwm", "avlr"):
        nm = fit_gmwm(segments, tau0, model=model, method=method)
        model_adev = nm.adev(res.taus_s)
        model_std = nm.adev_std(res.taus_s)
    elif method == "ieee952":
        model_adev = ieee.adev(res.taus_s)
        model_std = np.full(len(res.taus_s), np.nan)
    else:
        raise NoiseModelError(f"method must be gmwm, avlr or ieee952, got {method!r}")
    low95, high95 = allan_mod.confidence_interval(res.adev, res.edf, ADEQUACY_CI)
    adq = adequacy(res.taus_s, res.adev, low95, high95, model_adev)
    out = allan_mod.noise_json(res, ieee)
    out["method"] = method
    out["adev_model_deg_per_h"] = [float(x) for x in model_adev]
    out["adev_model_std"] = [None if not np.isfinite(x) else float(x) for x in model_std]
    out["adequacy"] = {"ci": ADEQUACY_CI, "low": [float(x) for x in low95], "high": [float(x) for x in high95], **adq}
    out["adequacy"]["verdict"] = verdict_line(res.taus_s, adq)
    if nm is not None:
        out["derived"] = nm.derived(float(res.taus_s.min()), float(res.taus_s.max()))
        out["model"] = nm.to_json()
    out["notes"] = list(notes)
    return out, res, ieee, nm


def verdict_line(taus_s, adq: dict) -> str:
    """One line: the model inside the empirical band at every τ, or where it is not."""
    n = len(taus_s)
    k = adq["n_outside"]
    if k == 0:
        return f"model inside the empirical {100 * ADEQUACY_CI:.0f} % band at all {n} taus"
    ts = ", ".join(f"{t:.3g}" for t in adq["taus_outside_s"][:6]) + (" ..." if k > 6 else "")
    expected = (1 - ADEQUACY_CI) * n
    tag = "POOR FIT" if k > max(1.0, 2.0 * expected) else "fit"
    return f"{tag}: model outside the empirical {100 * ADEQUACY_CI:.0f} % band at {k} of {n} taus (tau = {ts} s)"
