"""±1σ and ±2σ coverage of the headline read-offs N, B, K (issue 25), curve and model, on simulated white +
random-walk records with the model fixed: a small version of benchmarks/study_noise_readoff_coverage.py (which
has the selection in the loop, three truths and 300 records of 2^18 samples each).

Tolerances are exact binomial tails at the test's draw count: each of the 12 counts (2 sides × 3 figures × 2
levels) must lie inside the central binom(k, level) interval of probability 1 − ALPHA/12 (Bonferroni), so a
correct σ fails the test with probability ≤ ALPHA. The same draws with every σ scaled by 0.8 or 1.25 (the model's
std, and for the curve the χ² EDF divided by the square of the scale) must fail it: the test shows its own power.

Truths: N and K the simulated coefficients; B the IEEE 952 read-off σ_min/0.664 of the exact (sampled) Allan
deviation of the true model over the τ the curve's B read-off uses (headline.B_MAX_HALF_WIDTH)."""

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from gyrojax.noise import allan, headline, readoff
from gyrojax.noise.gmwm import WaveletVariance, fit_spec
from gyrojax.noise.gmwm_model import ModelSpec
from gyrojax.noise.spec import BI_FACTOR, NoiseSpec

DT, N, K = 0.05, 0.1, 8.0  # s, deg/√h, deg/h/√h: the ADEV's minimum at τ ≈ 78 s, inside a 3277 s record
TRUTH = NoiseSpec(white=N, random_walk=K)
FIGS = ("arw", "bias_instability", "rrw")
LEVELS = (allan.ONE_SIGMA, headline.TWO_SIGMA)
ALPHA = 1e-3
DRAWS = 600


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


def _draws(n_draws, n_samples, seed=2512):
    """Per side and figure, the rows (value, truth, a, b) of the draws that read it (not bounds): for the model
    a = std (delta method), for the curve a = σ̂ and b = the EDF at its τ (value/σ̂ the read-off's factor)."""
    rng = np.random.default_rng(seed)
    rows = {(s, f): [] for s in ("curve", "model") for f in FIGS}
    spec = ModelSpec.parse("white+rw")
    for _ in range(n_draws):
        y = _record(rng, n_samples)
        res, _ = allan.analyze([y], DT)
        truth = {"arw": N, "rrw": K, "bias_instability": _true_b(res)}
        for f, v in headline.curve_readoffs(res).items():
            if f in truth and v["value"] is not None and v["kind"] == "read":
                i = int(np.flatnonzero(res.taus_s == v["tau_s"])[0])
                rows["curve", f].append((v["value"], truth[f], res.adev[i], res.edf[i]))
        nm = fit_spec(spec, WaveletVariance.of([y], DT))
        for f, v in readoff.derived(nm, float(res.taus_s[0]), float(res.taus_s[-1])).items():
            if v["value"] is not None and v["std"] > 0:
                rows["model", f].append((v["value"], truth[f], v["std"], 0.0))
    return {k: np.asarray(v, float) for k, v in rows.items()}


def _covered(side, r, level, scale):
    """Whether each row's interval at ``level`` (its σ scaled by ``scale``) holds the truth."""
    value, truth, a, b = r.T
    if side == "model":  # readoff.log_interval at k σ, vectorised
        k = stats.norm.ppf((1 + level) / 2) * scale
        return np.abs(np.log(value / truth)) <= k * a / value
    low, high = allan.confidence_interval(a, b / scale**2, level)  # σ of ln σ̂ ∝ 1/√EDF
    return (low * value / a <= truth) & (truth <= high * value / a)


def _failures(rows, scale):
    """The counts outside their binomial tolerance (module doc), as messages."""
    out = []
    n_checks = len(rows) * len(LEVELS)
    for (side, f), r in rows.items():
        for level in LEVELS:
            k = len(r)
            hits = int(_covered(side, r, level, scale).sum())
            lo, hi = stats.binom.interval(1 - ALPHA / n_checks, k, level)
            if not lo <= hits <= hi:
                out.append(f"{side} {f}: {hits}/{k} = {hits / k:.3f} at level {level:.3f}, not in [{lo:g}, {hi:g}]")
    return out


@pytest.mark.slow
def test_readoff_coverage_on_white_plus_random_walk():
    """N, B, K read off the curve (χ² interval) and off a GMWM white+rw model (delta method in ln) in 600 records
    of 2^16 samples: ±1σ and ±2σ coverage inside the binomial tolerance (each figure read in at least 400 draws),
    and outside it with every σ scaled by 0.8 or by 1.25 (±1σ coverage 0.58 or 0.79 instead of 0.683: the
    tolerance at k = 600 is about ±0.075 there)."""
    rows = _draws(DRAWS, 2**16)
    for key, r in rows.items():
        assert len(r) >= 400, (key, len(r))
    assert not _failures(rows, 1.0), _failures(rows, 1.0)
    for scale in (0.8, 1.25):
        for side in ("curve", "model"):
            side_rows = {k: v for k, v in rows.items() if k[0] == side}
            assert _failures(side_rows, scale), f"the {side} checks pass with σ scaled by {scale}: no power"


def test_mata_interval_closed_forms():
    """One model: the interval is readoff.log_interval; a model whose figure is 0 holding ≥ α/2 of the weight
    sets the lower end to 0; two models: the tail equations of Turek & Fletcher (2012) hold (scipy.stats.norm)."""
    lo, hi = readoff.mata_interval([2.0], [0.1], [1.0])
    assert np.allclose([lo, hi], readoff.log_interval(2.0, 0.1), rtol=1e-9)
    assert readoff.mata_interval([2.0, None], [0.1, 0.0], [0.9, 0.1])[0] == 0.0
    v, s, w = np.array([2.0, 3.0]), np.array([0.1, 0.3]), np.array([0.7, 0.3])
    lo, hi = readoff.mata_interval(list(v), list(s), list(w))
    a = (1 - headline.TWO_SIGMA) / 2
    assert math.isclose(w @ stats.norm.sf((np.log(v) - math.log(lo)) / (s / v)), a, rel_tol=1e-6)
    assert math.isclose(w @ stats.norm.cdf((np.log(v) - math.log(hi)) / (s / v)), a, rel_tol=1e-6)
    assert 2.0 * math.exp(-2 * 0.05) < lo < 2.0 < 3.0 < hi  # 0.3 of the weight above: a lighter lower tail
