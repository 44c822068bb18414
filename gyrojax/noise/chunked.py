"""The overlapping Allan variance at octave τ of a series too long to hold, accumulated over chunks.

A rate series y_k (any unit) sampled every τ0 s is fed in chunks; its angle θ_0 = 0, θ_{k+1} = θ_k + (y_k − c)τ0
(c the first chunk's mean: a constant the second differences cancel, kept only so that θ stays small) is never
held whole. For each octave m = 2^k the sums of NIST SP 1065 eq. 11,

    S(m) = Σ_i (θ_{i+2m} − 2θ_{i+m} + θ_i)²,   σ²(τ = mτ0) = S(m) / (2τ²M),

are accumulated over the second differences that close inside each chunk, each level keeping the last 2m angles
it has seen (its lag window) across the chunk boundary. For m ≤ 2^``exact_levels`` every i counts (M = n + 1 − 2m,
the full overlap: the sums equal ``allantools.oadev``'s to rounding); beyond, the level keeps the angles at every
D-th sample, D = m / 2^``exact_levels``, and sums the second differences at i = 0, D, 2D, … (M = ⌊(n − 2m)/D⌋ + 1):
an overlapping estimate whose neighbouring terms are 2^``exact_levels`` apart in a lag of m, which leaves its
variance that of the full overlap to well under a percent (the overlap's gain saturates once the step is a small
fraction of m; NIST SP 1065 §5.2.4). So the state is at most 2^(``exact_levels`` + 1) angles per level, about
log₂ n levels: memory flat in the record's length, each sample touched once per exact level.

Each level is born from its parent's window when the parent closes its first second difference (the parent then
holds every angle from the start), so no history is kept beyond the windows. Pure numpy; no file, no JAX.
"""

from __future__ import annotations

import numpy as np

EXACT_LEVELS = 14
"""Octave levels (m ≤ 2^14 = 16384 samples) summed at every i, the full overlap; longer ones at a step of
m / 2^14 samples."""


SUB_CHUNK = 2**16
"""Samples processed at a time inside :meth:`OctaveAllan.feed`, so that the angle buffer of every channel stays
in the processor's cache through the exact levels."""


def _second_difference_sums(w: np.ndarray, lag: int, lo: int, hi: int) -> np.ndarray:
    """Σ_{j = lo}^{hi − 1} (w_{j+2·lag} − 2 w_{j+lag} + w_j)² per row of ``w`` (channels, length)."""
    d = w[:, lo + 2 * lag : hi + 2 * lag] - w[:, lo + lag : hi + lag]
    d -= w[:, lo + lag : hi + lag]
    d += w[:, lo:hi]
    return np.einsum("ij,ij->i", d, d)


class _Strided:
    """One octave m = 2^k beyond the exact levels: its angles at every ``step``-th sample (the window: the last
    2·``lag`` of them, or every one before its first second difference closes; new ones wait in ``pending`` until
    there are ``lag`` of them), its running sums (per channel) and count."""

    def __init__(self, k: int, exact_levels: int, history: np.ndarray):
        self.k = k
        self.m = 2**k
        self.step = 2 ** (k - exact_levels)
        self.lag = self.m // self.step
        self.window = history  # (channels, j)
        self.pending: list = []
        self.waiting = 0
        self.sums = np.zeros(history.shape[0])
        self.count = 0

    def add(self, angles: np.ndarray):
        """Queue angles (channels, j) at this level's step; :meth:`flush` once ``lag`` of them wait."""
        if angles.shape[1]:
            self.pending.append(angles.copy())
            self.waiting += angles.shape[1]
        return self.flush() if self.waiting >= self.lag else None

    def flush(self):
        """Close the second differences the window and the queue hold, keep the last 2·lag angles. Returns every
        angle from the start (channels, j) when this closed the level's first second difference (the next level is
        born from them), else None."""
        w = np.concatenate([self.window, *self.pending], axis=1) if self.pending else self.window
        self.pending, self.waiting = [], 0
        span = w.shape[1] - 2 * self.lag
        if span <= 0:
            self.window = w
            return None
        first = self.count == 0
        self.sums += _second_difference_sums(w, self.lag, 0, span)
        self.count += span
        self.window = w[:, -2 * self.lag :].copy()
        return w if first else None


