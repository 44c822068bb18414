"""One set of headline noise figures: the IEEE 952 read-offs of the Allan curve and of the fitted model, side by
side, each with its standard error and the τ where it was read, and a note wherever the two disagree.

Curve read-offs (IEEE 952-1997 annex C, conventions §6 units), from the overlapping Allan deviation σ(τ) and its
±1σ χ² interval (:class:`~gyrojax.noise.allan.AllanResult`), in the τ ranges where the local slope of σ is within
``SLOPE_TOL`` of the term's:

- N (deg/√h), slope −½: σ(τ)·√τ/60 at the point of the range nearest τ = 1 s (the −½ line's value at 1 s);
- B (deg/h), the flat minimum: σ_min/0.664 (:data:`~gyrojax.noise.spec.BI_FACTOR`) at an interior minimum of σ
  where the local slope is flat (within ``SLOPE_TOL`` of 0), the minimum taken over the τ where σ is known to
  ``B_MAX_HALF_WIDTH`` (all τ when fewer than 3 are), σ_min that of a local fit of the white, flat and
  random-walk terms around the smallest σ (:func:`_flat_minimum`; the smallest noisy σ alone is biased low);
  when σ still falls there (a noisy dip of a falling curve, or the last such τ), an upper bound σ_bound/0.664 at
  the minimum (below);
- K (deg/h/√h), slope +½: σ(τ)·√(3·3600/τ) at the longest τ of the range, its ``ci``'s lower end times
  √min(μ, 1), μ = 2·(local slope of σ) that of σ² at τ (the read-off's bias bound: every other term adds to σ², so
  σ(τ)·√(3·3600/τ) ≥ K; a term whose σ² does not rise there (white, flat, quantization, a Gauss–Markov beyond its
  peak) leaves the random walk a share p = (μ − s)/(1 − s) ≥ μ of σ², s ≤ 0 its slope, so K ≥ √μ·the read-off;
  the χ² interval alone missed K on the high side only, 32 and 43 times in 705 and 700 reads of 1000 simulated
  white + GM + RW and white + RW records, coverage 0.955 and 0.931 → 0.970 and 0.951 with the bound,
  ``benchmarks/study_noise_readoff_coverage.py --curve-only --draws 1000 --truth wgr wr``); when no such range
  is seen, the upper bound
  σ_bound(τ_max)·√(3·3600/τ_max) (a random walk of that size would reach the bound of σ at the longest τ);
- Q (arcsec), slope −1: σ(τ)·τ/√3; R (deg/h/h), slope +1: σ(τ)·√2·3600/τ; only where the slope is seen.

The standard error of a curve read-off is that of σ at its τ (half the width of the ±1σ interval), scaled; its
``ci`` the χ² interval of σ there at the ±2σ level (:data:`TWO_SIGMA`, NIST SP 1065 eq. 45 with the EDF of
:mod:`gyrojax.noise.allan`), scaled, with ``ci_level``. The interval, not value ± 2σ, is the figure's
uncertainty: σ̂ is a scale estimate (χ² with few EDF at long τ), and ±2σ misses on the low side
(benchmarks/study_noise_readoff_coverage.py).

**Upper bounds** (``kind`` "upper bound", ``value`` the bound, ``bound_level`` its one-sided level, ``bound_ratio``
the bound of σ over σ̂ at ``tau_s``, no ``ci``)
are one-sided at :data:`BOUND_LEVEL` = (1 + 0.9545)/2, the level of the ±2σ interval's upper end, *given that
the bound is issued*. A bound is issued because the curve ran low where it is taken (K: no +½ slope was seen
near τ_max; B: the curve still falls at its smallest σ, the minimum of the noisy σ̂ over the τ it was chosen
among), so the χ² bound of σ at that one τ holds less often than its level (the ±1σ high end held in 0.44–0.57
of the K bounds and 0.60–0.64 of the B bounds on the study's truths). The bound is the χ² bound of σ at the
Bonferroni level 1 − (1 − :data:`BOUND_LEVEL`)/J, J the τ the bound's τ stood among (``looks``: the τ of the
local-slope window at τ_max for K, those of the flat-minimum fit window for B): the event that σ_high < σ_true
at the selected τ lies in the union of those events at the J τ, each of probability (1 − level)/J (exact for B,
whose τ is the argmin over them; for K, whose τ is fixed, a guard against the same conditioning, checked by the
study). A bound on σ bounds the figure by IEEE 952 C.1: K·√(τ/10800) ≤ σ(τ) at every τ, and 0.664·B = min σ ≤
σ(τ). Measured (study, 300 draws per truth, white+GM+RW / white+RW / 4-GM): see its docstring.
Model read-offs are :func:`gyrojax.noise.readoff.derived`. Two values agree when they differ by less than 2
standard errors of their difference (or 10 %, whichever is larger: the curve's τ grid is coarse).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax import tails
from gyrojax.noise.allan import confidence_interval, local_slope
from gyrojax.noise.spec import BI_FACTOR
from gyrojax.units import SECONDS_PER_HOUR

SLOPE_TOL = 0.12
"""Largest |local slope of σ − the term's slope| of a read-off range."""

