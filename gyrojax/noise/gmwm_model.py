"""The latent-process models of the GMWM fit (:mod:`gyrojax.noise.gmwm`): which processes a model sums
(:class:`ModelSpec`, the ``--model`` labels such as ``white+gm+rw``), their exact Haar wavelet variance, spectrum and
wavelet-variance covariance as compiled functions of the log-parameters θ, and θ ↔ the natural parameters of
:class:`~gyrojax.noise.spec.NoiseSpec` (:func:`to_noise_spec`).

Natural units (IEEE 952 / conventions §6): white N deg/√h (per-sample variance (60N)²/Δt), quantization Q arcsec
(rate = Δe/Δt, 1 arcsec/s = 1 deg/h), random walk K deg/h/√h (per-step variance K²Δt/3600), drift R deg/h/h
(per-sample increment RΔt/3600), bias instability B deg/h (flicker, below), Gauss–Markov σ deg/h and T s. θ are
the logarithms of the latent per-sample parameters (variances, AR1 rate a = Δt/T), so every parameter stays positive.

**Bias instability (flicker).** IEEE 952 C.1's flicker floor: a flat Allan variance (2 ln 2/π)·B² = (0.664 B)², so
the Haar wavelet variance ν²(m) = b² = (ln 2/π)·B² at every scale (:func:`wv_flicker`; one parameter, B). It is the
continuous-time closed form of a 1/f rate spectrum S(f) = b²/(2 ln 2 |f|) (:func:`spectrum_flicker`, f in cycles per
sample, the spectrum the covariance Ω uses); the sampled 1/f process exceeds it by 19 % at m = 1, 0.9 % at m = 8 and
0.03 % at m = 64 (a (1/m)² approach, tests/test_gmwm_flicker.py), where the white term dominates ν² by orders of
magnitude. It stands for what one Gauss–Markov component cannot follow: a wander whose Allan deviation stays flat
over a decade or more of τ (a sum of Gauss–Markov processes spread over the scales, as the sensor's flicker is).
:class:`~gyrojax.noise.spec.NoiseSpec` carries it as ``bias_instability`` with the same flat Allan variance and,
for simulation, ``flicker_band`` = the τ range fitted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache, partial

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import protocol
from gyrojax.noise import wavelet as wv
from gyrojax.noise.spec import BI_FACTOR, NoiseModelError, NoiseSpec
from gyrojax.units import SECONDS_PER_HOUR


@dataclass(frozen=True)
class ModelSpec:
    """Which latent processes a noise model sums: white, quantization, random walk, drift, ``n_gm`` AR1s."""

    white: bool = True
    quantization: bool = False
    random_walk: bool = False
    drift: bool = False
    n_gm: int = 1
    flicker: bool = False

    def label(self) -> str:
        """E.g. ``white+2gm+rw``, ``white+flicker+rw``."""
        parts = [k for k, on in (("white", self.white), ("quant", self.quantization)) if on]
        if self.n_gm:
            parts.append("gm" if self.n_gm == 1 else f"{self.n_gm}gm")
        parts += [k for k, on in (("flicker", self.flicker), ("rw", self.random_walk), ("drift", self.drift)) if on]
        return "+".join(parts)

    @classmethod
    def parse(cls, text: str) -> "ModelSpec":
        """``white+gm+rw``, ``white+2gm``, ``white+flicker+rw``, ``quant+white+3gm+rw+drift`` (any order)."""
        kw = {"white": False, "quantization": False, "random_walk": False, "drift": False, "n_gm": 0, "flicker": False}
        for tok in (t.strip().lower() for t in text.split("+")):
            if tok == "white":
                kw["white"] = True
            elif tok in ("quant", "quantization"):
                kw["quantization"] = True
            elif tok in ("rw", "random_walk"):
                kw["random_walk"] = True
            elif tok in ("drift", "ramp"):
                kw["drift"] = True
            elif tok in ("flicker", "bi", "bias_instability"):
                kw["flicker"] = True
            elif tok.endswith("gm") and (tok[:-2] == "" or tok[:-2].isdigit()):
                kw["n_gm"] += int(tok[:-2] or 1)
            else:
                raise NoiseModelError(
                    f"noise model {text!r}: unknown part {tok!r} (use white, quant, Ngm, flicker, rw, drift joined by "
                    "'+')"
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
        out += ["bias_instability"] if self.flicker else []
        for i in range(self.n_gm):
            out += [f"gm{i + 1}_var", f"gm{i + 1}_rate"]
        return tuple(out)

    @property
    def n_params(self) -> int:
        """Number of log-parameters θ (two per Gauss–Markov process, one per other process)."""
        return len(self.names)


DEFAULT_CANDIDATES = tuple(
    ModelSpec(white=True, quantization=q, random_walk=rw, n_gm=k, flicker=fl)
    for q in (False, True)
    for fl in (False, True)
    for k in ((0, 1, 2, 3) if not fl else (0, 1, 2))
    for rw in (False, True)
)
"""Candidate sums tried by :func:`select_model`: white, optional quantization, 0–3 AR1s, optional random walk, and
the same with a flicker floor (bias instability) and 0–2 AR1s (a flicker beside three AR1s has more parameters
than a record's flat part can tell apart)."""


G_MAX = 3
"""Most AR1 processes in one model."""

FULL_NAMES = ("white", "quantization", "random_walk", "drift", "bias_instability") + tuple(
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
        e = np.eye(len(FULL_NAMES))[:, mask]  # (11, p) selection matrix
        return jnp.asarray(e) @ jnp.asarray(theta, dtype=jnp.float64)
    out = np.zeros(len(FULL_NAMES))
    out[mask] = np.asarray(theta, dtype=np.float64)
    return out


GM0 = 5
"""Index in :data:`FULL_NAMES` of the first AR1's variance (its rate follows; the next AR1 two places on)."""


def wv_flicker(m, b2):
    """ν² ((deg/h)²) of the flicker floor at half-width ``m`` samples: b² = (ln 2/π)·B² at every scale (module
    doc; IEEE 952 C.1's flat Allan variance (2 ln 2/π)·B², B in deg/h)."""
    return b2 * jnp.ones_like(jnp.asarray(m, dtype=jnp.float64))


def spectrum_flicker(f, b2):
    """S(f) = b²/(2 ln 2 |f|) of the 1/f rate process whose Haar wavelet variance tends to ``b2`` ((deg/h)²) at
    large m, (deg/h)² per cycle/sample, f in cycles/sample (module doc)."""
    return b2 / (2.0 * math.log(2.0) * jnp.abs(f))


@jax.jit
def _full_components(theta, mask, m):
    e = jnp.exp(theta)
    m = jnp.asarray(m, dtype=jnp.float64)
    comps = [
        wv.wv_white(m, e[0]),
        wv.wv_quantization(m, e[1]),
        wv.wv_random_walk(m, e[2]),
        wv.wv_drift(m, e[3]),
        wv_flicker(m, e[4]),
    ] + [wv.wv_gauss_markov(m, e[GM0 + 2 * i], e[GM0 + 1 + 2 * i]) for i in range(G_MAX)]
    gm_on = [mask[GM0 + 2 * i] for i in range(G_MAX)]
    on = [mask[0], mask[1], mask[2], mask[3], mask[4], *gm_on]
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
        jnp.where(mask[4], spectrum_flicker(f, e[4]), 0.0),
    ]
    parts += [
        jnp.where(mask[GM0 + 2 * i], wv.spectrum_gauss_markov(f, e[GM0 + 2 * i], e[GM0 + 1 + 2 * i]), 0.0)
        for i in range(G_MAX)
    ]
    return sum(parts)


full_wv_jacobian = jax.jit(jax.jacfwd(full_wv))
"""∂ν²/∂θ (J, 11) of :func:`full_wv`, compiled."""


def model_wv(spec: ModelSpec, theta, m):
    """ν²(m) of the model, (deg/h)², at half-widths ``m`` (samples): the sum of its processes' wavelet variances."""
    return full_wv(expand(spec, theta), spec_mask(spec), m)


def latent_parameters(spec: ModelSpec, theta):
    """Latent per-sample parameters from the compact log-parameters θ: a dict with ``white`` s², ``quantization``
    q², ``random_walk`` g², ``drift`` w² ((deg/h)², module :mod:`gyrojax.noise.wavelet` table), ``bias_instability``
    b² ((deg/h)², :func:`wv_flicker`; each 1 when the process is absent) and ``gm_var`` ((deg/h)²), ``gm_rate``
    (a = Δt/T, dimensionless) arrays of the AR1 processes."""
    e = jnp.exp(expand(spec, theta))
    out = {k: e[i] for i, k in enumerate(("white", "quantization", "random_walk", "drift", "bias_instability"))}
    out["gm_var"] = e[GM0::2][: spec.n_gm]
    out["gm_rate"] = e[GM0 + 1 :: 2][: spec.n_gm]
    return out


def natural_names(spec: ModelSpec) -> tuple[tuple, tuple]:
    """Names and units of the natural parameters of ``spec``, in the order of :func:`natural_parameters`."""
    names, units = [], []
    for k, unit in (
        ("white", "deg/sqrt(h)"),
        ("quantization", "arcsec"),
        ("random_walk", "deg/h/sqrt(h)"),
        ("drift", "deg/h/h"),
        ("flicker", "deg/h"),
    ):
        if getattr(spec, k):
            names.append("bias_instability" if k == "flicker" else k)
            units.append(unit)
    for i in range(spec.n_gm):
        names += [f"gm{i + 1}_sigma", f"gm{i + 1}_tau"]
        units += ["deg/h", "s"]
    return tuple(names), tuple(units)


def natural_parameters(spec: ModelSpec, theta, dt):
    """Natural parameters (module table units: deg/√h, arcsec, deg/h/√h, deg/h/h, B deg/h, deg/h and s) as a flat array,
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
    if spec.flicker:
        vals.append(jnp.sqrt(2.0 * p["bias_instability"]) / BI_FACTOR)
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
    if spec.flicker:
        th.append(math.log((BI_FACTOR * values["bias_instability"]) ** 2 / 2.0))
    for i in range(spec.n_gm):
        th += [math.log(values[f"gm{i + 1}_sigma"] ** 2), math.log(dt / values[f"gm{i + 1}_tau"])]
    return np.asarray(th)


@jax.jit
def model_covariance(theta, mask, m, counts, f, w, factors):
    """Ω(θ): covariance of the Haar wavelet variance estimates under the model (:func:`wavelet.wv_covariance`),
    full log-parameters θ and mask as :func:`levenberg_marquardt`; ``factors`` from :func:`wavelet.gain_factors`."""
    return wv.wv_covariance(m, counts, full_spectrum(theta, mask, f), f, w, factors)


def padded_length(j: int) -> int:
    """Length the arrays of ``j`` scales or taus are padded to: the compiled solver, covariance and Jacobians see a
    few shapes only (32, 64, …), so they compile once for every data length (padding rows carry zero weight)."""
    return max(32, 1 << (int(j) - 1).bit_length())


def pad(x, length: int, fill: float):
    """``x`` extended to ``length`` with ``fill``."""
    x = np.asarray(x, float)
    return np.concatenate([x, np.full(length - len(x), fill)])


NATURAL_TO_SPEC = {"drift": "rate_ramp"}
"""Natural-parameter names of this module that :class:`NoiseSpec` spells otherwise."""


def to_noise_spec(
    spec: ModelSpec, theta, cov, dt: float, method: str, info: dict, converged=True, reason="", flicker_band=None
):
    """The :class:`NoiseSpec` of log-parameters ``theta`` with covariance ``cov`` (infinite variance: pinned at a
    bound) for series sampled every ``dt`` s; the covariance of the natural parameters by the delta method (each
    natural parameter is a power of one e^θ_i: the Jacobian is diagonal, so pinned entries stay infinite).
    ``flicker_band`` (τ_min, τ_max) s: where the flicker floor of a ``flicker`` model was fitted (kept for
    simulation; default the scales 1 … 10⁶ samples)."""
    vals, jac = (np.asarray(a) for a in _natural_and_jacobian(spec, np.asarray(theta, float), dt))
    names, _ = natural_names(spec)
    g = np.diag(jac)
    cov = np.asarray(cov, float)
    with np.errstate(invalid="ignore"):
        cov_nat = np.where(np.isfinite(cov), cov * np.outer(g, g), np.inf)
    cov_nat[~np.isfinite(cov) & ~np.eye(len(g), dtype=bool)] = 0.0
    nat = dict(zip(names, (float(v) for v in vals)))
    kw = {NATURAL_TO_SPEC.get(k, k): v for k, v in nat.items() if not k.startswith("gm")}
    gm = tuple((nat[f"gm{i + 1}_sigma"], nat[f"gm{i + 1}_tau"]) for i in range(spec.n_gm))
    if spec.flicker and flicker_band is None:
        flicker_band = (dt, 1e6 * dt)
    return NoiseSpec(
        **kw,
        gauss_markov=gm,
        flicker_band=tuple(flicker_band) if spec.flicker else None,
        dt_s=dt,
        method=method,
        cov=cov_nat,
        cov_names=tuple(NATURAL_TO_SPEC.get(k, k) for k in names),
        converged=bool(converged),
        reason=str(reason),
        info=info,
    )


def theta_of(spec: ModelSpec, ns: NoiseSpec) -> np.ndarray:
    """The log-parameters θ of ``spec`` for the natural parameters of ``ns`` (at its ``dt_s``)."""
    inv = {v: k for k, v in NATURAL_TO_SPEC.items()}
    return theta_from_natural(spec, {inv.get(k, k): ns.value(k) for k in ns.names}, ns.dt_s)


def load_noise_model(path) -> NoiseSpec:
    """Read a noise model: a saved :class:`NoiseSpec`, the ``model`` object of ``gyrojax noise --json``, or that
    object as gyrojax 0.2 wrote it (``spec``, ``theta``, ``theta_cov``, ``dt_s``: converted by
    :func:`to_noise_spec`); :class:`NoiseModelError` naming the file and the key otherwise."""
    d = protocol.read_json_file(path, NoiseModelError, "a noise model")
    if isinstance(d, dict) and "model" in d and protocol.FORMAT_KEY not in d:
        d = d["model"]
    if not isinstance(d, dict):
        raise NoiseModelError(f"{path}: expected a JSON object with key 'model'")
    if protocol.FORMAT_KEY in d or "spec" not in d:
        return NoiseSpec.from_json(d, where=str(path))
    return _from_legacy(d, str(path))


def _from_legacy(d: dict, where: str) -> NoiseSpec:
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
    pinned = [k for k in d.get("pinned", []) if k in spec.names]
    for k in pinned:
        i = spec.names.index(k)
        cov[i, :] = cov[:, i] = 0.0
        cov[i, i] = np.inf
    method = str(d.get("method", "gmwm"))
    info = {"model": spec.label(), "objective": d.get("objective"), "dof": d.get("dof"), "p_value": d.get("p_value")}
    info.update(pinned=pinned, selection=list(d.get("selection", [])))
    return to_noise_spec(spec, theta, cov, dt, method, info)
