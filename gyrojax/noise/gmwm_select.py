"""Identified GMWM model selection: which sum of latent processes a static record can tell apart.

A candidate (:data:`~gyrojax.noise.gmwm_model.DEFAULT_CANDIDATES`) is **admissible** only when the record
identifies every one of its parameters:

- none at a bound of its box (a white term pinned at its floor, a Gauss–Markov T at the shortest or longest
  identifiable correlation time, :func:`gyrojax.noise.gmwm.gm_tau_limits`);
- no two Gauss–Markov components within a factor :data:`DUPLICATE_RATIO` in T (they are one component with its
  variance split in two: the smaller candidate holds the merged one);
- every natural parameter with a relative standard error under :data:`MAX_REL_STD` (a σ or T known to no better
  than ±100 % is not identified);
- a flicker floor (bias instability B, :mod:`~gyrojax.noise.gmwm_model`) only where it is seen: it must carry at
  least half of the model's Allan variance over a factor :data:`FLICKER_MIN_SPAN` of τ inside the fitted range
  (IEEE 952 reads B off a flat part; a floor hidden under the white, Gauss–Markov or random-walk terms everywhere
  is a parameter the record cannot tell from zero).

Among the admissible candidates the selection takes the least Q(θ̂; Ω_ref) + c·p (Q the GMWM objective with the
weights Ω of the largest candidate, p the number of parameters). The penalty c = :data:`PENALTY` is calibrated by
Monte Carlo so that white data gain a spurious component in :data:`FALSE_COMPONENT_LEVEL` of the records
(benchmarks/study_gmwm_selection.py; the χ² argument behind the WIC's 2 per parameter does not hold for a
Gauss–Markov component absent under the null, whose T is then not identified: WIC kept one in 10 of 60 white
records).

**Adequacy gate.** The candidate chosen is then fitted with its own efficient weights Ω(θ̂); when its J test
(Hansen; Q(θ̂) ~ χ²(J − p) under the model) rejects it at :data:`J_TEST_LEVEL`, the next admissible candidate by
criterion is taken, and so on (:func:`ranked`); the refusals are in the table (``j_test_p``) and, when no
candidate passes, the least-criterion one is kept with a note. A model that the common weights Ω_ref rate close
to a better one can still be far off the curve under its own covariance: the ADEV of a flat floor alone on a
gyro whose curve rises again past 300 s (the y gyro of a real ADIS16405, own-weight p = 2e-4) is 16–24 % low at
330–420 s, where the curve's ±1σ half-width is 12–14 %. On data the true model made, the gate changes the choice
in at most :data:`J_TEST_LEVEL` of records, so it adds at most that to the false-component rate.

**Short scales.** A sensor's own decimation / anti-alias filter makes neighbouring samples positively correlated:
m·ν̂²(m), constant for white noise, rises over the first scales. :func:`short_scale_limit` drops those scales
(at most :data:`MAX_DROPPED_SCALES`) when the rise is significant, so that the filter is neither fitted as
sub-sample Gauss–Markov components nor drags the white term to its floor; the limit and its cause are reported
(``info["tau_min_s"]``, ``info["short_scales"]``).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax.noise.spec import NoiseModelError, NoiseSpec

PENALTY = 3.0
"""Criterion cost per parameter (see the module doc and :data:`FALSE_COMPONENT_LEVEL`)."""

FALSE_COMPONENT_LEVEL = 0.05
"""The stated rate at which white data gain a spurious component."""

DUPLICATE_RATIO = 3.0
"""Two Gauss–Markov components closer than this factor in T are one."""

MAX_REL_STD = 1.0
"""Largest relative standard error of an identified natural parameter."""

FLICKER_MIN_SPAN = 4.0
"""Least ratio τ_max/τ_min of the range where a flicker floor carries half the model's Allan variance (two
octaves: a flat part, not a point)."""

J_TEST_LEVEL = 0.001
"""Level of the J test that the chosen candidate must pass under its own weights (module doc)."""

FILTER_Z = 3.0
"""z of the rise of m·ν̂²(m) between neighbouring scales above which a short scale is taken as filtered."""

MAX_DROPPED_SCALES = 6
"""At most this many of the shortest dyadic scales (m = 1 … 32) are dropped for the sensor's filter."""