AGREE_REL = 0.10
"""Relative difference two read-offs may always have and still agree."""

TWO_SIGMA = math.erf(2.0 / math.sqrt(2.0))
"""Level of the read-offs' intervals (0.9545, that of ±2σ of a normal estimate)."""

BOUND_LEVEL = (1.0 + TWO_SIGMA) / 2.0
"""One-sided level of an upper bound (0.97725, the upper end of the ±2σ interval), given that it is issued."""

K_LOOK_DECADES = 0.4
"""Half-width (decades) of the window of τ at τ_max whose local slope decides that no +½ slope is seen
(:func:`gyrojax.noise.allan.local_slope`'s default): the K bound's ``looks``."""


B_MAX_HALF_WIDTH = 0.15
"""Largest relative half-width of the ±1σ interval of σ at a τ where the flat minimum B may be read."""

FIGURES = (
    ("arw", -0.5, "deg/sqrt(h)"),
    ("bias_instability", 0.0, "deg/h"),
    ("rrw", 0.5, "deg/h/sqrt(h)"),
    ("quantization", -1.0, "arcsec"),
    ("rate_ramp", 1.0, "deg/h/h"),
)


def _factor(name: str, tau: float) -> float:
    return {
        "arw": math.sqrt(tau) / 60.0,
        "bias_instability": 1.0 / BI_FACTOR,
        "rrw": math.sqrt(3.0 * SECONDS_PER_HOUR / tau),
        "quantization": tau / math.sqrt(3.0),
        "rate_ramp": math.sqrt(2.0) * SECONDS_PER_HOUR / tau,
    }[name]


B_FIT_DECADES = 0.7
"""Half-width (decades of τ) of the local fit whose minimum is the flat minimum B is read at."""


FIT_PASSES = 4
"""Passes of the reweighted fit of :func:`_flat_minimum` (the weights settle in two or three)."""


