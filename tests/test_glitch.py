"""Glitches of static logs (issue 25): planted spikes and a stuck stretch found where they were planted, none on
clean logs (quantised ones included), and the headline N and the model moved by less than 10 % by them."""

import jax
import numpy as np
import pytest

from gyrojax.noise import glitch, readoff
from gyrojax.noise.processes import simulate
from gyrojax.noise.spec import NoiseSpec

DT = 0.01


def _log(n=2**18, seed=9):
    spec = NoiseSpec(white=0.2, gauss_markov=((3.0, 30.0),))
    y = np.asarray(simulate(spec, jax.random.PRNGKey(seed), np.arange(n) * DT, dt_white=DT))
    return np.round(y / 0.5) * 0.5  # a quantised logger: repeated values are normal here


def _planted(y, seed=1):
    rng = np.random.default_rng(seed)
    z = y.copy()
    sigma = np.std(np.diff(y)) / np.sqrt(2)
    free = np.r_[1000:99000, 103000 : len(y) - 1000]  # away from the stuck stretch
    idx = np.sort(rng.choice(free, 40, replace=False))
    z[idx] += 50 * sigma * rng.choice([-1.0, 1.0], 40)
    z[100000:102000] = z[100000]  # 20 s of a stuck logger value
    return z, idx


def test_clean_quantised_log_has_no_glitch():
    segs, rep = glitch.clean([_log()], DT)
    assert rep["spikes"]["count"] == 0 and rep["stuck"]["count"] == 0 and glitch.note(rep) == ""
    assert len(segs) == 1


def test_planted_glitches_are_found_where_planted():
    z, idx = _planted(_log())
    segs, rep = glitch.clean([z], DT)
    assert rep["spikes"]["count"] == 40
    np.testing.assert_allclose([t for _, t in rep["spikes"]["at"]], idx[:20] * DT)
    assert rep["stuck"]["count"] == 1
    _, start, length = rep["stuck"]["at"][0]
    assert start == pytest.approx(1000.0) and length == pytest.approx(20.0)
    assert rep["pieces"] == 2 and "40 spikes" in glitch.note(rep) and "1 stuck" in glitch.note(rep)


def test_estimates_move_less_than_ten_percent():
    """The report on the glitched log (masked) against the clean log: N (curve and model) within 10 %, the same
    model, and the glitches named in the notes; without masking the spikes inflate N by more than 10 %."""
    y = _log()
    z, _ = _planted(y)
    clean, *_ = readoff.noise_report([y], DT)
    dirty, *_ = readoff.noise_report([z], DT)
    raw, *_ = readoff.noise_report([z], DT, mask_glitches=False)
    for side in ("curve", "model"):
        a, b = clean["headline"]["arw"][side]["value"], dirty["headline"]["arw"][side]["value"]
        assert b == pytest.approx(a, rel=0.10), side
    assert clean["model"]["info"]["model"] == dirty["model"]["info"]["model"]
    assert any(n.startswith("glitches: 40 spikes") for n in dirty["notes"]) and dirty["glitches"]["masked"]
    assert raw["headline"]["arw"]["curve"]["value"] > 1.1 * clean["headline"]["arw"]["curve"]["value"]
    assert any("NOT masked" in n for n in raw["notes"])


def _coarse_log(sigma_lsb, n=2**18, seed=4):
    """White noise of ``sigma_lsb`` quantisation steps (deg/h, step 180 = the ADIS16405's 0.05 deg/s) with a slow
    Gauss–Markov wander of one step: at σ ≲ 0.7 step most samples equal the median of their neighbours."""
    rng = np.random.default_rng(seed)
    phi = np.exp(-1e-4)
    e = rng.normal(0.0, np.sqrt(1 - phi**2), n)
    from scipy import signal

    return 180.0 * np.round(rng.normal(0.0, sigma_lsb, n) + signal.lfilter([1.0], [1.0, -phi], e))


@pytest.mark.parametrize("sigma_lsb,stuck", [(0.6, False), (0.77, True)])
def test_spikes_found_on_a_coarsely_quantised_log(sigma_lsb, stuck):
    """A log whose noise is under one quantisation step (the ADIS16405 accelerometer, imu2 y): the robust σ of the
    distances from the median is taken on the lattice, so the 40 planted 50σ spikes are found where planted (with
    a 20 s stuck stretch, which adds exact ties) and the clean log has none; the plain MAD was 0 there, and the
    detector found nothing."""
    y = _coarse_log(sigma_lsb)
    assert glitch.spikes(y)[0].size == 0
    z = y.copy()
    if stuck:
        z[100000:102000] = z[100000]
    rng = np.random.default_rng(1)
    idx = np.sort(rng.choice(np.r_[1000:99000, 103000 : len(y) - 1000], 40, replace=False))
    z[idx] += 50 * 180.0 * sigma_lsb * rng.choice([-1.0, 1.0], 40)
    found, repl = glitch.spikes(z)
    np.testing.assert_array_equal(found, idx)
    assert np.all(np.abs(repl - y[idx]) <= 180.0 * (1 + 8 * sigma_lsb))  # the neighbours' median, not the spike


def test_lattice_median_is_the_grouped_median():
    """Grouped data: values 0, 1, 2 with 60 %, 30 %, 10 % of the samples; the cell of 0 is [0, ½), of 1 [½, 3/2):
    the median is at 0.5/0.6·½ = 5/12. Unquantised data: within half a spacing of the plain median."""
    a = np.r_[np.zeros(60), np.ones(30), 2 * np.ones(10)]
    assert glitch.lattice_median(a) == pytest.approx(5 / 12, rel=1e-9)
    x = np.abs(np.random.default_rng(0).standard_normal(10001))
    s = np.sort(x)
    k = np.searchsorted(s, np.median(x))
    assert abs(glitch.lattice_median(x) - np.median(x)) <= (s[k + 1] - s[k - 1]) / 2
    assert glitch.lattice_step(180.0 * np.round(x * 3)) == pytest.approx(180.0, rel=1e-9)
