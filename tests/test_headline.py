"""Headline IEEE 952 read-offs (issue 25): the curve read-offs against the closed forms of IEEE 952 annex C on
exact Allan curves, upper bounds where a slope is not seen, the model's and the curve's figures side by side on a
simulated record (against the simulated values), never contradicting silently, and a verdict that says how bad."""

import math

import jax
import numpy as np
import pytest
from scipy import stats

from gyrojax.noise import allan, headline, readoff
from gyrojax.noise.processes import simulate
from gyrojax.noise.spec import BI_FACTOR, NoiseSpec

N, K = 0.1, 2.0  # deg/√h, deg/h/√h


def _exact(taus, avar, edf=2000.0):
    """An AllanResult holding an exact σ²(τ) with ±1σ χ² intervals of ``edf`` degrees of freedom."""
    adev = np.sqrt(avar)
    low, high = allan.confidence_interval(adev, np.full(len(taus), edf))
    m = np.arange(1, len(taus) + 1)
    return allan.AllanResult(taus, adev, low, high, np.full(len(taus), edf), np.zeros(len(taus), int), m, m, (10,))


def test_curve_readoffs_match_the_closed_forms():
    """σ²(τ) = (60N)²/τ + K²τ/10800 (IEEE 952 C.2/C.4, τ in s, deg/h): N read on the −½ slope near τ = 1 s, K on
    the +½ slope, and the minimum σ² = 2·60N·K/√10800 at τ = 60N·√10800/K; B = σ_min/0.664."""
    taus = np.geomspace(0.01, 1e6, 200)
    res = _exact(taus, (60 * N) ** 2 / taus + K**2 * taus / 10800.0)
    r = headline.curve_readoffs(res)
    assert r["arw"]["value"] == pytest.approx(N, rel=0.02) and 0.3 < r["arw"]["tau_s"] < 3
    assert r["rrw"]["value"] == pytest.approx(K, rel=0.02) and r["rrw"]["kind"] == "read"
    sigma_min = math.sqrt(2 * 60 * N * K / math.sqrt(10800.0))
    assert r["bias_instability"]["value"] == pytest.approx(sigma_min / 0.664, rel=1e-3)
    assert r["bias_instability"]["tau_s"] == pytest.approx(60 * N * math.sqrt(10800.0) / K, rel=0.05)
    assert r["bias_instability"]["std"] > 0 and r["quantization"]["value"] is None


def test_a_wide_dip_at_the_long_end_is_not_the_flat_minimum():
    """The curve of the test above, its last 3 τ dipping to 0.6 × σ_min with 4 degrees of freedom (±1σ about
    ±35 %, as a real record's longest τ): B is still σ_min/0.664 at the closed-form τ, not a bound at the dip."""
    taus = np.geomspace(0.01, 1e6, 200)
    avar = (60 * N) ** 2 / taus + K**2 * taus / 10800.0
    sigma_min = math.sqrt(2 * 60 * N * K / math.sqrt(10800.0))
    avar[-3:] = (0.6 * sigma_min) ** 2
    edf = np.full(len(taus), 2000.0)
    edf[-3:] = 4.0
    res = _exact(taus, avar)
    low, high = allan.confidence_interval(np.sqrt(avar), edf)
    res = allan.AllanResult(taus, res.adev, low, high, edf, res.alpha, res.m, res.count, res.lengths)
    b = headline.curve_readoffs(res)["bias_instability"]
    assert b["kind"] == "read" and b["value"] == pytest.approx(sigma_min / 0.664, rel=1e-3)
    assert b["tau_s"] == pytest.approx(60 * N * math.sqrt(10800.0) / K, rel=0.05)


def test_k_interval_carries_the_other_terms_share_where_it_is_read():
    """σ² = (60N)²/τ + C + K²τ/10800 (white, flat, random walk) ending where the random walk carries ~80 % of σ²:
    the +½ read-off σ(τ)·√(10800/τ) is above K by 1/√(share) (every term adds), beyond the narrow χ² interval
    of 2000 degrees of freedom (the interval of σ alone misses K), and the ``ci``'s lower end, times √μ (μ the
    local slope of σ², ≤ the random walk's share when the other terms do not rise), holds K."""
    c = 0.5**2
    taus = np.geomspace(0.01, 4000.0, 150)
    avar = (60 * N) ** 2 / taus + c + K**2 * taus / 10800.0
    k = headline.curve_readoffs(_exact(taus, avar))["rrw"]
    share = (K**2 * k["tau_s"] / 10800.0) / np.interp(k["tau_s"], taus, avar)
    assert k["kind"] == "read" and share < 0.9
    assert k["value"] == pytest.approx(K / math.sqrt(share), rel=1e-9)
    low2, high2 = allan.confidence_interval(np.array([k["value"]]), np.array([2000.0]), headline.TWO_SIGMA)
    assert low2[0] > K  # the χ² interval of σ alone (the old rule) does not hold K
    assert k["ci"][0] <= K <= k["ci"][1] and k["ci"][1] == pytest.approx(high2[0], rel=1e-9)


