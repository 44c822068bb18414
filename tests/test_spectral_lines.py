"""Spectral lines in static records (:mod:`gyrojax.noise.lines`, issue 25): a sinusoid found at its frequency and
amplitude, none on noise-only records, the line's Allan variance against allantools, and the report's keys."""

import math

import numpy as np
import pytest

from gyrojax.noise import lines
from gyrojax.noise.readoff import noise_report
from gyrojax.noise.sensor_units import accelerometer_report

from .synth import one_over_f

TAU0 = 0.01
N = 2**16


def _noise(kind: str, rng: np.random.Generator, n: int = N) -> np.ndarray:
    """Unit white noise plus a Gauss–Markov (σ 3, 1 s), a random walk (0.05 per sample) or a 1/f series."""
    y = rng.standard_normal(n)
    if kind == "gm":
        from scipy.signal import lfilter

        phi = math.exp(-TAU0)
        y += lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * math.sqrt(1 - phi**2) * 3.0)
    elif kind == "rw":
        y += np.cumsum(rng.standard_normal(n)) * 0.05
    elif kind == "flicker":
        y += one_over_f(rng, n, 0.03)
    return y


def _sine(f0: float, a: float, n: int = N, phase: float = 0.4) -> np.ndarray:
    return a * np.sin(2 * math.pi * f0 * np.arange(n) * TAU0 + phase)


@pytest.mark.parametrize("kind,seed", [("white", 3), ("rw", 4)])
def test_a_sine_is_found_at_its_frequency_and_amplitude(kind, seed):
    f0, a = 0.565, 0.1  # power ratio ≈ 8 at the peak bin
    res = lines.find_lines([_noise(kind, np.random.default_rng(seed)) + _sine(f0, a)], TAU0)
    assert res["searched"] and res["band_hz"][0] < f0 < res["band_hz"][1]
    ln = res["lines"][0]
    assert abs(ln["frequency_hz"] - f0) <= res["resolution_hz"]
    # the stated uncertainty (±2 se covered the truth in 0.94–0.96 of the study's draws; 3 se here)
    assert abs(ln["amplitude"] - a) <= 3 * ln["amplitude_std"]
    assert 0 < ln["amplitude_std"] and ln["p_family"] < res["level"]


@pytest.mark.parametrize("kind", ["white", "gm", "rw", "flicker"])
def test_no_line_on_noise_only_records(kind):
    for seed in range(5):
        res = lines.find_lines([_noise(kind, np.random.default_rng(100 + seed))], TAU0)
        assert res["searched"] and res["lines"] == [], (kind, seed, res["lines"])


@pytest.mark.slow
def test_false_line_rate_at_its_level():
    """Monte Carlo: the family-wise false-line rate on 200 line-free records of each kind (2^14 samples) is within
    the binomial 0.999 point of the stated level α = 0.01 (the study, benchmarks/study_spectral_lines.py, runs
    1000 of 2^16)."""
    from scipy.stats import binom

    draws = 200
    for kind in ("white", "gm", "rw", "flicker"):
        hits = sum(
            bool(lines.find_lines([_noise(kind, np.random.default_rng(7000 + i), 2**14)], TAU0)["lines"])
            for i in range(draws)
        )
        assert hits <= binom.ppf(0.999, draws, lines.LEVEL), (kind, hits)


def test_record_too_short_is_said_not_searched():
    res = lines.find_lines([np.random.default_rng(0).standard_normal(3000)], TAU0)
    assert not res["searched"] and "fewer than" in res["reason"]
    assert lines.note([], res).startswith("spectral lines: not searched")


def test_line_allan_variance_against_allantools():
    """σ²(τ) = A² sin⁴(πf₀τ)/(πf₀τ)² (continuous averaging) against allantools' overlapping ADEV of a sampled sine.
    Sampled, the m-sample mean carries m·sin(πf₀τ₀) in place of πf₀τ: a relative (πf₀τ₀)²/3; a finite record of
    M second differences averages cos² to ½ within 1/(M·|sin(2πf₀τ₀)|)."""
    allantools = pytest.importorskip("allantools")
    f0, a, n = 0.565, 2.0, 2**16
    y = _sine(f0, a, n)
    m = np.unique(np.geomspace(1, 3000, 60).astype(int))
    taus, adev, *_ = allantools.oadev(y, rate=1.0 / TAU0, data_type="freq", taus=m * TAU0)
    closed = lines.line_avar(f0, a, taus)
    keep = closed > 1e-6 * a**2  # away from the zeros τ = k/f₀
    n_diff = n - 2 * np.round(taus / TAU0) + 1
    x0 = math.pi * f0 * TAU0
    tol = x0**2 / 3 + 1.0 / (n_diff * abs(math.sin(2 * x0))) + 1e-9
    rel = np.abs(adev**2 / closed - 1.0)
    assert np.all(rel[keep] <= tol[keep]), (taus[keep][rel[keep] > tol[keep]], rel[keep].max())
    # its peak: tan x = 2x at x = πf₀τ, σ = 0.725·A there
    assert math.tan(lines.X_PEAK) == pytest.approx(2 * lines.X_PEAK, rel=1e-12)
    t = np.geomspace(0.1, 1.5, 20001) / f0
    assert t[np.argmax(lines.line_avar(f0, a, t))] == pytest.approx(lines.X_PEAK / (math.pi * f0), rel=1e-3)
    # the envelope is the closed form up to the peak and bounds it beyond
    env = lines.line_avar_envelope(f0, a, t)
    assert np.all(env >= lines.line_avar(f0, a, t) * (1 - 1e-12))


@pytest.fixture(scope="module")
def with_a_line():
    """A rate record (deg/h) of white noise (σ 100 deg/h per 0.01 s sample) and a 30 deg/h line at 0.565 Hz."""
    rng = np.random.default_rng(25)
    y = 100.0 * rng.standard_normal(2**15) + _sine(0.565, 30.0, 2**15)
    return noise_report([y], TAU0, model="white")[0]


def test_the_report_names_the_line(with_a_line):
    out = with_a_line
    (ln,) = out["spectral_lines"]
    assert abs(ln["frequency_hz"] - 0.565) <= out["spectral_line_search"]["resolution_hz"]
    assert abs(ln["amplitude"] - 30.0) <= 3 * ln["amplitude_std"] and ln["unit"] == "deg/h"
    lo, hi = ln["tau_range_s"]
    assert lo < ln["tau_peak_s"] < ln["tau_zero_s"] < hi
    assert any(n.startswith("spectral lines (1 found") for n in out["notes"])
    # a white model cannot follow the line's bump: the verdict names it
    assert out["adequacy"]["n_outside"] > 0
    assert "within reach of a 0.56" in out["adequacy"]["verdict"]
    acc = accelerometer_report(out)
    assert acc["spectral_lines"][0]["unit"] == "m/s^2"
    note = next(n for n in acc["notes"] if n.startswith("spectral lines"))
    assert "deg/h" not in note and "deg/h" not in acc["adequacy"]["verdict"]


def test_cause_words():
    ln = {"frequency_hz": 0.5, "amplitude": 1.0, "amplitude_std": 0.1, "unit": "deg/h", "power_ratio": 9.0}
    ln["tau_range_s"] = [0.1, 4.0]
    assert lines.cause([ln], [0.5, 2.0]).startswith("within reach of a 0.5 Hz line")
    assert lines.cause([ln], [0.5, 20.0]).startswith("partly within reach")
    assert lines.cause([ln], [20.0]) == "" and lines.cause([{**ln, "tau_range_s": None}], [1.0]) == ""
