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

Among the admissible candidates the selection takes the least criterion Q(θ̂; Ω_ref) + Σ cost (Q the GMWM
objective with the weights Ω_ref of the largest candidate): each process beside the white one costs what adding it
to a model without it must lower Q by to pass a test at the per-component level α₁ = :data:`COMPONENT_LEVEL`:

- a process with one variance (quantization, random walk, flicker floor, ramp): under the smaller model that
  variance is on its boundary 0, so ΔQ ~ ½χ²₀ + ½χ²₁ (Self & Liang 1987) and its cost is c₁ = Φ⁻¹(1 − α₁)²
  (:func:`linear_cost`);
- a Gauss–Markov component: its T is not identified under the smaller model, so ΔQ is the supremum over T, in
  the identified range (:func:`gyrojax.noise.gmwm.gm_tau_limits`), of the squared score Z(T)² of its variance,
  a χ² process; its cost c_GM = u² from Davies' (1987) bound P(sup_T Z(T) > u) ≤ Φ(−u) + V/(2π)·e^(−u²/2),
  V the angle the whitened direction of the Gauss–Markov column sweeps as T runs over the range, beyond what the
  one-variance processes (white, quantization, random walk and the flicker floor, which a spread of Gauss–Markov
  components stands in for) explain (:func:`gm_sweep`, :func:`davies_cost`; V ≈ 6.3 and c_GM ≈ 7.3 for the 15
  dyadic scales of a 2^17 record, where the former flat c = 3 per parameter charged 6).

The Davies cost is what keeps a spurious Gauss–Markov component beside a 1/f floor (or two of them in place of the
floor) out: with c = 3 per parameter, white + an exact 1/f floor gained one in 8 % of records
(benchmarks/study_gmwm_selection.py). α₁ is calibrated by Monte Carlo so that the selection adds a spurious process
in at most :data:`FALSE_COMPONENT_LEVEL` of the records of every null case of the study (white, white + GM, white +
a flicker-like sum of GMs, white + a 1/f floor; the union of the one-component alternatives makes the rate exceed
α₁, the admissibility rules below make it less).

Measured (benchmarks/study_gmwm_selection.py --draws 200, 2^17 samples; binomial sd ≈ 0.015): false-component
rate white 0.030, white + GM 0.040, flicker-like GM sum 0.040, white + 1/f floor 0.045; power, white + 1/f floor +
random walk with both found: 0.915.

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
from scipy import optimize

from gyrojax import tails
from gyrojax.noise import wavelet as wv
from gyrojax.noise.spec import NoiseModelError, NoiseSpec

FALSE_COMPONENT_LEVEL = 0.05
"""The stated false-component rate: the share of records whose chosen model has more processes than the one that
made them (white, white + GM, white + flicker-like GM sums, white + a 1/f floor; study_gmwm_selection.py)."""

COMPONENT_LEVEL = 0.03
"""α₁, the level of the test each added process must pass (module doc), calibrated for
:data:`FALSE_COMPONENT_LEVEL`."""

LINEAR = ("quantization", "random_walk", "drift", "flicker")
"""The one-variance processes of :class:`~gyrojax.noise.gmwm_model.ModelSpec` beside the white one."""

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


def linear_cost(level: float = COMPONENT_LEVEL) -> float:
    """c₁ = Φ⁻¹(1 − α₁)²: the drop of Q that a one-variance process must bring, its variance on the boundary 0
    under the smaller model (ΔQ ~ ½χ²₀ + ½χ²₁, Self & Liang 1987; P(ΔQ > c₁) = α₁); dimensionless."""
    return float(tails.norm_isf(level)) ** 2


def davies_cost(sweep: float, level: float = COMPONENT_LEVEL) -> float:
    """u² with Φ(−u) + V/(2π)·e^(−u²/2) = α₁ (Davies 1987, a one-sided Gaussian score process over a nuisance
    parameter identified only under the alternative; V = ``sweep``, radians): the drop of Q a Gauss–Markov
    component must bring; c₁ of :func:`linear_cost` when V = 0."""

    def excess(u):
        return tails.norm_sf(u) + sweep / (2.0 * math.pi) * math.exp(-0.5 * u * u) - level

    return float(optimize.brentq(excess, 0.0, 40.0)) ** 2


def gm_sweep(m, p_mat, linear_basis, tau_limits, grid_points: int = 200) -> float:
    """V (radians) of :func:`davies_cost`: the length of the path of the unit vector along P·g(T) (g the Haar
    wavelet variance of a unit-variance Gauss–Markov process at half-widths ``m`` samples, P = ``p_mat`` the
    whitening of the reference weights, PᵀP = Ω_ref⁻¹) projected off the columns ``linear_basis`` (J, k) of the
    one-variance processes, as T runs over ``tau_limits`` (samples, :func:`gyrojax.noise.gmwm.gm_tau_limits`)."""
    m = np.asarray(m, float)
    p_mat = np.asarray(p_mat, float)
    q, _ = np.linalg.qr(p_mat @ np.asarray(linear_basis, float))
    taus = np.geomspace(*tau_limits, grid_points)
    g = np.asarray(wv.wv_gauss_markov(m[:, None], 1.0, 1.0 / taus[None, :]))
    r = p_mat @ g
    r = r - q @ (q.T @ r)
    r = r / np.linalg.norm(r, axis=0)
    return float(np.sum(np.arccos(np.clip(np.sum(r[:, 1:] * r[:, :-1], axis=0), -1.0, 1.0))))


def costs(sweep: float, level: float = COMPONENT_LEVEL) -> dict:
    """The criterion costs of one selection (module doc): ``linear`` c₁, ``gauss_markov`` c_GM, with the ``sweep``
    V (:func:`gm_sweep`) and ``level`` α₁."""
    return {"level": level, "linear": linear_cost(level), "gauss_markov": davies_cost(sweep, level), "sweep": sweep}


def cost_of(spec, cost: dict) -> float:
    """Σ cost of the processes of ``spec`` beside the white one (:func:`costs`)."""
    n_lin = sum(bool(getattr(spec, k)) for k in LINEAR)
    return n_lin * cost["linear"] + spec.n_gm * cost["gauss_markov"]


def table_row(spec, ns: NoiseSpec, cost: dict | None = None, penalty: float | None = None) -> dict:
    """The selection-table row of candidate ``spec`` fitted as ``ns`` (with the reference weights): its objective
    Q, criterion Q + :func:`cost_of` ``cost`` (or Q + ``penalty``·p, a flat cost per parameter, when given) and
    rejection (None when admissible)."""
    objective = float(ns.info["objective"])
    extra = penalty * spec.n_params if penalty is not None else cost_of(spec, cost)
    return {
        "model": spec.label(),
        "n_params": spec.n_params,
        "objective": objective,
        "criterion": objective + extra,
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


def passes_j_test(ns: NoiseSpec) -> bool:
    """Whether a fit with its own efficient weights passes its J test at :data:`J_TEST_LEVEL` (no test: True)."""
    p = ns.info.get("p_value")
    return p is None or p >= J_TEST_LEVEL