def test_quantization_and_ramp_read_where_seen():
    """σ² = 3Q²/τ² (Q arcsec = deg/h·s) at short τ and R²τ²/2 (R deg/h per s) at long τ: both read back."""
    q, r_dphph = 0.5, 36.0
    taus = np.geomspace(0.001, 1e5, 200)
    avar = 3 * q**2 / taus**2 + (60 * N) ** 2 / taus + (r_dphph / 3600.0) ** 2 * taus**2 / 2
    r = headline.curve_readoffs(_exact(taus, avar))
    assert r["quantization"]["value"] == pytest.approx(q, rel=0.05)
    assert r["rate_ramp"]["value"] == pytest.approx(r_dphph, rel=0.05)


def test_no_rrw_seen_gives_an_upper_bound_and_no_floor_a_bound_on_b():
    """White only: K is an upper bound at the longest τ, B too (the curve still falls): σ̂·√(ν/χ²_q(ν)) at the
    Bonferroni tail q = (1 − BOUND_LEVEL)/looks (scipy.stats.chi2), one-sided, no ``ci``; both hold the exact
    curve's figures (K = 0 ≤ bound, and the bound of B above σ_min/0.664 at the longest τ)."""
    taus = np.geomspace(0.01, 100.0, 50)
    res = _exact(taus, (60 * N) ** 2 / taus, edf=50)
    r = headline.curve_readoffs(res)
    for name, factor in (("rrw", math.sqrt(3 * 3600 / 100.0)), ("bias_instability", 1 / BI_FACTOR)):
        v = r[name]
        assert v["kind"] == "upper bound" and "ci" not in v and v["bound_level"] == headline.BOUND_LEVEL
        q = (1 - headline.BOUND_LEVEL) / v["looks"]
        assert v["looks"] >= 2 and v["tau_s"] == pytest.approx(100.0)
        assert v["value"] == pytest.approx(res.adev[-1] * math.sqrt(50 / stats.chi2.ppf(q, 50)) * factor, rel=1e-9)
        assert v["value"] > res.high[-1] * factor  # beyond the ±1σ end, which held 0.44-0.64 of issued bounds
        assert v["bound_ratio"] * res.adev[-1] * factor == pytest.approx(v["value"], rel=1e-12)  # where it is drawn


def test_report_puts_model_and_curve_side_by_side():
    """A simulated white + RW record (N = 0.1, K = 2): the headline N and K of the curve and of the model within
    3σ (or 10 %) of the truth, or, where the curve gives an upper bound (its K here: no +½ slope seen), the bound
    above the truth; the two agree, and the model's B read where the curve's minimum is."""
    spec = NoiseSpec(white=N, random_walk=K)
    dt = 0.05
    y = np.asarray(simulate(spec, jax.random.PRNGKey(4), np.arange(2**18) * dt, dt_white=dt))
    out, res, ieee, nm = readoff.noise_report([y], dt)
    h = out["headline"]
    for k, truth in (("arw", N), ("rrw", K)):
        for side in ("curve", "model"):
            v = h[k][side]
            if v.get("kind") == "upper bound":  # no +1/2 slope seen (this record's curve K): a bound, not an estimate
                assert v["value"] >= truth and "ci" not in v, (k, side, v)
            else:
                assert abs(v["value"] - truth) < max(3 * v["std"], 0.1 * truth), (k, side, v)
                assert v["ci"][0] <= v["value"] <= v["ci"][1] and v["ci_level"] == headline.TWO_SIGMA
        assert h[k]["agree"] is True, h[k]
    b = h["bias_instability"]
    assert b["curve"]["value"] is not None and b["model"]["value"] is not None and b["agree"] is True
    assert all(note.split(":")[0] in h or note.startswith("terms.") for note in out["notes"])


def test_disagreement_is_a_note():
    model = {"arw": {"value": 0.2, "std": 0.001, "unit": "deg/sqrt(h)", "tau_s": 0.1}}
    curve = {"arw": {"value": 0.1, "std": 0.001, "unit": "deg/sqrt(h)", "tau_s": 1.0, "kind": "read"}}
    c = headline.compare(model, curve)
    assert c["arw"]["agree"] is False and "differ by 100 %" in c["arw"]["note"]
    assert c["bias_instability"]["agree"] is None


def test_verdict_says_how_bad_and_the_cause():
    taus = np.array([0.01, 0.02, 0.04, 1.0, 10.0])
    adq = {"inside": [False, False, True, True, True], "ratio": [1.02, 1.011, 1.0, 1.0, 1.0], "n_outside": 2}
    adq["taus_outside_s"] = [0.01, 0.02]
    line = readoff.verdict_line(taus, adq, 0.04, "the sensor's own filter colours the noise")
    assert "by up to 2 %" in line and "tau 0.01 to 0.02 s" in line and "sensor's own filter" in line