def _flat_minimum(taus, ad, known) -> tuple[int, float | None]:
    """(index of the τ nearest the flat minimum, σ_min or None).

    Through the known τ within :data:`B_FIT_DECADES` of the smallest σ, the relative least-squares fit
    σ²(τ) = A/τ + C + Bτ (the white, flat and random-walk terms of IEEE 952 C.1, linear in A, C, B; weights
    from the fitted σ², reweighted :data:`FIT_PASSES` times, as the noisy σ² would favour the low points); with
    A, B > 0 its minimum σ²_min = C + 2√(AB) at τ* = √(A/B), exact on sums of those terms. (The smallest σ's
    index, None) when fewer than 5 τ lie there, A or B ≤ 0, σ²_min ≤ 0 or τ* is outside them.

    The smallest of ~15 correlated noisy σ sits on a downward fluctuation. On 600 simulated white + random walk
    records (N = 0.1, K = 8, 2^16 samples of 0.05 s) it fell 1.9 % below the true minimum (its σ is 9 %), and
    ±2σ covered 0.949; the fit's minimum fell 1.4 % below (the minimum of any estimated curve is biased low) and
    covered 0.966. Its standard error is taken as that of σ at the τ nearest τ*: the fit averages strongly
    correlated neighbours, and its spread was 0.93 of that (benchmarks/study_noise_readoff_coverage.py has the
    coverage on full records)."""
    i0 = int(known[np.argmin(ad[known])])
    win = known[np.abs(np.log10(taus[known] / taus[i0])) <= B_FIT_DECADES]
    if win.size < 5:
        return i0, None
    t, v = taus[win], ad[win] ** 2
    basis = np.stack([1.0 / t, np.ones_like(t), t], axis=1)
    w = v
    for _ in range(FIT_PASSES):  # weights from the fitted σ², not the noisy one (which favours the low points)
        a, c, b = np.linalg.lstsq(basis / w[:, None], v / w, rcond=None)[0]
        fitted = basis @ np.array([a, c, b])
        if not np.all(fitted > 0):
            return i0, None
        w = fitted
    if not (a > 0 and b > 0):
        return i0, None
    tau_star, v_min = math.sqrt(a / b), c + 2.0 * math.sqrt(a * b)
    if not (v_min > 0 and t.min() < tau_star < t.max()):
        return i0, None
    return int(win[np.argmin(np.abs(np.log(t / tau_star)))]), math.sqrt(v_min)


def upper_bound(adev: float, edf: float, looks: int, level: float = BOUND_LEVEL) -> float:
    """The one-sided χ² upper bound of an Allan deviation σ̂ with ``edf`` degrees of freedom, at the Bonferroni
    level 1 − (1 − ``level``)/``looks`` (module doc): σ̂·√(ν/χ²_{(1−level)/looks}(ν)), NIST SP 1065 eq. 45."""
    tail = (1.0 - level) / max(int(looks), 1)
    return float(adev * math.sqrt(edf / tails.chi2_ppf(tail, max(float(edf), 1e-3))))


