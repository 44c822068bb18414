"""±2σ coverage of the headline read-offs N, B, K (issue 25), curve and model, on simulated white + random-walk
records: a small version of benchmarks/study_noise_readoff_coverage.py whose tolerances come from the number of
draws (binomial for the coverage, the χ²-law spread of mean z² for the model's σ), so that a σ off by 20 % fails.

Truths: N and K the simulated coefficients; B the IEEE 952 read-off σ_min/0.664 of the exact (sampled) Allan
deviation of the true model over the τ the curve's B read-off uses (headline.B_MAX_HALF_WIDTH)."""

import dataclasses
import math

import numpy as np

from gyrojax.noise import allan, headline, readoff
from gyrojax.noise.gmwm import WaveletVariance, fit_spec
from gyrojax.noise.gmwm_model import ModelSpec
from gyrojax.noise.spec import BI_FACTOR, NoiseSpec

DT, N, K = 0.05, 0.1, 8.0  # s, deg/√h, deg/h/√h: the ADEV's minimum at τ ≈ 78 s, inside a 3277 s record
TRUTH = NoiseSpec(white=N, random_walk=K)
LEVEL = 0.95


def _record(rng, n):
    """White rate noise of ARW N plus a rate random walk of K (deg/h), n samples every DT s (processes module)."""
    white = N * 60.0 / math.sqrt(DT) * rng.standard_normal(n)
    return white + np.cumsum(K * math.sqrt(DT / 3600.0) * rng.standard_normal(n))


def _true_b(res):
    sd = (res.high - res.low) / 2.0
    known = np.flatnonzero(sd <= headline.B_MAX_HALF_WIDTH * res.adev)
    tt = np.geomspace(res.taus_s[0], res.taus_s[known[-1]], 2000)
    ad = dataclasses.replace(TRUTH, dt_s=DT).adev(tt)
    i = int(np.argmin(ad))
    assert 0 < i < len(tt) - 1, "the truth's minimum must lie inside the read-off's range"
    return float(ad[i] / BI_FACTOR)


def _z(figs, truth):
    """z = (value − truth)/σ of the figures read (not bounds), per figure."""
    out = {}
    for f, t in truth.items():
        v = figs[f]
        if v["value"] is not None and v.get("kind", "read") == "read" and v["std"] > 0:
            out[f] = (v["value"] - t) / v["std"]
    return out


def _coverage_ok(z, k_sigma):
    """(|fraction of |z| ≤ k_sigma − its normal probability| within 3 binomial sd of ``len(z)`` draws, fraction,
    expected, tolerance)."""
    k = len(z)
    level = math.erf(k_sigma / math.sqrt(2.0))
    c = float(np.mean(np.abs(np.asarray(z)) <= k_sigma))
    tol = 3.0 * math.sqrt(level * (1 - level) / k)
    return abs(c - level) <= tol, c, level, tol


def _draws(n_draws, n_samples, seed=2512):
    rng = np.random.default_rng(seed)
    curve, model = {}, {}
    spec = ModelSpec.parse("white+rw")
    for _ in range(n_draws):
        y = _record(rng, n_samples)
        res, _ = allan.analyze([y], DT)
        truth = {"arw": N, "rrw": K, "bias_instability": _true_b(res)}
        for f, z in _z(headline.curve_readoffs(res), truth).items():
            curve.setdefault(f, []).append(z)
        nm = fit_spec(spec, WaveletVariance.of([y], DT))
        for f, z in _z(readoff.derived(nm, float(res.taus_s[0]), float(res.taus_s[-1])), truth).items():
            model.setdefault(f, []).append(z)
    return curve, model


def test_readoff_coverage_on_white_plus_random_walk():
    """N, B, K read off the curve and off a GMWM white+rw model (delta method) in 300 records of 2^16 samples:
    the fractions within ±1σ and ±2σ of the truth each within 3 binomial sd of 0.683 and 0.954 (each figure read
    in at least 200). A σ 20 % too small gives 0.58 and 0.89, 20 % too wide 0.79 and 0.99: outside (±0.08 and
    ±0.036 at k = 300)."""
    curve, model = _draws(300, 2**16)
    for side, zs in (("curve", curve), ("model", model)):
        for f in ("arw", "bias_instability", "rrw"):
            assert len(zs.get(f, [])) >= 200, (side, f, len(zs.get(f, [])))
            for k_sigma in (1.0, 2.0):
                ok, c, level, tol = _coverage_ok(zs[f], k_sigma)
                msg = f"{side} {f}: ±{k_sigma:g}σ coverage {c:.3f} of {len(zs[f])} draws, not {level:.3f} ± {tol:.3f}"
                assert ok, msg
