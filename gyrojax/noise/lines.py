"""Spectral lines in a static rate record: narrow peaks of the Welch power spectral density above its smooth local
level, each named with its frequency, its sinusoid amplitude and the averaging times τ of the Allan deviation it
reaches — a sinusoid, which no term of the noise-model family is.

**Estimate.** The record's segments are cut into Hann-windowed pieces of ``nperseg`` samples overlapping by half
(Welch 1967; ``scipy.signal.spectrogram``, each piece's mean removed), their one-sided density periodograms
p_s(f_k) averaged: P_k (series unit²/Hz). Bin spacing Δf = 1/(nperseg·τ0) Hz.

**Null law.** For a Gaussian process whose spectrum S is smooth over a few bins, P_k ≈ S_k·χ²_ν/ν with the Welch
equivalent degrees of freedom ν = 2K/(1 + 2Σ_{j≥1}(1 − j/K)ρ_j) of K pieces, ρ_j = (Σ_t w_t w_{t+jD})²/(Σ_t w_t²)²
the correlation of periodograms j pieces apart (D = nperseg/2; Percival & Walden 1993, eq. 292b; 1/36 for Hann at
half overlap). The local level is L_k = median of P_j over the bins 3 … 2 + M_k away on either side (the two nearest
on each side, where the Hann lobe of a line at k lies, are left out; M_k = min(16, ⌊k/2⌋ − 2), so the window spans
at most ±50 % of f_k and a 1/f or 1/f² slope moves the median by a few per cent only; bins with M_k < 4 are not
tested). Ŝ_k = L_k/c_ν, c_ν the median of χ²_ν/ν, estimates S_k; by the asymptotic law of a sample median
(var ≈ var(mean of 1{X_j ≤ c})/f(c)², f the density of χ²_ν/ν, the indicators' covariance asin(r)/(2π) for
periodogram correlation r between bins — 4/9 one bin apart for Hann, 1/36 two apart, 0 beyond) Ŝ_k/S_k ≈ χ²_{ν_L}/ν_L
with ν_L = 2c_ν²/var(median). Bins three or more apart are uncorrelated for white noise, so the statistic
R_k = P_k/Ŝ_k follows F(ν, ν_L) under the null, and a bin is a line when its p-value is below α/N over the N bins
tested (Bonferroni: family-wise false-line rate ≤ α per record, :data:`LEVEL` = 0.01). Flagged bins within two of
one another are one line.

The F law's χ² tail is light by 15–30 % at p ≈ 5e-6, so a bin it puts within 100·α/N is decided by the exact law
of the Welch average of a white series, S·Σ_j μ_j E_j (:func:`piece_weights`), against the level's χ²_{ν_L}: the
saddlepoint tail of the difference (:func:`ratio_sf`).

**Calibration** (``benchmarks/study_spectral_lines.py``, 1000 line-free records of 2^16 samples each, binomial sd
0.003): at α = 0.01 false lines on 9 (white), 14 (white + Gauss–Markov), 9 (white + random walk) and 9 (white +
1/f) per 1000; at α = 0.05 on 46, 46, 43, 50 per 1000.

**Amplitude.** A sinusoid A·sin(2πf₀t + φ) puts its power A²/2 into the Hann lobe (Σ_k P_k·Δf = A²/2, Parseval
with the density scaling); over the five bins k* − 2 … k* + 2 around the peak the excess is
Ē = Σ_j (P_j − Ŝ_{k*})·Δf, and A = √(2·Ē/γ), γ the lobe's share of a tone at the estimated offset from k* (≥ 0.99
for Hann). Its standard error: var(Ē) of the tone of that A and f₀ in white noise of density Ŝ, exact for the
Gaussian quadratic form (:func:`lobe_sum_variance`: the pieces' DFTs at those bins, their covariance within a piece
and between pieces that overlap by half, and the tone's cross term), plus (5·Δf·Ŝ)²·2/ν_L for the level;
se(A) = se(Ē)/(γA). The frequency is the excess power's centroid over those bins.

**Allan variance of a line** (IEEE Std 952-1997 and NIST SP 1065 §5.2: a sinusoidal rate of amplitude A averaged
over τ): σ²(τ) = A² sin⁴(πf₀τ)/(πf₀τ)², largest at τ = 0.371/f₀ (tan x = 2x, x = πf₀τ = 1.1656) where σ = 0.725·A,
and 0 at τ = k/f₀. A line *reaches* the τ where its Allan variance (above the peak, its falling envelope, the
largest value at any longer τ) exceeds the standard error σ̂²(τ)·√(2/EDF) of the record's own Allan variance
(:func:`tau_reach`): there it is more than the curve's noise, and a model without a sinusoid cannot follow it.
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax import tails

LEVEL = 0.01
"""Family-wise false-line rate per record (Bonferroni over the bins tested), dimensionless."""

GUARD = 2
"""Bins on either side of the tested one left out of its local level (the Hann main lobe spans ±2 bins)."""

HALF_WINDOW = 16
"""Largest number of bins on either side (beyond the guard) whose median is the local level."""

MIN_HALF_WINDOW = 4
"""Fewest bins on either side for a bin to be tested."""

MAX_SPAN = 0.5
"""Largest (guard + half window)/k: the level's window spans at most ±50 % of the tested frequency."""

