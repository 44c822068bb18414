"""The one description of random drift: :class:`NoiseSpec`, in the natural units of IEEE Std 952-1997 annex C.

===================  ==================  ===============================================  ============
field                coefficient, unit   Allan variance σ²(τ), (deg/h)², τ in s           σ(τ) slope
===================  ==================  ===============================================  ============
``quantization``     Q, arcsec           3Q²/τ²             (1 arcsec/s = 1 deg/h)        −1
``white``            N, deg/√h           N²/τ_h = 3600 N²/τ  (angle random walk)           −1/2
``bias_instability`` B, deg/h            (2 ln 2/π) B² = (BI_FACTOR·B)² (flicker floor)    0
``random_walk``      K, deg/h/√h         K²τ_h/3 = K²τ/10800                              +1/2
``rate_ramp``        R, deg/h/h          R²τ_h²/2 = R²τ²/(2·3600²)                        +1
``gauss_markov``     (σ deg/h, T s)…     (2σ²T/τ)[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})]  +1/2 … −1/2
===================  ==================  ===============================================  ============

A spec may also carry an AR(p) colour of its white part (``ar``, the φ of r_t = Σ φ_i r_{t−i} + e_t with the
innovation e_t the white term, Hu 4-110), the sample interval ``dt_s`` its per-sample values refer to, and — when it
is an estimate — the covariance of its parameters (``cov`` over ``cov_names``, natural units), the ``method``
(``"ieee952"``, ``"gmwm"``, ``"avlr"``, ``"reml"``, ``"ar"``) and the optimiser's convergence status
(``converged``, ``reason``). For an accelerometer residual the same fields hold in g instead of deg/h.

The spec of a sampled series (``dt_s`` set) has the exact Allan variance of the sampled processes (twice the Haar
wavelet variances of :mod:`gyrojax.noise.wavelet`); without ``dt_s`` the continuous closed forms above.

Truth files (conventions §8) keep their dict, ``{"white": N, "gauss_markov": [σ, T], "random_walk": K,
"quantization": Q}`` (and ``"bias_instability": [B, τ_min, τ_max]``), read by :meth:`NoiseSpec.from_truth` and
written by :meth:`NoiseSpec.to_truth`. Saved specs use the result protocol (:mod:`gyrojax.protocol`), format tag
:data:`FORMAT`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import protocol
from gyrojax.errors import GyrojaxError, TruthError
from gyrojax.noise import wavelet as wv
from gyrojax.noise.meancov import (
    flicker_poles,
    gm_mean_covariance,
    gm_mean_factor,
    quantization_mean_covariance,
    rw_mean_covariance,
)
from gyrojax.units import SECONDS_PER_HOUR

FORMAT = "gyrojax-noise-model"
VERSION = 1

BI_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""Allan deviation of the flicker floor per unit bias instability B (IEEE 952 C.1: σ_min = 0.664 B); its square is
the Allan variance ratio."""

METHODS = ("given", "ieee952", "gmwm", "avlr", "reml", "ar")
LINEAR = ("quantization", "white", "bias_instability", "random_walk", "rate_ramp")
UNITS = {
    "white": "deg/sqrt(h)",
    "quantization": "arcsec",
    "bias_instability": "deg/h",
    "random_walk": "deg/h/sqrt(h)",
    "rate_ramp": "deg/h/h",
    "sigma": "deg/h",
    "tau": "s",
    "ar": "1",
}
TRUTH_KEYS = ("white", "gauss_markov", "random_walk", "quantization", "bias_instability")


class NoiseModelError(GyrojaxError, ValueError):
    """A noise model that cannot be fitted, read or used as asked."""


