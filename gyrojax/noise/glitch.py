"""Glitches of a static rate log — spikes and stuck (repeated) values — found, reported and masked, so that a few
bad samples do not create noise terms.

**Spikes.** A sample whose distance d_t = y_t − med_t from the median of its 2·:data:`SPIKE_HALF_WINDOW`
neighbours (the sample itself left out, so that neither the spike nor a tie with itself sets its reference)
exceeds :data:`SPIKE_Z` robust standard deviations plus one quantisation step q of the log. The robust σ is
1.4826 × the median absolute deviation of d, the median taken as that of grouped data (:func:`lattice_median`):
a quantised log's d sits on a lattice, where the plain median jumps between lattice values — more than half the
d exactly 0 at σ ≲ 0.7 q gives σ = 0 and a detector that finds nothing (the ADIS16405's accelerometer at 3.33 mg
steps: a 20 s stuck stretch tipped imu2 y there, and all 40 planted 50σ spikes passed), one step more gives
1.5 σ. Rounding y and its median moves d by at most q, hence the margin. For Gaussian noise a sample crosses
8 σ with probability 1.2e-15: no false spike in any record we could hold; a Gauss–Markov or random-walk drift
slower than the window moves the median with it. Heavier tails than Gaussian are flagged as what they are.

**Stuck stretches.** A run of identical consecutive values longer than chance allows: with p the fraction of
neighbouring samples that are equal anywhere in the segment (quantised logs repeat values), a run of L equal
values happens by chance with probability about n·p^(L−1); a run is stuck when that is below
:data:`STUCK_FALSE_RATE` (and L ≥ :data:`STUCK_MIN_RUN`).

**Masking.** A spike is replaced by the median of its neighbours (one sample: cutting the log there would
split it into pieces too short for the long τ). A stuck stretch is cut out and the pieces on either side analysed
as separate segments, pooled (a gap, exactly as the record's own gaps are); pieces shorter than
:data:`MIN_PIECE` samples are dropped. The Haar wavelet variance and the Allan variance of the pieces are then
those of the log without the glitches (no cut is bridged), so the noise terms are estimated without them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

SPIKE_Z = 8.0
"""Robust z above which a sample is a spike."""

SPIKE_HALF_WINDOW = 5
"""Neighbours on either side of a sample in its median (the sample itself left out), samples."""

STUCK_FALSE_RATE = 1e-3
"""Chance probability below which a run of repeated values is called stuck."""

STUCK_MIN_RUN = 5
"""Shortest stuck run, samples."""

MIN_PIECE = 16
"""Shortest piece kept after masking, samples."""


def lattice_step(x) -> float:
    """The step q of the lattice the values of ``x`` lie on (units of ``x``): the smallest gap between its
    distinct values, values within 1e-9 of its largest |value| taken as equal (0 for a constant series). For an
    unquantised series it is the smallest spacing of its values, i.e. about 0."""
    x = np.asarray(x, float)
    tol = 1e-9 * float(np.max(np.abs(x))) if len(x) else 0.0
    if not tol > 0:
        return 0.0
    _, first = np.unique(np.round(x / tol), return_index=True)
    return float(np.min(np.diff(x[first]))) if len(first) > 1 else 0.0  # the values themselves, in sorted order


def lattice_median(a) -> float:
    """Median of the non-negative values ``a`` read as grouped data (units of ``a``): each distinct value v_k holds
    the samples rounded to it, spread evenly over its cell from the midpoint to the value below (0 for the first)
    to the midpoint to the value above; the median is where that piecewise-linear distribution function is 1/2.
    Continuous in the data on a lattice (the plain median jumps a whole step there) and within half a spacing of
    the plain median for unquantised data."""
    a = np.asarray(a, float)
    tol = 1e-9 * float(np.max(a)) if len(a) else 0.0
    if not tol > 0:
        return 0.0
    u, c = np.unique(np.round(a / tol), return_counts=True)
    u = u * tol
    f = np.cumsum(c) / len(a)
    k = int(np.searchsorted(f, 0.5))
    if len(u) == 1:
        return float(u[0])
    lo = (u[k - 1] + u[k]) / 2.0 if k > 0 else max(0.0, u[0] - (u[1] - u[0]) / 2.0)
    hi = (u[k] + u[k + 1]) / 2.0 if k + 1 < len(u) else u[k] + (u[k] - u[k - 1]) / 2.0
    f_lo = f[k - 1] if k > 0 else 0.0
    return float(lo + (0.5 - f_lo) / (f[k] - f_lo) * (hi - lo))


def neighbour_median(y) -> np.ndarray:
    """Median of the 2·:data:`SPIKE_HALF_WINDOW` neighbours of each sample, itself left out (the mean of the two
    middle values; the ends mirrored as ``nearest``), units of ``y``."""
    fp = np.ones(2 * SPIKE_HALF_WINDOW + 1, bool)
    fp[SPIKE_HALF_WINDOW] = False
    r = SPIKE_HALF_WINDOW
    lo = ndimage.rank_filter(y, r - 1, footprint=fp, mode="nearest")
    hi = ndimage.rank_filter(y, r, footprint=fp, mode="nearest")
    return (lo + hi) / 2.0


def spikes(y) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the spikes of one rate series (module doc) and the median of their neighbours there (their
    replacement, in the units of the series)."""
    y = np.asarray(y, float)
    if len(y) < 2 * SPIKE_HALF_WINDOW + 2:
        return np.zeros(0, int), np.zeros(0)
    med = neighbour_median(y)
    d = y - med
    scale = 1.4826 * lattice_median(np.abs(d - np.median(d)))
    if not scale > 0:
        return np.zeros(0, int), np.zeros(0)
    idx = np.flatnonzero(np.abs(d) > SPIKE_Z * scale + lattice_step(y))
    return idx, med[idx]


