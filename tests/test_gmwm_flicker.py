"""The flicker floor (bias instability B) of the GMWM models (issue 25): its flat Haar wavelet variance against the
integral of a 1/f spectrum (scipy) and against 1/f series synthesised by FFT (allantools oadev), its
identification on simulated records, the "not seen" rejection, and the J-test gate of the selection."""

import functools
import math

import allantools
import numpy as np
import pytest
from scipy import integrate

from gyrojax.noise import gmwm, gmwm_select
from gyrojax.noise import gmwm_model as gm
from gyrojax.noise.spec import BI_FACTOR, NoiseSpec

from .synth import floor_b2, one_over_f

DT = 0.01


def _haar_integral(m: int, b2: float) -> float:
    """ν²(m) = 2∫₀^½ |G_m(f)|² S(f) df of the 1/f spectrum of :func:`gm.spectrum_flicker` (scipy quad, split at
    the zeros of the Haar gain)."""

    def g(f):
        return math.sin(math.pi * f * m) ** 4 / (m * m * math.sin(math.pi * f) ** 2) * float(gm.spectrum_flicker(f, b2))

    pts = np.arange(1, m) / (2.0 * m) if m > 1 else None
    return 2.0 * integrate.quad(g, 0.0, 0.5, points=pts, limit=4 * m + 200)[0]


def test_flat_floor_is_the_haar_integral_of_a_one_over_f_spectrum():
    """ν² = b² at every m (IEEE 952's (2 ln 2/π)B² Allan floor): the sampled 1/f process's exact value exceeds it
    by less than 1/m from m = 4 on and the excess falls with m; the NoiseSpec's Allan variance is 2b²."""
    b2 = 2.5
    excess = [_haar_integral(m, b2) / b2 - 1.0 for m in (4, 16, 64, 256)]
    assert all(0.0 < e < 1.0 / m for e, m in zip(excess, (4, 16, 64, 256))), excess
    assert excess == sorted(excess, reverse=True)
    assert float(gm.wv_flicker(16, b2)) == b2
    spec = gm.ModelSpec(n_gm=0, flicker=True)
    b = 30.0
    th = gm.theta_from_natural(spec, {"white": 2.0, "bias_instability": b}, DT)
    ns = gm.to_noise_spec(spec, th, np.eye(2) * 1e-4, DT, "gmwm", {"pinned": []})
    assert ns.bias_instability == pytest.approx(b, rel=1e-12)
    taus = np.array([1.0, 100.0])
    assert ns.term_avar(taus)["bias_instability"] == pytest.approx((BI_FACTOR * b) ** 2, rel=1e-12)
    assert 2.0 * float(gm.wv_flicker(100, math.exp(th[1]))) == pytest.approx((BI_FACTOR * b) ** 2, rel=1e-12)


def test_flat_floor_against_synthesised_one_over_f_series():
    """8 FFT-synthesised 1/f series of 2^18 samples: the mean allantools oadev²/2 at m = 8 … 512 equals the exact
    Haar integral within 4 standard errors of that mean (from the spread of the 8 series)."""
    rng = np.random.default_rng(11)
    b2, n, ms = 4.0, 2**18, np.array([8, 32, 128, 512])
    est = []
    for _ in range(8):
        y = one_over_f(rng, n, b2)
        _, ad, _, _ = allantools.oadev(y, rate=1.0, data_type="freq", taus=ms.astype(float))
        est.append(ad**2 / 2.0)
    est = np.array(est)
    mean, se = est.mean(axis=0), est.std(axis=0, ddof=1) / math.sqrt(len(est))
    exact = np.array([_haar_integral(int(m), b2) for m in ms])
    assert np.all(np.abs(mean - exact) < 4.0 * se), (mean, exact, se)
    assert np.all(np.abs(exact / b2 - 1.0) < 0.01)


def _record(seed, n, white=0.1, b=6.0, k=0.0):
    rng = np.random.default_rng(seed)
    b2 = floor_b2(b)
    y = rng.normal(0.0, 60.0 * white / math.sqrt(DT), n) + one_over_f(rng, n, b2)
    if k:
        y = y + np.cumsum(rng.normal(0.0, k * math.sqrt(DT / 3600.0), n))
    return y