MIN_PIECES = 31
"""Fewest Welch pieces (K): with half overlap ν ≈ 1.9K ≥ 59 degrees of freedom per bin."""

NPERSEG_RANGE = (256, 65536)
"""Shortest and longest Welch piece, samples."""

LOBE = 2
"""Bins on either side of a line's peak summed into its power."""

X_PEAK = 1.1655611852072113
"""The root of tan x = 2x: the Allan variance sin⁴x/x² of a line is largest at x = πf₀τ = X_PEAK, dimensionless."""


def line_avar(f0_hz: float, amplitude: float, taus_s) -> np.ndarray:
    """Allan variance of the rate A·sin(2πf₀t + φ) (any φ, A = ``amplitude`` in the series unit) at averaging times
    ``taus_s`` s: A² sin⁴(πf₀τ)/(πf₀τ)² (IEEE 952; NIST SP 1065 §5.2), in the series unit squared."""
    x = math.pi * f0_hz * np.asarray(taus_s, float)
    return amplitude**2 * np.sin(x) ** 4 / x**2


def line_avar_envelope(f0_hz: float, amplitude: float, taus_s) -> np.ndarray:
    """The line's Allan variance (:func:`line_avar`, series unit squared) up to its peak at τ = X_PEAK/(πf₀) s, and
    beyond it the largest value at any longer τ: A²/x² at the local maxima, so that its zeros at τ = k/f₀ (which
    move with f₀) count as reached."""
    taus = np.asarray(taus_s, float)
    x = math.pi * f0_hz * taus
    tau_peak = X_PEAK / (math.pi * f0_hz)
    rising = line_avar(f0_hz, amplitude, np.minimum(taus, tau_peak))
    # beyond the peak the local maxima of sin⁴x/x² lie at x ≈ (k + 1/2)π; bound by A²/x², capped at the peak value
    falling = np.minimum(amplitude**2 / np.maximum(x, 1e-300) ** 2, line_avar(f0_hz, amplitude, tau_peak))
    return np.where(x <= X_PEAK, rising, falling)


def tau_reach(f0_hz: float, amplitude: float, taus_s, avar, edf) -> list | None:
    """[τ_lo, τ_hi] s: the contiguous run of ``taus_s`` around the line's Allan-variance peak where its envelope
    (:func:`line_avar_envelope`) exceeds the standard error avar·√(2/edf) of the curve's Allan variance ``avar``
    (series unit squared, ``edf`` its equivalent degrees of freedom); None where it exceeds it at no τ."""
    taus = np.asarray(taus_s, float)
    se = np.asarray(avar, float) * np.sqrt(2.0 / np.asarray(edf, float))
    env = line_avar_envelope(f0_hz, amplitude, taus)
    above = env > se
    if not above.any():
        return None
    i = int(np.argmax(env / se))
    lo = i
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = i
    while hi < len(taus) - 1 and above[hi + 1]:
        hi += 1
    return [float(taus[lo]), float(taus[hi])]


