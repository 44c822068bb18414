"""Glitches of a static rate log — spikes and stuck (repeated) values — found, reported and masked, so that a few
bad samples do not create noise terms (issue 25).

**Spikes.** A sample whose distance from the running median of its neighbours (window 2·:data:`SPIKE_HALF_WINDOW`
+ 1) exceeds :data:`SPIKE_Z` robust standard deviations (1.4826 × the median absolute deviation of those
distances). For Gaussian noise a sample crosses 8 σ with probability 1.2e-15: no false spike in any record we
could hold; a Gauss–Markov or random-walk drift slower than the window moves the median with it.

**Stuck stretches.** A run of identical consecutive values longer than chance allows: with p the fraction of
neighbouring samples that are equal anywhere in the segment (quantised logs repeat values), a run of L equal
values happens by chance with probability about n·p^(L−1); a run is stuck when that is below
:data:`STUCK_FALSE_RATE` (and L ≥ :data:`STUCK_MIN_RUN`).

**Masking.** A spike is replaced by the running median at its place (one sample: cutting the log there would
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
"""Half-width of the running median, samples."""

STUCK_FALSE_RATE = 1e-3
"""Chance probability below which a run of repeated values is called stuck."""

STUCK_MIN_RUN = 5
"""Shortest stuck run, samples."""

MIN_PIECE = 16
"""Shortest piece kept after masking, samples."""


def spikes(y) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the spikes of one rate series (module doc) and the running median there (their replacement,
    in the units of the series)."""
    y = np.asarray(y, float)
    if len(y) < 2 * SPIKE_HALF_WINDOW + 2:
        return np.zeros(0, int), np.zeros(0)
    med = ndimage.median_filter(y, size=2 * SPIKE_HALF_WINDOW + 1, mode="nearest")
    d = y - med
    scale = 1.4826 * np.median(np.abs(d - np.median(d)))
    if not scale > 0:
        return np.zeros(0, int), np.zeros(0)
    idx = np.flatnonzero(np.abs(d) > SPIKE_Z * scale)
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
        "glitches: " + "; ".join(parts) + f": spikes replaced by the running median, stuck stretches cut out "
        f"({report['samples_dropped']} samples), the {report['pieces']} pieces analysed separately and pooled "
        "(or --robust: the robust wavelet variance, unmasked)"
    )