@pytest.mark.parametrize("seed", [1, 2])
def test_flicker_identified_on_white_plus_one_over_f(seed):
    """White N = 0.1 deg/√h + a 1/f floor B = 6 deg/h (2^17 samples): the selection takes white+flicker, B and N
    within 3 of their own standard errors (B's error also carries the 1/m excess of the sampled process, < 1 %)."""
    ns = gmwm.fit_gmwm(_record(seed, 2**17), DT)
    assert ns.info["model"] == "white+flicker", ns.info["selection"]
    assert abs(ns.bias_instability - 6.0) < 3.0 * ns.std("bias_instability") + 0.01 * 6.0
    assert abs(ns.white - 0.1) < 3.0 * ns.std("white")
    assert ns.flicker_band == pytest.approx((ns.info["tau_min_s"], DT * 2**14))


def test_flicker_and_random_walk_identified():
    """White + B = 6 deg/h + K = 60 deg/h/√h (2^18 samples; the floor dominates from 2 to 47 s): white+flicker+rw,
    B and K within 3 standard errors."""
    ns = gmwm.fit_gmwm(_record(3, 2**18, k=60.0), DT)
    assert ns.info["model"] == "white+flicker+rw", ns.info["selection"]
    assert abs(ns.bias_instability - 6.0) < 3.0 * ns.std("bias_instability") + 0.06
    assert abs(ns.random_walk - 60.0) < 3.0 * ns.std("random_walk")


def _white_and_floor(b: float) -> NoiseSpec:
    """A fitted white (1 deg/√h) + flicker floor (B = ``b`` deg/h) model over τ up to 100 s."""
    return NoiseSpec(
        white=1.0,
        bias_instability=b,
        dt_s=DT,
        flicker_band=(DT, 100.0),
        cov=(np.eye(2) * 1e-6).ravel(),
        cov_names=("white", "bias_instability"),
        info={"pinned": []},
    )


def test_a_hidden_floor_is_not_seen():
    """A floor 0.1 of the white term's ADEV at the longest fitted τ carries half the variance nowhere: rejected."""
    hidden = _white_and_floor(1.0)  # white ADEV at 100 s: 60/10 = 6 deg/h, floor 0.66 deg/h
    assert gmwm_select.flicker_span(hidden) == 1.0
    assert "not seen" in gmwm_select.rejection(hidden)
    seen = _white_and_floor(20.0)  # equal at τ = (60/13.3)² = 20 s: half or more from 20 to 100 s
    assert gmwm_select.flicker_span(seen) == pytest.approx(100.0 / 20.4, rel=0.05)
    assert gmwm_select.rejection(seen) == ""


def test_j_test_gate_moves_past_an_inadequate_candidate(monkeypatch):
    """With a penalty so large that white alone ranks first on white + a strong Gauss–Markov record, white fails its
    own J test (p ≪ 0.001) and the gate takes white+gm; with white the only candidate, it is kept with a note."""
    rng = np.random.default_rng(4)
    n = 2**15
    e = rng.normal(size=n)
    x = np.zeros(n)
    phi = math.exp(-DT / 2.0)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + math.sqrt(1 - phi * phi) * 20.0 * e[i]
    y = rng.normal(0.0, 60.0 * 0.1 / math.sqrt(DT), n) + x
    est = gmwm.WaveletVariance.of(y, DT)
    monkeypatch.setattr(gmwm_select, "table_row", functools.partial(gmwm_select.table_row, penalty=1e4))
    cands = (gm.ModelSpec(n_gm=0), gm.ModelSpec(n_gm=1))
    ns = gmwm.select_model(est, cands)
    assert ns.info["model"] == "white+gm" and ns.info["j_test"] is None
    assert ns.info["selection"][0]["j_test_p"] < gmwm_select.J_TEST_LEVEL
    alone = gmwm.select_model(est, cands[:1])
    assert alone.info["model"] == "white" and "J test" in alone.info["j_test"]


def test_report_says_which_b_is_which():
    """The headline model B (σ_min/0.664 of the whole model's ADEV, IEEE 952) is at least the flicker floor's own B
    (the other terms only add variance); where they differ by more than 10 % a note names both."""
    from gyrojax.noise.readoff import noise_report

    out, *_ = noise_report([_record(3, 2**18, k=60.0)], DT)
    floor = out["model"]["parameters"]["bias_instability"]["value"]
    head = out["headline"]["bias_instability"]["model"]["value"]
    assert head >= floor * (1 - 1e-9)
    said = [n for n in out["notes"] if n.startswith("model.bias_instability")]
    assert bool(said) == (head - floor > 0.1 * head), (floor, head, out["notes"])