def stuck_runs(y) -> list[tuple[int, int]]:
    """(start, end) index ranges (end exclusive) of the stuck stretches of one rate series (module doc; any
    units of the series)."""
    y = np.asarray(y, float)
    n = len(y)
    if n < STUCK_MIN_RUN:
        return []
    same = y[1:] == y[:-1]
    p = float(same.mean())
    if p <= 0.0:
        need = STUCK_MIN_RUN
    elif p >= 1.0:
        return [(0, n)]
    else:
        need = max(STUCK_MIN_RUN, 1 + math.ceil(math.log(STUCK_FALSE_RATE / n) / math.log(p)))
    edges = np.diff(np.concatenate([[0], same.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b) + 1) for a, b in zip(starts, ends) if b + 1 - a >= need]


def clean(segments, dt: float) -> tuple[list, dict]:
    """The segments with spikes replaced and stuck stretches cut out (module doc), and the report: ``spikes``
    (count and the first 20 as [segment, time s from its start]), ``stuck`` (count, total seconds, the first 20 as
    [segment, start s, length s]), ``pieces`` after masking and the samples dropped."""
    out, spike_at, stuck_at = [], [], []
    n_spikes = n_stuck = dropped = 0
    stuck_s = 0.0
    for j, s in enumerate(segments):
        s = np.array(s, float)
        bad = np.zeros(len(s), bool)
        idx, med = spikes(s)
        s[idx] = med
        n_spikes += len(idx)
        spike_at += [[j, float(i * dt)] for i in idx[: max(0, 20 - len(spike_at))]]
        for a, b in stuck_runs(s):
            bad[a:b] = True
            n_stuck += 1
            stuck_s += (b - a) * dt
            if len(stuck_at) < 20:
                stuck_at.append([j, float(a * dt), float((b - a) * dt)])
        if not bad.any():
            out.append(s)
            continue
        labels, k = ndimage.label(~bad)
        for lab in range(1, k + 1):
            piece = s[labels == lab]
            if len(piece) >= MIN_PIECE:
                out.append(piece)
            else:
                dropped += len(piece)
        dropped += int(bad.sum())
    report = {
        "spikes": {"count": n_spikes, "at": spike_at},
        "stuck": {"count": n_stuck, "seconds": stuck_s, "at": stuck_at},
        "pieces": len(out),
        "samples_dropped": dropped,
    }
    return out, report


def note(report: dict, masked: bool = True, robust: bool = False) -> str:
    """One sentence for ``notes``: what was found and how it was masked, or that it was not ("" when nothing);
    ``robust``: not masked, the model estimated by the robust wavelet variance (:mod:`gyrojax.noise.robust_wv`)."""
    sp, st = report["spikes"], report["stuck"]
    if not sp["count"] and not st["count"]:
        return ""
    parts = []
    if sp["count"]:
        where = ", ".join(f"{t:.6g} s" for _, t in sp["at"][:5]) + (" ..." if sp["count"] > 5 else "")
        parts.append(f"{sp['count']} spikes (at {where})")
    if st["count"]:
        where = ", ".join(f"{t:.6g} s for {d:.3g} s" for _, t, d in st["at"][:3]) + (" ..." if st["count"] > 3 else "")
        parts.append(f"{st['count']} stuck stretches, {st['seconds']:.3g} s in all ({where})")
    if robust:
        return (
            "glitches: " + "; ".join(parts) + ": not masked; the model is fitted to the robust wavelet variance, "
            "the empirical Allan deviation (and the curve read-offs) include them"
        )
    if not masked:
        return "glitches: " + "; ".join(parts) + ": NOT masked, the estimates include them"
    return (
        "glitches: " + "; ".join(parts) + ": spikes replaced by the median of their neighbours, stuck stretches "
        "cut out "
        f"({report['samples_dropped']} samples), the {report['pieces']} pieces analysed separately and pooled "
        "(or --robust: the robust wavelet variance, unmasked)"
    )