def gauss_markov_avar(tau, sigma, t_c):
    """Allan variance ((deg/h)²) of a first-order Gauss–Markov rate of std σ (deg/h), correlation time T (s).

    σ²(τ) = (2σ²T/τ)[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})]: → 2σ²τ/(3T) (random-walk-like) for τ ≪ T,
    → 2σ²T/τ (white) for τ ≫ T, peak 0.3811σ² at τ = 1.8923T. Series form for τ/T < 1e-3 (no cancellation).
    """
    x = np.asarray(tau, float) / t_c
    with np.errstate(all="ignore"):
        big = (2.0 / x) * (1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x))
    small = 2.0 * x / 3.0 - x * x / 2.0 + 7.0 * x**3 / 30.0
    return sigma**2 * np.where(x < 1e-3, small, big)


def term_basis(name: str, tau) -> np.ndarray:
    """σ²(τ) in (deg/h)² of the linear term ``name`` per unit squared coefficient (:data:`UNITS`), ``tau`` in s
    (IEEE 952 C.1, module table)."""
    tau = np.asarray(tau, float)
    if name == "quantization":
        return 3.0 / tau**2
    if name == "white":
        return SECONDS_PER_HOUR / tau
    if name == "bias_instability":
        return np.full_like(tau, BI_FACTOR**2)
    if name == "random_walk":
        return tau / (3.0 * SECONDS_PER_HOUR)
    if name == "rate_ramp":
        return tau**2 / (2.0 * SECONDS_PER_HOUR**2)
    raise NoiseModelError(f"unknown noise term {name!r}; valid: {', '.join(LINEAR)}, gauss_markov")


