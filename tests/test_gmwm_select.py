"""Identified GMWM model selection (issue 25): Gauss–Markov correlation times inside what the scales identify,
duplicates and unidentified components rejected, the sensor's filtered short scales dropped with the reason, white
data kept white, a planted component found. The false-component rate itself is a Monte Carlo study
(benchmarks/study_gmwm_selection.py); these tests use a few seeds."""

import jax
import numpy as np
import pytest

from gyrojax.noise import gmwm, gmwm_select
from gyrojax.noise import gmwm_model as gm
from gyrojax.noise.processes import simulate
from gyrojax.noise.spec import NoiseSpec

DT = 0.01
N_WHITE = 0.1  # deg/√h: per-sample σ = 60 N / √Δt = 60 deg/h at 100 Hz


def _white(n, seed):
    return np.random.default_rng(seed).normal(0.0, 60.0 * N_WHITE / np.sqrt(DT), n)


@pytest.mark.slow
def test_white_data_stay_white():
    """30 white records of 2^14 samples: a spurious component in at most 5 (binomial at the stated 5 %:
    P(X ≥ 6) = 0.3 %; the WIC selection this replaces kept one in 10 of 60), every white-only fit's N within 3 % of
    the simulated one (sd of N̂ ≈ 0.6 % here), and no short scale dropped."""
    false = 0
    for seed in range(30):
        nm = gmwm.fit_gmwm(_white(2**14, seed), DT)
        false += nm.info["model"] != "white"
        if nm.info["model"] == "white":
            assert nm.white == pytest.approx(N_WHITE, rel=0.03)
        assert nm.info["short_scales"] == "" and nm.info["tau_min_s"] == DT
    assert gmwm_select.FALSE_COMPONENT_LEVEL == 0.05 and false <= 5, false


def test_gm_tau_stays_inside_the_identifiable_range():
    """A forced white+3gm fit on white data: every T between 3 samples and the longest scale (the old box allowed
    0.05 samples), and the selection table rejects the duplicates / pinned ones with a reason."""
    y = _white(2**15, 7)
    est = gmwm.WaveletVariance.of(y, DT)
    t_lo, t_hi = gmwm.gm_tau_limits(est.m)
    assert t_lo == 3.0 and t_hi == est.m.max()
    ns = gmwm.fit_spec(gm.ModelSpec(n_gm=3), est)
    for _, tau in ns.gauss_markov:
        assert 3.0 * DT * (1 - 1e-6) <= tau <= est.m.max() * DT * (1 + 1e-6)
    assert gmwm_select.rejection(ns) != ""


def test_duplicates_are_rejected():
    two = NoiseSpec(
        white=0.1,
        gauss_markov=((1.0, 2.0), (1.0, 3.0)),
        cov=np.eye(5).ravel(),
        info={"pinned": []},
        cov_names=("white", "gm1_sigma", "gm1_tau", "gm2_sigma", "gm2_tau"),
    )
    assert "duplicate" in gmwm_select.rejection(two)
    apart = NoiseSpec(
        white=0.1,
        gauss_markov=((1.0, 2.0), (1.0, 20.0)),
        cov=(0.01 * np.eye(5)).ravel(),
        info={"pinned": []},
        cov_names=two.cov_names,
    )
    assert gmwm_select.rejection(apart) == ""


def test_planted_gauss_markov_is_found():
    """White + GM σ = 20 deg/h, T = 5 s (its ADEV bump 12 deg/h against white 2.7 deg/h at 5 s): one GM, T within
    its ±3σ, white not pinned and within 3 % of the truth."""
    spec = NoiseSpec(white=N_WHITE, gauss_markov=((20.0, 5.0),))
    t = np.arange(2**17) * DT
    y = np.asarray(simulate(spec, jax.random.PRNGKey(3), t, dt_white=DT))
    nm = gmwm.fit_gmwm(y, DT)
    assert nm.info["model"] == "white+gm", nm.info["selection"]
    assert abs(nm.gauss_markov[0][1] - 5.0) < 3 * nm.std("gm1_tau")
    assert nm.white == pytest.approx(N_WHITE, rel=0.03) and not nm.info["pinned"]


def test_sensor_filter_drops_the_short_scales():
    """White noise through a 4-tap moving average (a decimation filter): the shortest scales are dropped with the
    cause named, no Gauss–Markov component below 3 samples, and N within 10 % of the unfiltered white (a filter of
    unit DC gain leaves the long-τ ADEV, hence N, unchanged)."""
    x = _white(2**17 + 3, 11)
    y = np.convolve(x, np.ones(4) / 4.0, mode="valid")
    nm = gmwm.fit_gmwm(y, DT)
    assert nm.info["tau_min_s"] >= 4 * DT and "filter" in nm.info["short_scales"]
    assert all(tau >= 3 * DT for _, tau in nm.gauss_markov)
    assert nm.white == pytest.approx(N_WHITE, rel=0.10) and not nm.info["pinned"]


def test_a_ringing_short_scale_is_dropped_too():
    """White noise through a 2-tap average plus a tone at a quarter of the sample rate (a ringing filter, as the z
    gyro of a real ADIS16405: m·ν̂² rises, falls and rises again over m = 1 … 4): those scales are dropped, no
    quantization or sub-sample term is fitted to them, and N stays within 6 % of the unfiltered white (the
    average has unit DC gain and the tone no white content; kept at m = 2 only, N came out 20 % low as white +
    quantization)."""
    rng = np.random.default_rng(11)
    y = np.convolve(_white(2**17 + 1, 11), np.ones(2) / 2.0, mode="valid")
    y = y + 60.0 * np.sin(np.pi * np.arange(len(y)) / 2.0 + rng.uniform(0.0, 2.0 * np.pi))
    nm = gmwm.fit_gmwm(y, DT)
    assert nm.info["tau_min_s"] >= 4 * DT and "filter" in nm.info["short_scales"]
    assert nm.quantization == 0.0 and all(tau >= 3 * DT for _, tau in nm.gauss_markov)
    assert nm.white == pytest.approx(N_WHITE, rel=0.06) and not nm.info["pinned"]
