"""Synthetic series the tests and the studies share, written once: a circular 1/f rate series by FFT synthesis."""

import math

import numpy as np

from gyrojax.noise.spec import BI_FACTOR


def one_over_f(rng: np.random.Generator, n: int, b2: float) -> np.ndarray:
    """A circular series (deg/h) of per-sample spectrum b²/(2 ln 2 |f|), DC removed: X_k = √(n S(f_k)) Z_k, the
    Nyquist term real. Its Haar wavelet variance is the flat floor b² (:func:`gyrojax.noise.gmwm_model.wv_flicker`)."""
    f = np.fft.rfftfreq(n)
    s = np.zeros_like(f)
    s[1:] = b2 / (2.0 * math.log(2.0) * f[1:])
    z = (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)) / math.sqrt(2.0)
    z[-1] = rng.normal()
    return np.fft.irfft(np.sqrt(n * s) * z, n)


def floor_b2(b: float) -> float:
    """The floor b² of a flicker of bias instability B = ``b`` deg/h: b² = (ln 2/π)·B² (IEEE 952's Allan floor
    (0.664 B)² halved), the ``b2`` of :func:`one_over_f`."""
    return (BI_FACTOR * b) ** 2 / 2.0


def plant_spikes(y: np.ndarray, k: int, seed: int = 1, size: float = 50.0, margin: int = 1000) -> np.ndarray:
    """``y`` with ``k`` spikes of ±``size``σ planted (random signs and places, none within ``margin``
    samples of the ends), σ the white noise per sample read off the first differences, std(Δy)/√2."""
    rng = np.random.default_rng(seed)
    n = len(y)
    sigma = np.std(np.diff(y)) / math.sqrt(2)
    z = np.array(y, dtype=float)
    z[rng.choice(np.arange(margin, n - margin), k, replace=False)] += size * sigma * rng.choice([-1.0, 1.0], k)
    return z