def choose_nperseg(lengths) -> int | None:
    """The longest power-of-two Welch piece (samples, within :data:`NPERSEG_RANGE`) that gives at least
    :data:`MIN_PIECES` half-overlapping pieces over the segments of ``lengths`` samples; None when none does."""
    lo, hi = NPERSEG_RANGE
    best = None
    nper = lo
    while nper <= hi:
        if n_pieces(lengths, nper) >= MIN_PIECES:
            best = nper
        nper *= 2
    return best


def n_pieces(lengths, nperseg: int) -> int:
    """Number of half-overlapping Welch pieces of ``nperseg`` samples in segments of ``lengths`` samples."""
    step = nperseg // 2
    return int(sum((n - nperseg) // step + 1 for n in lengths if n >= nperseg))


def overlap_correlations(window: np.ndarray, step: int) -> np.ndarray:
    """ρ_j = (Σ_t w_t w_{t+j·step})²/(Σ_t w_t²)², j = 1, 2, …, while the pieces overlap: the correlation of the
    periodograms of pieces j apart, for a white series (dimensionless)."""
    w = np.asarray(window, float)
    e = float(w @ w)
    out = []
    j = 1
    while j * step < len(w):
        out.append(float(w[: len(w) - j * step] @ w[j * step :]) ** 2 / e**2)
        j += 1
    return np.array(out)


def welch_edf(k_pieces: int, rho: np.ndarray) -> float:
    """Welch's equivalent degrees of freedom 2K/(1 + 2Σ_j (1 − j/K) ρ_j) of K averaged pieces (Percival & Walden
    1993, eq. 292b), dimensionless."""
    j = np.arange(1, len(rho) + 1)
    keep = j < k_pieces
    return 2.0 * k_pieces / (1.0 + 2.0 * float(np.sum((1.0 - j[keep] / k_pieces) * rho[keep])))


def bin_correlations(window: np.ndarray, lags: int) -> np.ndarray:
    """Correlation |Σ_t w_t² e^{−2πi d t/L}|²/(Σ_t w_t²)² of a windowed periodogram's bins d = 0 … ``lags`` apart,
    for a white series (dimensionless; Hann: 1, 4/9, 1/36, 0 …)."""
    w2 = np.asarray(window, float) ** 2
    f = np.fft.rfft(w2)
    return np.abs(f[: lags + 1]) ** 2 / abs(f[0]) ** 2


def level_edf(nu: float, offsets: np.ndarray, rbin: np.ndarray) -> float:
    """ν_L of the local level: Ŝ/S ≈ χ²_{ν_L}/ν_L for the median of the periodogram bins at ``offsets`` (bins,
    relative to the tested one) with bin correlations ``rbin`` (:func:`bin_correlations`), each bin χ²_ν/ν
    (module doc), dimensionless."""
    d = np.abs(offsets[:, None] - offsets[None, :])
    r = np.where(d < len(rbin), rbin[np.minimum(d, len(rbin) - 1)], 0.0)
    cov = np.arcsin(np.clip(r, -1.0, 1.0)) / (2.0 * math.pi)
    np.fill_diagonal(cov, 0.25)
    n = len(offsets)
    var_ind = float(cov.sum()) / n**2
    c = tails.chi2_ppf(0.5, nu) / nu
    dens = tails.chi2_pdf(c * nu, nu) * nu
    var_med = var_ind / dens**2
    return 2.0 * c**2 / var_med


def piece_weights(lengths, nperseg: int, window: np.ndarray) -> np.ndarray:
    """μ_j: the Welch average at a bin of a white series is S·Σ_j μ_j E_j, E_j independent unit exponentials, with
    μ the eigenvalues of the pieces' DFT correlation matrix divided by K (dimensionless; pieces of one segment a
    tridiagonal Toeplitz block of off-diagonal Σ_t w_t w_{t+D}/Σ_t w_t², D = nperseg/2, pieces of different
    segments independent)."""
    step = nperseg // 2
    w = np.asarray(window, float)
    a = float(w[: len(w) - step] @ w[step:]) / float(w @ w)
    mus = []
    for n in lengths:
        if n < nperseg:
            continue
        k = (n - nperseg) // step + 1
        j = np.arange(1, k + 1)
        mus.append(1.0 + 2.0 * a * np.cos(math.pi * j / (k + 1)))  # eigenvalues of the tridiagonal Toeplitz block
    mu = np.concatenate(mus)
    return mu / mu.size


def ratio_sf(r: float, mu: np.ndarray, nu_l: float) -> float:
    """P(Q ≥ r·V) for Q = Σ_j μ_j E_j (:func:`piece_weights`) and an independent V ~ χ²_{ν_L}/ν_L (the level):
    the saddlepoint (Lugannani–Rice 1980) tail of Y = Q − rV at 0, its cumulant generating function
    K(s) = −Σ_j ln(1 − μ_j s) − (ν_L/2)·ln(1 + 2rs/ν_L) (dimensionless)."""
    from scipy.optimize import brentq

    b = nu_l / 2.0

    def k0(s):
        return -np.sum(np.log1p(-mu * s)) - b * math.log1p(r * s / b)

    def k1(s):
        return float(np.sum(mu / (1.0 - mu * s))) - r / (1.0 + r * s / b)

    def k2(s):
        return float(np.sum((mu / (1.0 - mu * s)) ** 2)) + r**2 / b / (1.0 + r * s / b) ** 2

    hi = (1.0 / mu.max()) * (1 - 1e-12)  # K is finite for −b/r < s < 1/max μ; the root is in (0, hi)
    if k1(0.0) >= 0.0:  # the mean of Y ≥ 0: not in the upper tail
        return 1.0
    s = brentq(k1, 1e-300, hi, xtol=1e-14, maxiter=500)
    w = math.sqrt(max(2.0 * (0.0 - k0(s)), 0.0))
    u = s * math.sqrt(k2(s))
    if w < 1e-6:  # the saddlepoint at the mean: the formula's limit is ½
        return 0.5
    return float(min(1.0, max(tails.norm_sf(w) + tails.norm_pdf(w) * (1.0 / u - 1.0 / w), 0.0)))


def periodograms(segments, tau0: float, nperseg: int):
    """(f Hz, p): the Hann-windowed, half-overlapping pieces' one-sided density periodograms p (bins × pieces,
    series unit²/Hz) of every segment at least ``nperseg`` samples long, sampled at ``tau0`` s."""
    from scipy.signal import spectrogram

    out, f = [], None
    for s in segments:
        s = np.asarray(s, float)
        if len(s) < nperseg:
            continue
        f, _, p = spectrogram(
            s, fs=1.0 / tau0, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant"
        )
        out.append(p)
    return f, np.concatenate(out, axis=1)


def lobe_share(window: np.ndarray, offset: float) -> float:
    """Share of a tone's power (dimensionless) that falls in the 2·:data:`LOBE` + 1 bins around the bin nearest to
    it, for a tone ``offset`` bins (|offset| ≤ ½) from that bin, with this window."""
    n = len(window)
    t = np.arange(n)
    x = np.abs(np.fft.fft(window * np.exp(2j * math.pi * (offset + n // 4) * t / n))) ** 2
    k = n // 4
    return float(x[k - LOBE : k + LOBE + 1].sum() / x.sum())


def find_lines(segments, tau0: float, level: float = LEVEL, nperseg: int | None = None) -> dict:
    """Search the rate series ``segments`` (series unit, e.g. deg/h; sampled at ``tau0`` s) for spectral lines
    (module doc). Returns ``searched`` (False with ``reason`` when the record is too short for
    :data:`MIN_PIECES` pieces of 256 samples), the Welch settings (``nperseg``, ``pieces``, ``edf``,
    ``resolution_hz``), the band tested (``band_hz``), ``bins_tested``, ``level`` and ``threshold_p`` (α/N), and
    ``lines``: per line ``frequency_hz``, ``amplitude`` and ``amplitude_std`` (sinusoid amplitude, series unit),
    ``power_ratio`` (P/Ŝ at the peak bin), ``p_value`` (per bin, under F(ν, ν_L)) and ``p_family`` (× N, capped at
    1), strongest first."""
    from scipy.signal import get_window

    lengths = [len(s) for s in segments]
    nper = nperseg or choose_nperseg(lengths)
    base = {"searched": False, "level": float(level), "lines": []}
    if nper is None or n_pieces(lengths, nper) < 2:
        need = MIN_PIECES * NPERSEG_RANGE[0] // 2
        return {
            **base,
            "reason": f"fewer than {MIN_PIECES} Welch pieces of {NPERSEG_RANGE[0]} samples ({need} samples)",
        }
    freqs, p = periodograms(segments, tau0, nper)
    k_pieces = p.shape[1]
    window = get_window("hann", nper)
    nu = welch_edf(k_pieces, overlap_correlations(window, nper // 2))
    rbin = bin_correlations(window, GUARD + 1)
    pw = p.mean(axis=1)
    df = float(freqs[1] - freqs[0])
    nb = len(freqs)
    c_nu = tails.chi2_ppf(0.5, nu) / nu
    half = np.minimum(HALF_WINDOW, np.floor(MAX_SPAN * np.arange(nb)).astype(int) - GUARD)
    top = nb - 1 - GUARD - HALF_WINDOW
    tested = np.flatnonzero((half >= MIN_HALF_WINDOW) & (np.arange(nb) <= top))
    if not tested.size:
        return {**base, "nperseg": int(nper), "reason": "no bin has a full local window"}
    s_hat = np.full(nb, np.nan)
    nu_l = np.full(nb, np.nan)
    for m in np.unique(half[tested]):
        ks = tested[half[tested] == m]
        offs = np.concatenate([np.arange(-GUARD - m, -GUARD), np.arange(GUARD + 1, GUARD + m + 1)])
        nu_l[ks] = level_edf(nu, offs, rbin)
        s_hat[ks] = np.median(pw[ks[:, None] + offs[None, :]], axis=1) / c_nu
    with np.errstate(divide="ignore", invalid="ignore"):  # a level of 0 (a constant stretch) tests nothing
        stat = np.where(s_hat > 0, pw / s_hat, 0.0)
    pval = np.ones(nb)
    pval[tested] = tails.f_sf(stat[tested], nu, nu_l[tested])  # F(ν, ν_L): a light-tailed screen
    mu = piece_weights(lengths, nper, window)
    n_test = int(tested.size)
    for k in tested[pval[tested] <= 100.0 * level / n_test]:  # the exact weights' saddlepoint tail decides
        pval[k] = ratio_sf(float(stat[k]), mu, float(nu_l[k]))
    thr = level / n_test
    flagged = tested[pval[tested] <= thr]
    groups: list[list[int]] = []
    for k in flagged:
        if groups and k - groups[-1][-1] <= LOBE:
            groups[-1].append(int(k))
        else:
            groups.append([int(k)])
    lines = []
    for g in groups:
        k = g[int(np.argmax(stat[g]))]
        lines.append(_line(p, freqs, k, s_hat[k], df, nu_l[k], window, stat[k], pval[k], n_test, lengths, tau0))
    lines.sort(key=lambda ln: -ln["power_ratio"])
    return {
        **base,
        "searched": True,
        "nperseg": int(nper),
        "pieces": int(k_pieces),
        "edf": float(nu),
        "resolution_hz": df,
        "band_hz": [float(freqs[tested[0]]), float(freqs[tested[-1]])],
        "bins_tested": n_test,
        "threshold_p": float(thr),
        "lines": lines,
    }


def lobe_sum_variance(window, lengths, nperseg, bins, f0_hz, amplitude, level, tau0) -> float:
    """Variance of Σ_s Σ_j p_s(f_j) over the pieces s of segments of ``lengths`` samples and the ``bins`` j (indices
    into the one-sided grid) for a tone ``amplitude``·sin(2π·``f0_hz``·t) in white noise of one-sided density
    ``level`` (series unit²/Hz), sampled at ``tau0`` s; in series unit⁴/Hz².

    With Y_s = √(2τ0/Σw²)·DFT(w·x_s) at those bins, p_s = |Y_s|² and Y = y + Z (y the tone's, Z circular Gaussian
    of covariance C: S·G0 within a piece, S·G1 between pieces half overlapping, 0 otherwise), Var(Σ|Y|²) =
    tr(C²) + 2·yᴴCy (the quadratic and the linear part of |y + Z|² are uncorrelated)."""
    w = np.asarray(window, float)
    n = len(w)
    step = nperseg // 2
    t = np.arange(n)
    e2 = float(w @ w)
    basis = np.exp(-2j * math.pi * np.outer(bins, t) / n)  # bins × t
    g0 = (basis * w**2) @ basis.conj().T / e2
    g1 = (basis[:, step:] * (w[step:] * w[: n - step])) @ basis[:, : n - step].conj().T / e2
    beta = 2.0 * math.pi * f0_hz * tau0
    scale = math.sqrt(2.0 * tau0 / e2)
    u = (basis * (w * np.exp(1j * beta * t))) @ np.ones(n)
    v = (basis * (w * np.exp(-1j * beta * t))) @ np.ones(n)
    quad = lin = 0.0
    for length in lengths:
        if length < nperseg:
            continue
        k = (length - nperseg) // step + 1
        alpha = beta * step * np.arange(k)
        y = amplitude * scale * (np.exp(1j * alpha)[:, None] * u - np.exp(-1j * alpha)[:, None] * v) / 2j  # k × bins
        quad += k * float(np.sum(np.abs(g0) ** 2)) + 2 * (k - 1) * float(np.sum(np.abs(g1) ** 2))
        lin += float(np.real(np.einsum("sa,ab,sb->", y.conj(), g0, y)))
        if k > 1:
            lin += 2.0 * float(np.real(np.einsum("sa,ab,sb->", y[:-1].conj(), g1, y[1:])))
    return level**2 * quad + 2.0 * level * lin


def _line(p, freqs, k, s_hat, df, nu_l, window, ratio, pval, n_test, lengths, tau0) -> dict:
    """One line at peak bin ``k`` (module doc: centroid frequency, amplitude from the lobe's excess)."""
    j = np.arange(k - LOBE, k + LOBE + 1)
    j = j[(j >= 0) & (j < len(freqs))]
    excess = np.maximum(p[j, :].mean(axis=1) - s_hat, 0.0)
    f0 = float(excess @ freqs[j] / excess.sum()) if excess.sum() > 0 else float(freqs[k])
    offset = float(np.clip((f0 - freqs[k]) / df, -0.5, 0.5))
    share = lobe_share(window, offset)
    kk = p.shape[1]
    e_bar = float((p[j, :].mean(axis=1) - s_hat).sum()) * df  # the lobe's excess power, series unit²
    amp = math.sqrt(2.0 * max(e_bar, 0.0) / share)
    var_sum = lobe_sum_variance(window, lengths, len(window), j, f0, amp, s_hat, tau0)
    var_e = var_sum * df**2 / kk**2 + (len(j) * df * s_hat) ** 2 * 2.0 / nu_l
    amp_std = math.sqrt(var_e) / (share * amp) if amp > 0 else float("nan")  # A² = 2Ē/γ: dA = dĒ/(γA)
    return {
        "frequency_hz": f0,
        "amplitude": amp,
        "amplitude_std": amp_std,
        "power_ratio": float(ratio),
        "p_value": float(pval),
        "p_family": float(min(1.0, pval * n_test)),
    }


# ---- in the report of ``gyrojax noise`` -------------------------------------------------------------------------


def with_reach(search: dict, taus_s, avar, edf, unit: str) -> list[dict]:
    """The lines of ``search`` (:func:`find_lines`) as the report lists them: ``frequency_hz``, ``amplitude``,
    ``amplitude_std``, ``unit`` (the series unit, e.g. deg/h), ``power_ratio``, ``p_family``, the line's Allan
    deviation peak ``adev_peak`` (0.725·A, same unit) at ``tau_peak_s`` = 0.371/f₀ s, its first zero
    ``tau_zero_s`` = 1/f₀ s, and ``tau_range_s`` (:func:`tau_reach` over the curve's ``taus_s`` s, ``avar`` in the
    unit squared, ``edf``; None where it reaches no τ)."""
    out = []
    for ln in search.get("lines", []):
        f0, a = ln["frequency_hz"], ln["amplitude"]
        out.append(
            {
                "frequency_hz": f0,
                "amplitude": a,
                "amplitude_std": ln["amplitude_std"],
                "unit": unit,
                "power_ratio": ln["power_ratio"],
                "p_family": ln["p_family"],
                "adev_peak": float(a * math.sin(X_PEAK) ** 2 / X_PEAK),
                "tau_peak_s": float(X_PEAK / (math.pi * f0)),
                "tau_zero_s": float(1.0 / f0),
                "tau_range_s": tau_reach(f0, a, taus_s, avar, edf),
            }
        )
    return out


def describe(line: dict) -> str:
    """A line in words: its frequency (Hz), amplitude ± se in its unit and power ratio (dimensionless)."""
    return (
        f"a {line['frequency_hz']:.4g} Hz line of amplitude {line['amplitude']:.3g} ± {line['amplitude_std']:.2g} "
        f"{line['unit']} (PSD {line['power_ratio']:.3g}x its local level)"
    )


def note(found: list[dict], search: dict) -> str | None:
    """The sentence of the report's ``notes`` (frequencies in Hz, τ in s): the lines found (:func:`with_reach`) and
    what they do to the Allan deviation, or that the search could not be made; None when it was made and found
    none."""
    if not search.get("searched"):
        return f"spectral lines: not searched ({search.get('reason')})"
    if not found:
        return None
    parts = []
    for ln in found:
        r = ln["tau_range_s"]
        reach = (
            f"above the curve's standard error at tau {r[0]:.3g} to {r[1]:.3g} s"
            if r
            else "below the curve's standard error at every tau"
        )
        parts.append(
            f"{describe(ln)}: its Allan deviation peaks at {ln['adev_peak']:.3g} {ln['unit']} at tau = "
            f"{ln['tau_peak_s']:.3g} s, is 0 at {ln['tau_zero_s']:.3g} s and is {reach}"
        )
    lo, hi = search["band_hz"]
    return (
        f"spectral lines ({len(found)} found over {lo:.3g} to {hi:.3g} Hz at family-wise level {search['level']:g}): "
        + "; ".join(parts)
        + ". No term of the noise model is a sinusoid: near those tau the model cannot follow the curve"
    )


def cause(found: list[dict], taus_out_s) -> str:
    """The verdict's cause: the lines whose ``tau_range_s`` holds every τ (s) of ``taus_out_s`` ("within reach
    of …") or some of them ("partly within reach of …"); "" when none holds any."""
    t = np.asarray(taus_out_s, float)
    all_in, some_in = [], []
    for ln in found:
        r = ln.get("tau_range_s")
        if not r or not t.size:
            continue
        inside = (t >= r[0] * (1 - 1e-9)) & (t <= r[1] * (1 + 1e-9))
        if inside.all():
            all_in.append(ln)
        elif inside.any():
            some_in.append(ln)
    if all_in:
        return "within reach of " + " and ".join(describe(ln) for ln in all_in)
    if some_in:
        return "partly within reach of " + " and ".join(describe(ln) for ln in some_in)
    return ""