def _number(v, where: str, error=NoiseModelError) -> float:
    if not protocol.is_finite_number(v) or float(v) < 0:
        raise error(f"{where} must be a finite number >= 0, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class NoiseSpec:
    """Random drift in IEEE 952 units (module table: N deg/√h, Q arcsec, B deg/h, K deg/h/√h, R deg/h/h, σ deg/h and
    T s; ``dt_s`` in s); an estimate also carries its covariance and status."""

    white: float = 0.0
    quantization: float = 0.0
    bias_instability: float = 0.0
    random_walk: float = 0.0
    rate_ramp: float = 0.0
    gauss_markov: tuple = ()
    """((σ deg/h, T s), …)."""
    flicker_band: tuple | None = None
    """(τ_min, τ_max) s of the simulated flicker behind ``bias_instability`` (truth files)."""
    ar: tuple = ()
    """φ_1 … φ_p of an AR(p) colour of the white term (its innovation), per sample of ``dt_s``."""
    ma: tuple = ()
    """θ_1 … θ_q of an ARMA(p, q) colour, x̃_t − Σ φ_i x̃_{t−i} = a_t − Σ θ_j a_{t−j} (Hu 4-122), a_t the white term."""
    dt_s: float | None = None
    method: str = "given"
    cov: tuple = ()
    cov_names: tuple = ()
    converged: bool = True
    reason: str = ""
    info: dict = field(default_factory=dict, compare=True, hash=False)
    """Method-specific figures of the estimate (JSON values: e.g. GMWM's objective, p-value, model selection)."""
    readout_var: float = 0.0
    """σ_q² ((deg/h)² per sample of ``dt_s``) of a servo readout's white angle error over the sample interval, e/Δ,
    which differences into the increments (:func:`gyrojax.noise.reml.readout_scan`); known, not fitted
    (:mod:`gyrojax.noise.readout`); 0: none."""

    def __post_init__(self):
        for k in LINEAR:
            object.__setattr__(self, k, _number(getattr(self, k), f"noise model: {k}"))
        object.__setattr__(self, "readout_var", _number(self.readout_var, "noise model: readout_var"))
        gms = []
        for i, pair in enumerate(self.gauss_markov):
            if len(pair) != 2:
                raise NoiseModelError(f"noise model: gauss_markov[{i}] must be (sigma, tau), got {pair!r}")
            s, t = _number(pair[0], f"noise model: gauss_markov[{i}] sigma"), float(pair[1])
            if not (math.isfinite(t) and t > 0):
                raise NoiseModelError(f"noise model: gauss_markov[{i}] tau must be > 0 s, got {pair[1]!r}")
            gms.append((s, t))
        object.__setattr__(self, "gauss_markov", tuple(gms))
        object.__setattr__(self, "ar", tuple(float(x) for x in self.ar))
        object.__setattr__(self, "ma", tuple(float(x) for x in self.ma))
        if self.flicker_band is not None:
            object.__setattr__(self, "flicker_band", tuple(float(x) for x in self.flicker_band))
        if self.dt_s is not None:
            if not (math.isfinite(float(self.dt_s)) and float(self.dt_s) > 0):
                raise NoiseModelError(f"noise model: dt_s must be > 0, got {self.dt_s!r}")
            object.__setattr__(self, "dt_s", float(self.dt_s))
        if self.method not in METHODS:
            raise NoiseModelError(f"noise model: method must be one of {', '.join(METHODS)}, got {self.method!r}")
        k = len(self.cov_names)
        c = np.asarray(self.cov, float)
        if c.size != k * k:
            raise NoiseModelError(f"noise model: cov is not {k} x {k} (cov_names {list(self.cov_names)})")
        cov = tuple(tuple(float(x) for x in row) for row in c.reshape(k, k))
        object.__setattr__(self, "cov", cov)
        object.__setattr__(self, "cov_names", tuple(str(k) for k in self.cov_names))
        if (self.ar or self.ma) and self.dt_s is None:
            raise NoiseModelError("noise model: an AR/ARMA colour needs the sample interval dt_s")

    # -- names and values
    @property
    def names(self) -> tuple:
        """Names of the nonzero parameters, natural units (``gm1_sigma``, ``gm1_tau``, …, ``ar1`` …)."""
        out = [k for k in LINEAR if getattr(self, k) > 0]
        for i in range(len(self.gauss_markov)):
            out += [f"gm{i + 1}_sigma", f"gm{i + 1}_tau"]
        out += [f"ar{i + 1}" for i in range(len(self.ar))] + [f"ma{i + 1}" for i in range(len(self.ma))]
        return tuple(out)

    def value(self, name: str) -> float:
        """The parameter ``name`` of :attr:`names` (or a zero linear term)."""
        if name in LINEAR:
            return getattr(self, name)
        if name.startswith("gm") and "_" in name:
            i, part = name[2:].split("_")
            return self.gauss_markov[int(i) - 1][0 if part == "sigma" else 1]
        if name.startswith(("ar", "ma")):
            return getattr(self, name[:2])[int(name[2:]) - 1]
        raise NoiseModelError(f"noise model: no parameter {name!r}; it has {', '.join(self.names)}")

    @staticmethod
    def unit(name: str) -> str:
        """The unit of parameter ``name``."""
        return UNITS.get(name, UNITS.get(name.rsplit("_", 1)[-1], UNITS["ar"]))

    def std(self, name: str) -> float:
        """Standard error of parameter ``name`` from :attr:`cov` (inf when pinned at a bound, nan when unknown)."""
        if name not in self.cov_names:
            return float("nan")
        i = self.cov_names.index(name)
        v = self.cov[i][i]
        return math.sqrt(v) if v >= 0 else float("nan")

    def parameters(self) -> dict:
        """{name: {"value", "std", "unit", "ci95"}}: the 95 % interval value·e^{±1.96 s/value} is that of the
        log-parameter (the variances and correlation times are skewed; ``None`` without a finite std)."""
        out = {}
        for k in self.names:
            v, s = self.value(k), self.std(k)
            r = math.exp(1.96 * s / v) if v > 0 and math.isfinite(s) and s / v < 300 else float("inf")
            ci = [v / r, v * r] if math.isfinite(r) else None
            out[k] = {"value": v, "std": s if math.isfinite(s) else None, "unit": self.unit(k), "ci95": ci}
        return out

    @property
    def white_variance(self) -> float:
        """Per-sample variance (60N)²/Δt of the white term ((deg/h)², Δt = ``dt_s``)."""
        return (60.0 * self.white) ** 2 / self._dt("a per-sample variance")

    # -- per-sample read-offs of a fit's noise model (white + one Gauss–Markov, or an AR colour)
    @property
    def gm_variance(self) -> float:
        """σ² of the first Gauss–Markov term ((deg/h)²; 0 without one)."""
        return self.gauss_markov[0][0] ** 2 if self.gauss_markov else 0.0

    @property
    def gm_tau(self) -> float:
        """T (s) of the first Gauss–Markov term (nan without one)."""
        return self.gauss_markov[0][1] if self.gauss_markov else float("nan")

    @property
    def order(self):
        """``"gm"`` for a Gauss–Markov model, else the AR order p (0: white)."""
        return "gm" if self.gauss_markov else len(self.ar)

    @property
    def innovation_std(self) -> float:
        """Innovation std per sample: s of the AR colour (the white term), or for white + GM the steady-state
        innovation std of a unit step, √(σ_w² + σ_g²(1 − e^{−2/T})) (the white-equivalent level)."""
        if not self.gauss_markov:
            return math.sqrt(self.white_variance)
        return math.sqrt(self.white_variance + self.gm_variance * (1 - math.exp(-2.0 / max(self.gm_tau, 1e-300))))

    @property
    def stationary_std(self) -> float:
        """Stationary std per sample: √(σ_g² + σ_w²), or s/√Π(1 − k_i²) of the AR colour (k_i its partial
        autocorrelations by the step-down recursion, Hu 4-110)."""
        if self.gauss_markov:
            return math.sqrt(self.gm_variance + self.white_variance)
        phi, ratio = np.asarray(self.ar, float), 1.0
        for _ in range(len(phi)):  # step-down (reverse Levinson–Durbin)
            k = phi[-1]
            ratio /= 1.0 - k * k
            phi = (phi[:-1] + k * phi[:-1][::-1]) / (1.0 - k * k)
        return math.sqrt(self.white_variance * ratio)

    @property
    def variance_ratio(self) -> float:
        """σ²/s²: how much of the residual variance the colour explains (1 for white)."""
        s = self.innovation_std
        return (self.stationary_std / s) ** 2 if s > 0 else 1.0

    @property
    def is_zero(self) -> bool:
        """No random term at all (a noise-free truth or study)."""
        return not (
            any(getattr(self, k) for k in ("white", "quantization", "bias_instability", "random_walk", "rate_ramp"))
            or any(s for s, _ in self.gauss_markov)
            or self.readout_var
        )

    def _dt(self, what: str) -> float:
        if self.dt_s is None:
            raise NoiseModelError(f"noise model: {what} needs the sample interval dt_s")
        return self.dt_s

    @classmethod
    def from_sample_variances(cls, white_var: float, dt_s: float, gm=(), **kw) -> "NoiseSpec":
        """The spec of a per-sample white variance ``white_var`` at ``dt_s`` s and Gauss–Markov (σ², T) pairs."""
        n = math.sqrt(max(white_var, 0.0) * dt_s) / 60.0
        return cls(white=n, gauss_markov=tuple((math.sqrt(max(v, 0.0)), t) for v, t in gm), dt_s=dt_s, **kw)

    def with_status(self, converged: bool, reason: str = "") -> "NoiseSpec":
        """The same spec with the convergence status of its estimate."""
        return replace(self, converged=bool(converged), reason=str(reason))

    # -- Allan variance
    def term_avar(self, taus_s) -> dict:
        """Each term's own Allan variance ((deg/h)²) at ``taus_s`` (s); Gauss–Markov terms as ``gm1``, ``gm2`` …
        (module doc: sampled when ``dt_s`` is set, continuous otherwise)."""
        if self.ar or self.ma:
            raise NoiseModelError("noise model: the Allan variance of an AR/ARMA colour is not implemented")
        tau = np.asarray(taus_s, float)
        out = {}
        if self.dt_s is None:
            for k in LINEAR:
                if getattr(self, k) > 0:
                    out[k] = getattr(self, k) ** 2 * term_basis(k, tau)
            for i, (s, t) in enumerate(self.gauss_markov):
                out[f"gm{i + 1}"] = gauss_markov_avar(tau, s, t)
            return out
        dt = self.dt_s
        m = tau / dt
        lat = {
            "white": (wv.wv_white, (60.0 * self.white) ** 2 / dt),
            "quantization": (wv.wv_quantization, (self.quantization / dt) ** 2),
            "random_walk": (wv.wv_random_walk, self.random_walk**2 * dt / SECONDS_PER_HOUR),
            "rate_ramp": (wv.wv_drift, (self.rate_ramp * dt / SECONDS_PER_HOUR) ** 2),
        }
        for k in LINEAR:
            if getattr(self, k) > 0:
                if k == "bias_instability":
                    out[k] = self.bias_instability**2 * term_basis(k, tau)
                else:
                    fn, v = lat[k]
                    out[k] = 2.0 * np.asarray(fn(m, v))
        for i, (s, t) in enumerate(self.gauss_markov):
            out[f"gm{i + 1}"] = 2.0 * np.asarray(wv.wv_gauss_markov(m, s * s, dt / t))
        return out

    def avar(self, taus_s) -> np.ndarray:
        """Allan variance of the model, (deg/h)², at ``taus_s`` (s): the sum of :meth:`term_avar`."""
        return sum(self.term_avar(taus_s).values(), np.zeros(np.shape(taus_s)))

    def adev(self, taus_s) -> np.ndarray:
        """Allan deviation of the model, deg/h, at ``taus_s`` (s)."""
        return np.sqrt(self.avar(taus_s))

    def term_adev(self, taus_s) -> dict:
        """Each term's own Allan deviation (deg/h)."""
        return {k: np.sqrt(v) for k, v in self.term_avar(taus_s).items()}

    # -- the mean of a static interval
    def mean_variance(self, span_s):
        """Variance ((deg/h)²) of the mean rate over ``span_s`` seconds (a static position): 3600 N²/T from the
        white term, σ²·2(x − 1 + e^{−x})/x² (x = T/τ) from each Gauss–Markov term (:func:`gm_mean_factor`), 2Q²/T²
        from quantization (the mean rate is the angle error's difference over T, Q² its variance, IEEE 952 C.3).
        Terms with no stationary mean variance (flicker, random walk, ramp, AR) are refused."""
        other = [k for k in ("bias_instability", "random_walk", "rate_ramp") if getattr(self, k)]
        if other or self.ar or self.ma:
            raise NoiseModelError(
                "noise model: the variance of a mean is defined here for white, quantization and Gauss-Markov terms, "
                f"not {', '.join(other + (['ar'] if self.ar else []))}"
            )
        var = (60.0 * self.white) ** 2 / span_s + 2.0 * self.quantization**2 / span_s**2
        for s, t in self.gauss_markov:
            var = var + s * s * gm_mean_factor(span_s / t)
        return var

    def mean_terms(self, where: str = "noise model") -> "NoiseSpec":
        """The spec as the processes :meth:`mean_covariance` and the Monte Carlo simulate: the flicker floor
        (``bias_instability`` over ``flicker_band``) replaced by its Gauss–Markov poles (:func:`flicker_poles`).
        Refuses, naming ``where`` and the term, what has no covariance of means: a rate ramp (a deterministic drift
        R·t, not a random term: model it as ``bias_trend``), an AR/ARMA colour, a flicker floor without its band."""
        if self.rate_ramp:
            raise NoiseModelError(
                f"{where}: rate_ramp (R = {self.rate_ramp:g} deg/h/h) is a deterministic drift R·t, not a covariance "
                "of position means; refit without drift, or fit it as the effect bias_trend"
            )
        if self.ar or self.ma:
            raise NoiseModelError(f"{where}: the covariance of means of an AR/ARMA colour is not implemented")
        gms = tuple(self.gauss_markov)
        if self.bias_instability:
            if self.flicker_band is None:
                raise NoiseModelError(
                    f"{where}: bias_instability needs its flicker_band (tau_min, tau_max s) for a covariance of means"
                )
            gms += flicker_poles(self.bias_instability, self.flicker_band)
        return replace(self, bias_instability=0.0, flicker_band=None, gauss_markov=gms)

    def mean_covariance(self, start_s, span_s, sample_s=None, contiguous: bool = True, where: str = "noise model"):
        """(n, n) covariance ((deg/h)²) of the mean rates over the intervals [start_k, start_k + span_k) (s, time
        order, t = 0 the series' first sample): the full matrix over a plan's time line, differentiable in the
        starts and spans. White 3600N²/T on the diagonal; quantization :func:`quantization_mean_covariance`; each
        Gauss–Markov term :func:`gm_mean_covariance`; random walk :func:`rw_mean_covariance`; the flicker floor
        as its Gauss–Markov poles (:meth:`mean_terms`, which also names what is refused). ``sample_s``: the means
        of point samples every ``sample_s`` s (the simulator's series) instead of continuous averages; white and
        quantization are the same either way. The diagonal of the continuous form is :meth:`mean_variance`."""
        spec = self.mean_terms(where)
        span = jnp.asarray(span_s, jnp.float64)
        cov = jnp.diag((60.0 * spec.white) ** 2 / span)
        if spec.quantization:
            cov = cov + quantization_mean_covariance(span, spec.quantization, contiguous)
        if spec.gauss_markov:  # every term (the flicker's poles too) in one vectorised sum
            s, t = (jnp.asarray(v, jnp.float64) for v in zip(*spec.gauss_markov))
            each = jax.vmap(lambda a, b: gm_mean_covariance(start_s, span, a, b, sample_s))(s, t)
            cov = cov + jnp.sum(each, axis=0)
        if spec.random_walk:
            cov = cov + rw_mean_covariance(start_s, span, spec.random_walk, sample_s)
        return cov

    # -- whitening
    def whitening_theta(self, dt_s: float | None = None) -> tuple:
        """(T s, σ_g², σ_w²) of the Kalman whitening filter (:func:`gyrojax.noise.reml.whiten_scan`): white +
        at most one Gauss–Markov term, σ_w² per sample of ``dt_s`` (default: the spec's own)."""
        extra = [k for k in ("quantization", "bias_instability", "random_walk", "rate_ramp") if getattr(self, k)]
        if len(self.gauss_markov) > 1:
            extra.append(f"{len(self.gauss_markov)} Gauss-Markov processes")
        if extra or self.ar or self.ma:
            raise NoiseModelError(
                "noise model: the whitening filter takes white + one Gauss-Markov process, not "
                f"{', '.join(extra + (['ar'] if self.ar else []))}; refit with gyrojax noise --model white+gm"
            )
        w = (60.0 * self.white) ** 2 / (dt_s or self._dt("a per-sample variance"))
        if not self.gauss_markov:
            return (1.0, 0.0, w)
        s, t = self.gauss_markov[0]
        return (t, s * s, w)

    def whitening_readout(self, step_s: float):
        """(σ_q², Δ s) of the servo readout for :func:`gyrojax.noise.reml.whiten_scan` at sample step ``step_s``, or
        None without one."""
        return (self.readout_var, float(step_s)) if self.readout_var > 0 else None

    # -- truth files (conventions §8)
    @classmethod
    def from_truth(cls, d, where: str = "noise") -> "NoiseSpec":
        """The spec of a truth file's ``noise`` dict; :class:`~gyrojax.errors.TruthError` naming ``where`` and the
        key for an unknown term or a bad value."""
        d = dict(d or {})
        kw: dict = {}
        for k, v in d.items():
            if k not in TRUTH_KEYS:
                raise TruthError(f"{where}: unknown noise term {k!r}; valid: {', '.join(TRUTH_KEYS)}")
            if k == "gauss_markov":
                if not isinstance(v, (list, tuple)) or len(v) != 2:
                    raise TruthError(f"{where}.gauss_markov must be [sigma_deg_per_h, tau_s], got {v!r}")
                s, tau = _float(v[0], f"{where}.gauss_markov"), _float(v[1], f"{where}.gauss_markov")
                if s < 0 or tau <= 0:
                    raise TruthError(f"{where}.gauss_markov needs sigma >= 0 and tau > 0, got {v!r}")
                kw["gauss_markov"] = ((s, tau),)
            elif k == "bias_instability":
                if not isinstance(v, (list, tuple)) or len(v) != 3:
                    raise TruthError(f"{where}.bias_instability must be [B_deg_per_h, tau_min_s, tau_max_s], got {v!r}")
                b, t0, t1 = (_float(x, f"{where}.bias_instability") for x in v)
                if b < 0 or not 0 < t0 <= t1:
                    raise TruthError(f"{where}.bias_instability needs B >= 0 and 0 < tau_min <= tau_max, got {v!r}")
                kw["bias_instability"], kw["flicker_band"] = b, (t0, t1)
            else:
                kw[k] = _number(v, f"{where}.{k}", TruthError)
        return cls(**kw)

    @classmethod
    def simulation_terms(cls, spec: "NoiseSpec") -> "NoiseSpec":
        """The processes of ``spec`` alone (values and sample interval; no covariance, method or fit details): what
        a simulation of it needs."""
        keep = ("white", "quantization", "bias_instability", "random_walk", "rate_ramp", "flicker_band", "ar", "ma")
        return cls(**{k: getattr(spec, k) for k in keep}, gauss_markov=spec.gauss_markov, dt_s=spec.dt_s)

    def to_truth(self) -> dict:
        """The truth file's ``noise`` dict (conventions §8): the terms that are not zero."""
        out = {k: getattr(self, k) for k in ("white", "random_walk", "quantization") if getattr(self, k) > 0}
        if (
            len(self.gauss_markov) > 1
            or self.rate_ramp
            or self.ar
            or self.ma
            or (self.bias_instability and not self.flicker_band)
        ):
            raise NoiseModelError(
                "noise model: a truth file holds white, one Gauss-Markov process, random walk, quantization and a "
                "banded bias instability; refit with e.g. --model white+gm+rw"
            )
        if self.gauss_markov:
            out["gauss_markov"] = list(self.gauss_markov[0])
        if self.bias_instability:
            out["bias_instability"] = [self.bias_instability, *self.flicker_band]
        return out

    # -- files
    def to_json(self) -> dict:
        """The spec as a strict-JSON object tagged :data:`FORMAT` / :data:`VERSION` (infinite variances of pinned
        parameters as ``null``)."""
        body = {f.name: getattr(self, f.name) for f in fields(self)}
        body["gauss_markov"] = [list(p) for p in self.gauss_markov]
        body["cov"] = [list(r) for r in self.cov]
        return protocol.strict({protocol.FORMAT_KEY: FORMAT, protocol.VERSION_KEY: VERSION, **body})

    @classmethod
    def from_json(cls, d, where: str = "noise model") -> "NoiseSpec":
        """The spec of a :meth:`to_json` object; :class:`NoiseModelError` naming ``where`` and the key otherwise."""
        try:
            d = protocol.check(d, FORMAT, VERSION, where)
        except GyrojaxError as e:
            raise NoiseModelError(str(e)) from None
        known = {f.name for f in fields(cls)}
        kw = {k: v for k, v in d.items() if k in known}
        try:
            kw["gauss_markov"] = tuple(tuple(p) for p in kw.get("gauss_markov", ()))
            kw["cov"] = tuple(tuple(math.inf if x is None else x for x in r) for r in kw.get("cov", ()))
            for k in ("ar", "ma", "cov_names"):
                kw[k] = tuple(kw.get(k, ()))
            return cls(**kw)
        except (TypeError, ValueError) as e:
            raise NoiseModelError(f"{where}: {e}") from None

    def save(self, path, force: bool = False):
        """Write the spec to ``path`` (:func:`gyrojax.protocol.save`)."""
        return protocol.save(path, self.to_json(), FORMAT, VERSION, force=force)

    @classmethod
    def load(cls, path) -> "NoiseSpec":
        """Read a spec written by :meth:`save`, or the ``model`` object of ``gyrojax noise --json``."""
        d = protocol.read_json_file(path, NoiseModelError, "a noise model")
        if isinstance(d, dict) and "model" in d and protocol.FORMAT_KEY not in d:
            d = d["model"]
        return cls.from_json(d, where=str(path))


def _float(v, where: str) -> float:
    if not protocol.is_finite_number(v):
        raise TruthError(f"{where} must hold finite numbers, got {v!r}")
    return float(v)


JACOBIAN_STEP = 1e-5
"""Relative step of the central differences of :func:`adev_jacobian` (truncation error ~1e-10 relative)."""


def adev_jacobian(spec: NoiseSpec, taus_s) -> np.ndarray:
    """∂σ_model(τ)/∂(parameters of ``spec.cov_names``), (len(taus), p), deg/h per parameter unit, by central
    differences of relative step :data:`JACOBIAN_STEP` (the Allan variances are smooth in every parameter > 0)."""
    cols = []
    for k in spec.cov_names:
        v = spec.value(k)
        h = JACOBIAN_STEP * abs(v) if v else JACOBIAN_STEP
        cols.append((_with(spec, k, v + h).adev(taus_s) - _with(spec, k, v - h).adev(taus_s)) / (2.0 * h))
    return np.stack(cols, axis=-1) if cols else np.zeros(np.shape(taus_s) + (0,))


def _with(spec: NoiseSpec, name: str, v: float) -> NoiseSpec:
    if name in LINEAR:
        return replace(spec, **{name: v})
    if name.startswith("gm"):
        i, part = name[2:].split("_")
        gm = [list(p) for p in spec.gauss_markov]
        gm[int(i) - 1][0 if part == "sigma" else 1] = v
        return replace(spec, gauss_markov=tuple(tuple(p) for p in gm))
    coef = list(getattr(spec, name[:2]))
    coef[int(name[2:]) - 1] = v
    return replace(spec, **{name[:2]: tuple(coef)})


@dataclass(frozen=True)
class SessionNoise:
    """The noise of a hand session (``imu-triad`` records) in the vocabulary of :class:`NoiseSpec`: each gyro
    channel's sample noise (``channels``, x y z: the long-run variance of a channel's filtered noise as the white
    term at the session's sample interval ``dt_s``), and the random effects between the session's segments —
    ``pose_bias_scatter`` τ_b (deg/h, calibrated: a bias step at each pose), ``move_angle_noise`` τ_m (deg: an angle
    error of each gravity-to-gravity move) and ``bias_walk`` (deg/h per √pose: a bias that walks from pose to pose)."""

    channels: tuple
    pose_bias_scatter: float = 0.0
    move_angle_noise: float = 0.0
    bias_walk: float = 0.0

    @classmethod
    def of_sample_variances(cls, q, dt_s: float, **between) -> "SessionNoise":
        """From each channel's per-sample variance ``q`` ((deg/h)²) at ``dt_s`` s and the components ``between``."""
        return cls(tuple(NoiseSpec.from_sample_variances(float(v), dt_s) for v in q), **between)

    def sample_variances(self, dt_s: float) -> np.ndarray:
        """Each channel's per-sample variance ((deg/h)²) at ``dt_s`` s: (60 N)² / Δt."""
        if len(self.channels) != 3:
            raise NoiseModelError(f"a session's noise has one spec per channel x, y, z, got {len(self.channels)}")
        return np.array([(60.0 * c.white) ** 2 / dt_s for c in self.channels])

    def to_json(self) -> dict:
        """The channels' specs and the components between segments (report units)."""
        return {
            "channels": [c.to_json() for c in self.channels],
            "pose_bias_scatter_deg_per_h": self.pose_bias_scatter,
            "move_angle_noise_deg": self.move_angle_noise,
            "bias_walk_deg_per_h_per_sqrt_pose": self.bias_walk,
        }