def curve_readoffs(res) -> dict:
    """The IEEE 952 read-offs of an :class:`~gyrojax.noise.allan.AllanResult` (module doc): per figure a dict with
    ``value``, ``std``, ``unit``, ``tau_s``, ``kind`` ("read" or "upper bound") and, when read, ``ci`` (the
    ±2σ-level χ² interval) and ``ci_level``, when a bound, ``bound_level`` and ``looks`` (module doc); or
    ``value`` None and the ``reason``."""
    taus, ad = np.asarray(res.taus_s, float), np.asarray(res.adev, float)
    sd = (np.asarray(res.high, float) - np.asarray(res.low, float)) / 2.0
    low2, high2 = confidence_interval(ad, res.edf, TWO_SIGMA)
    slope = local_slope(taus, ad**2) / 2.0
    out = {}

    def read(name, i, unit, level=None):
        f = _factor(name, float(taus[i]))
        v = (ad[i] if level is None else level) * f
        out[name] = {"value": float(v), "std": float(sd[i] * f), "unit": unit, "tau_s": float(taus[i]), "kind": "read"}
        scale = v / ad[i]  # the interval of σ at τ_i, moved with the value (the fitted σ_min of B)
        out[name]["ci"] = [float(low2[i] * scale), float(high2[i] * scale)]
        out[name]["ci_level"] = TWO_SIGMA

    def bound(name, i, unit, looks):
        f = _factor(name, float(taus[i]))
        hi = upper_bound(float(ad[i]), float(res.edf[i]), looks)
        v = hi * f
        out[name] = {"value": v, "std": float(sd[i] * f), "unit": unit, "tau_s": float(taus[i]), "kind": "upper bound"}
        # bound_ratio: the bound of σ over σ̂ at tau_s (unit-free: where the plot draws the bound on the curve)
        out[name].update(bound_level=BOUND_LEVEL, looks=int(looks), bound_ratio=float(hi / ad[i]))

    for name, s, unit in FIGURES:
        near = np.flatnonzero(np.abs(slope - s) <= SLOPE_TOL)
        if name == "bias_instability":
            # a dip at the long τ end, known to no better than ±15 %, is not the flat minimum (a real 10 000 s
            # ADIS16405 record dips to 0.7× its flat part at τ = 3333 s with ±90 %): read among the known τ
            known = np.flatnonzero(sd <= B_MAX_HALF_WIDTH * ad)
            known = known if known.size >= 3 else np.arange(len(taus))
            i, level = _flat_minimum(taus, ad, known)
            if 0 < i < known[-1] and abs(slope[i]) <= SLOPE_TOL:
                read(name, i, unit, level=level)
            elif slope[i] < 0:  # looks: the τ of the fit window the smallest σ was chosen among
                i0 = int(known[np.argmin(ad[known])])
                looks = int(np.sum(np.abs(np.log10(taus[known] / taus[i0])) <= B_FIT_DECADES))
                bound(name, i, unit, looks)
            else:
                out[name] = {"value": None, "reason": "the curve has no minimum inside the tau range", "unit": unit}
        elif near.size:
            if name == "arw":
                i = int(near[np.argmin(np.abs(np.log(taus[near])))])
            elif name == "rrw":
                i = int(near[-1])
            else:
                i = int(near[0]) if s < 0 else int(near[-1])
            read(name, i, unit)
            if name == "rrw":  # the other terms' share of σ² at τ_i biases K high: lower end by its bound
                out[name]["ci"][0] *= math.sqrt(min(2.0 * float(slope[i]), 1.0))
        elif name == "rrw":
            looks = int(np.sum(np.log10(taus[-1] / taus) <= K_LOOK_DECADES))
            bound(name, len(taus) - 1, unit, looks)
        else:
            closest = float(slope[np.argmin(np.abs(slope - s))])
            out[name] = {"value": None, "reason": f"no range of slope {s:+g} (closest {closest:.2f})", "unit": unit}
    return out


def compare(model: dict, curve: dict) -> dict:
    """``headline``: per figure {``curve``, ``model``, ``agree``, ``note``}; ``agree`` None when either is not
    read; the note says which is used and why when they differ or one is missing."""
    out = {}
    for name, _, _ in FIGURES:
        c = curve.get(name, {"value": None, "reason": "not read"})
        m = model.get(name, {"value": None, "reason": "not a model read-off"})
        agree, note = None, ""
        if c["value"] is not None and m["value"] is not None:
            if c.get("kind") == "upper bound":  # a one-sided bound at BOUND_LEVEL already
                agree = m["value"] <= c["value"]
                rel = "within" if agree else "ABOVE"
                note = f"the model's {m['value']:.4g} is {rel} the curve's upper bound {c['value']:.4g}"
            else:
                diff = abs(m["value"] - c["value"])
                tol = max(2 * math.hypot(c["std"], m.get("std", 0.0)), AGREE_REL * abs(c["value"]))
                agree = diff <= tol
                if not agree:
                    at = f" (tau {m['tau_s']:.3g} s)" if m.get("tau_s") else ""
                    note = (
                        f"model {m['value']:.4g}{at} and curve {c['value']:.4g} "
                        f"(tau {c['tau_s']:.3g} s) differ by {100 * diff / abs(c['value']):.0f} %"
                    )
        elif c["value"] is not None:
            note = f"model: not read ({m.get('reason', '')}); the curve's {c.get('kind', 'read')} is the figure"
        elif m["value"] is not None:
            note = f"curve: not read ({c.get('reason', '')}); the model's value is the figure"
        out[name] = {"curve": c, "model": m, "agree": agree, "note": note}
    return out