class OctaveAllan:
    """Overlapping Allan variance sums at octave m of ``channels`` series fed in chunks (module doc).

    ``feed(y)`` with y (c, channels) (any c ≥ 1, in order); :meth:`result` the averaging factors, variances, counts
    and the number of samples. The exact levels share one buffer of the last 2^(exact_levels + 1) angles per
    channel; each level beyond keeps its own window of 2^(exact_levels + 1) angles at its step."""

    def __init__(self, tau0: float, channels: int = 1, exact_levels: int = EXACT_LEVELS):
        if not (np.isfinite(tau0) and tau0 > 0):
            raise ValueError(f"tau0 must be a positive number of seconds, got {tau0!r}")
        self.tau0 = float(tau0)
        self.channels = int(channels)
        self.exact_levels = int(exact_levels)
        self.n = 0
        self.offset = None
        self.history = np.zeros((self.channels, 1))  # θ_0 = 0, then the last 2^(E+1) angles
        self.sums = np.zeros((self.exact_levels + 1, self.channels))
        self.counts = np.zeros(self.exact_levels + 1, dtype=np.int64)
        self.strided = [_Strided(self.exact_levels + 1, self.exact_levels, self.history.copy())]

    def feed(self, y) -> None:
        """Add the next samples, (c, channels) or (c,) for one channel."""
        y = np.asarray(y, dtype=np.float64)
        if y.ndim == 1:
            y = y[:, None]
        if y.ndim != 2 or y.shape[1] != self.channels:
            raise ValueError(f"expected {self.channels} channels, got shape {y.shape}")
        if not len(y):
            return
        if self.offset is None:
            self.offset = y.mean(axis=0)
        for s in range(0, len(y), SUB_CHUNK):
            self._feed(y[s : s + SUB_CHUNK])

    def _feed(self, y: np.ndarray) -> None:
        theta = (y - self.offset).T * self.tau0
        np.cumsum(theta, axis=1, out=theta)
        theta += self.history[:, -1:]
        first = self.n + 1  # the global index of theta[:, 0]
        self.n += y.shape[0]
        h = self.history.shape[1]
        buf = np.concatenate([self.history, theta], axis=1)
        for k in range(self.exact_levels + 1):
            m = 2**k
            lo, hi = max(h - 2 * m, 0), buf.shape[1] - 2 * m  # the second differences whose last angle is new
            if hi > lo:
                self.sums[k] += _second_difference_sums(buf, m, lo, hi)
                self.counts[k] += hi - lo
        self.history = buf[:, -(2 ** (self.exact_levels + 1)) :].copy()
        for i in range(len(self.strided)):  # the levels born below receive no angle of this chunk: they hold them
            lev = self.strided[i]
            everything = lev.add(theta[:, (-first) % lev.step :: lev.step])
            if everything is not None and i == len(self.strided) - 1:
                self._born(everything)

    def _born(self, everything: np.ndarray) -> None:
        """The next strided level (and the ones after it, while each closes a difference at birth), from every angle
        of the last level so far."""
        while everything is not None:
            last = self.strided[-1]
            child = _Strided(last.k + 1, self.exact_levels, everything[:, ::2].copy())
            self.strided.append(child)
            everything = child.flush()

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """(m, σ² per level and channel (L, channels) in the input unit², second differences M per level, the
        number of samples n): the levels that closed at least one second difference."""
        for i in range(len(self.strided)):
            everything = self.strided[i].flush()
            if everything is not None and i == len(self.strided) - 1:
                self._born(everything)
        m = [2**k for k in range(self.exact_levels + 1)] + [lev.m for lev in self.strided]
        counts = np.concatenate([self.counts, [lev.count for lev in self.strided]]).astype(float)
        sums = np.vstack([self.sums, *[lev.sums[None, :] for lev in self.strided]])
        keep = counts > 0
        m = np.asarray(m, dtype=np.int64)[keep]
        tau = m * self.tau0
        return m, sums[keep] / (2.0 * (tau * tau * counts[keep])[:, None]), counts[keep], self.n


def pooled(results, tau0: float):
    """Pool the :meth:`OctaveAllan.result` of independent pieces of one channel (each (m, σ² (L,), M, n)) as
    :func:`gyrojax.noise.allan.allan` pools segments: σ²(τ) = Σ_j M_j σ²_j / Σ_j M_j over the pieces that reach
    that m. Returns (:class:`~gyrojax.noise.allan.AllanResult` at the octave τ = m·τ0 with 2m ≤ n_max − 1, its EDF
    that of the full overlap, :class:`~gyrojax.noise.gmwm.WaveletVariance` at the dyadic m ≤ n_max/8): the
    variances of a record never held."""
    from gyrojax.noise.allan import AllanError, AllanResult, noise_alpha
    from gyrojax.noise.gmwm import WaveletVariance
    from gyrojax.noise.wavelet import dyadic_m

    lengths = tuple(int(r[3]) for r in results)
    n_max = max(lengths)
    if n_max < 16:
        raise AllanError(f"need at least 16 samples for a noise model, got {n_max}")
    m_all = 2 ** np.arange(int(np.log2(max(n_max // 2, 1))) + 1)
    num, dens = np.zeros(len(m_all)), np.zeros(len(m_all))
    full = np.zeros(len(m_all))  # the full overlap's count: the strided sums carry its information
    for m, avar, counts, n in results:
        idx = np.searchsorted(m_all, m)
        num[idx] += avar * counts
        dens[idx] += counts
        full[idx] += n + 1 - 2 * m
    ok = dens > 0
    avar = np.where(ok, num / np.where(ok, dens, 1.0), 0.0)
    curve = ok & (2 * m_all <= n_max - 1)
    m_c = m_all[curve]
    taus = m_c * tau0
    adev = np.sqrt(avar[curve])
    if not np.any(adev > 0):
        raise AllanError("the Allan variance is zero at every tau (to rounding): the rate series is constant")
    one = np.ones(len(m_c))
    res = AllanResult(taus, adev, adev, adev, one, np.zeros(len(m_c), int), m_c, full[curve], lengths)
    res = res.with_alpha(noise_alpha(taus, avar[curve]))
    dy = np.isin(m_all, dyadic_m(n_max)) & ok & (full > 0)
    est = WaveletVariance(m_all[dy], avar[dy] / 2.0, full[dy], float(tau0), int(sum(lengths)))
    return res, est