def short_scale_limit(est) -> tuple[int, str]:
    """(number of leading scales of ``est`` to drop, the reason or "").

    The shortest scale is dropped when m·ν̂²(m) rises to the next scale by more than :data:`FILTER_Z` standard
    errors (the relative variance of ν̂² taken as 2m/M, conservative for white noise); each next one while every
    shorter scale was dropped and m·ν̂² still changes by more than :data:`FILTER_Z` standard errors, unless it
    rises after a rise by more than the one before (a filter's excess fades past its length, or rings — rises and
    falls in turn, as the z gyro of a real ADIS16405 record: +99 %, −51 %, +20 %, −15 % over m = 1 … 16; a
    Gauss–Markov process longer than the scales makes m·ν² grow ever faster, up to 4× per scale, and is kept);
    white noise keeps m·ν̂² flat, quantization makes it fall: only a low-pass (the sensor's filter, or a Gauss–Markov
    process shorter than a few samples) makes it rise there."""
    w = est.m * est.nu2
    k = 0
    zs = []
    while k < min(MAX_DROPPED_SCALES, len(est.m) - 1):
        sd = math.sqrt(2.0 * est.m[k] / est.counts[k] + 2.0 * est.m[k + 1] / est.counts[k + 1])
        z = math.log(w[k + 1] / w[k]) / sd
        rose_before = k and w[k] > w[k - 1]
        if k == 0 and not z > FILTER_Z:
            break
        # past a dropped scale: a ringing filter alternates rises and falls; a rise growing on a rise is a GM
        if k and (not abs(z) > FILTER_Z or (z > 0 and rose_before and w[k + 1] / w[k] > w[k] / w[k - 1])):
            break
        zs.append(f"{100 * (w[k + 1] / w[k] - 1):+.1f} % ({z:.0f} sigma) from m = {est.m[k]}")
        k += 1
    if k == 0:
        return 0, ""
    tau = float(est.m[k] * est.dt)
    return k, (
        f"m*nu^2 is not flat over the shortest scales ({'; '.join(zs)}): the sensor's own filter colours the noise "
        f"below tau = {tau:.3g} s, so the fit starts there"
    )


def flicker_span(ns: NoiseSpec) -> float:
    """τ_max/τ_min of the longest range inside ``ns.flicker_band`` (the fitted τ range, s) where the flicker floor
    carries at least half of the model's Allan variance (1.0 when nowhere; dimensionless)."""
    taus = np.geomspace(*ns.flicker_band, 400)
    parts = ns.term_avar(taus)
    share = parts["bias_instability"] / sum(parts.values())
    best, start = 1.0, None
    for i, on in enumerate(np.append(share >= 0.5, False)):
        if on and start is None:
            start = i
        elif not on and start is not None:
            best = max(best, float(taus[i - 1] / taus[start]))
            start = None
    return best


def rejection(ns: NoiseSpec) -> str:
    """Why a fitted candidate is not identified by the record ("" when it is admissible)."""
    if ns.info.get("pinned"):
        return "at a bound: " + ", ".join(ns.info["pinned"])
    if ns.bias_instability > 0 and ns.flicker_band is not None:
        span = flicker_span(ns)
        if span < FLICKER_MIN_SPAN:
            return (
                f"bias instability not seen: its flat floor carries half the Allan variance over a factor "
                f"{span:.2g} of tau only (needs {FLICKER_MIN_SPAN:g})"
            )
    taus = sorted(t for _, t in ns.gauss_markov)
    for a, b in zip(taus, taus[1:]):
        if b / a < DUPLICATE_RATIO:
            return f"duplicate Gauss-Markov components (T = {a:.3g} and {b:.3g} s)"
    for k in ns.cov_names:
        v, s = abs(ns.value(k)), ns.std(k)
        if not (s <= MAX_REL_STD * v):
            return f"{k} not identified (relative standard error {s / v if v else math.inf:.2g})"
    return ""


def table_row(spec, ns: NoiseSpec, penalty: float = PENALTY) -> dict:
    """The selection-table row of candidate ``spec`` fitted as ``ns`` (with the reference weights): its objective
    Q, criterion Q + ``penalty``·p and rejection (None when admissible)."""
    objective = float(ns.info["objective"])
    return {
        "model": spec.label(),
        "n_params": spec.n_params,
        "objective": objective,
        "criterion": objective + penalty * spec.n_params,
        "rejected": rejection(ns) or None,
    }


def ranked(rows) -> list:
    """Indices of the admissible rows, least criterion first; :class:`NoiseModelError` listing every rejection
    when no candidate is identified."""
    ok = [i for i, r in enumerate(rows) if not r["rejected"]]
    if not ok:
        raise NoiseModelError(
            "no candidate noise model is identified by this record: "
            + "; ".join(f"{r['model']}: {r['rejected']}" for r in rows)
        )
    return sorted(ok, key=lambda i: rows[i]["criterion"])


def choose(rows) -> int:
    """Index of the admissible row of least criterion (:func:`ranked`), before the adequacy gate."""
    return ranked(rows)[0]


def passes_j_test(ns: NoiseSpec) -> bool:
    """Whether a fit with its own efficient weights passes its J test at :data:`J_TEST_LEVEL` (no test: True)."""
    p = ns.info.get("p_value")
    return p is None or p >= J_TEST_LEVEL
