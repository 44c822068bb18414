"""What a fitted noise model (:class:`~gyrojax.noise.spec.NoiseSpec`) tells: the standard error of its Allan
deviation, the IEEE 952 figures read off it (ARW, bias instability, RRW), its adequacy against the empirical
Allan deviation, and the report of ``gyrojax noise``."""

from __future__ import annotations

import math

import numpy as np

from gyrojax import tails
from gyrojax.noise import headline
from gyrojax.noise.spec import BI_FACTOR, UNITS, NoiseModelError, NoiseSpec, adev_jacobian
from gyrojax.units import SECONDS_PER_HOUR


def cov_finite(spec: NoiseSpec) -> np.ndarray:
    """Cov of the parameters (``spec.cov_names``) with the rows/columns of pinned ones set to 0 (held fixed)."""
    c = np.asarray(spec.cov, float).reshape(len(spec.cov_names), len(spec.cov_names))
    return np.where(np.isfinite(c), c, 0.0)


def adev_std(spec: NoiseSpec, taus_s) -> np.ndarray:
    """Standard error of the model Allan deviation at ``taus_s`` (delta method), deg/h."""
    jac = adev_jacobian(spec, np.asarray(taus_s, float))
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, cov_finite(spec), jac), 0.0))


def derived(spec: NoiseSpec, tau_min: float, tau_max: float, slope_tol: float = 0.1) -> dict:
    """ARW, bias instability (flicker floor) and RRW read off the model's ADEV between ``tau_min`` and ``tau_max``
    s, each with its standard error and the τ where it was read (``None`` with the reason when the model has no
    range of that slope).

    ARW N = σ(τ)√τ/60 at the shortest τ where the log-log slope is within ``slope_tol`` of −½ (a Gauss–Markov
    process far beyond its correlation time is white too, so the shortest such τ is the sensor's ARW); RRW
    K = σ(τ)√(3·3600/τ) where it is closest to +½ (within ``slope_tol``); bias instability B = σ_min/0.664 at an
    interior minimum of σ(τ) (IEEE 952 C.1, :data:`~gyrojax.noise.spec.BI_FACTOR`).
    """
    tt = np.geomspace(tau_min, tau_max, 400)
    lt = np.log(tt)
    ad = spec.adev(tt)
    slope = np.gradient(np.log(ad), lt)
    out = {}

    def read(name, idx, factor, unit):
        out[name] = read_at(spec, float(tt[idx]), factor, unit)

    near = np.flatnonzero(np.abs(slope + 0.5) <= slope_tol)
    i = int(near[0]) if near.size else int(np.argmin(np.abs(slope + 0.5)))  # the shortest white-like τ
    if abs(slope[i] + 0.5) <= slope_tol:
        read("arw", i, math.sqrt(tt[i]) / 60.0, "deg/sqrt(h)")
    else:
        out["arw"] = {"value": None, "reason": f"no range of slope -1/2 (closest {slope[i]:.2f})"}
    i = int(np.argmin(ad))
    if 0 < i < len(tt) - 1:
        read("bias_instability", i, 1.0 / BI_FACTOR, "deg/h")
    else:
        out["bias_instability"] = {"value": None, "reason": "the model's ADEV has no minimum inside the τ range"}
    i = int(np.argmin(np.abs(slope - 0.5)))
    if abs(slope[i] - 0.5) <= slope_tol:
        read("rrw", i, math.sqrt(3.0 * SECONDS_PER_HOUR / tt[i]), "deg/h/sqrt(h)")
    else:
        out["rrw"] = {"value": None, "reason": f"no range of slope +1/2 (closest {slope[i]:.2f})"}
    return out


def read_at(spec: NoiseSpec, tau: float, factor: float, unit: str) -> dict:
    """``factor`` × the model's ADEV at ``tau`` s, with its standard error (delta method), its ±2σ-level interval
    ``ci`` (:func:`log_interval`) and that τ."""
    g = adev_jacobian(spec, np.array([tau]))[0] * factor
    value = float(spec.adev(np.array([tau]))[0] * factor)
    std = float(math.sqrt(max(g @ cov_finite(spec) @ g, 0.0)))
    return {"value": value, "std": std, "ci": log_interval(value, std), "unit": unit, "tau_s": float(tau)}


def log_interval(value: float, std: float, k: float = 2.0) -> list | None:
    """value·exp(±k·std/value), in the value's unit: the ±kσ interval of ln(value), whose delta-method standard
    error is std/value.

    A model read-off is a positive scale figure, √ of a sum of variances; the GMWM parameters are the logarithms
    of those variances (:mod:`gyrojax.noise.gmwm`), so ln(value) is the nearly linear function of them that the
    delta method assumes, and value ± kσ is not: with σ ∝ value, a low estimate carries a small σ and value ± 2σ
    missed K and B on the low side only (benchmarks/study_noise_readoff_coverage.py). None for a value ≤ 0."""
    if not (value > 0 and math.isfinite(std)):
        return None
    r = std / value
    return [float(value * math.exp(-k * r)), float(value * math.exp(k * r))]


# ---- selection uncertainty ------------------------------------------------------------------------------------

SELECTION_FIGURES = ("arw", "bias_instability", "rrw")
"""The model read-offs whose interval carries the uncertainty of the model selection (:func:`with_selection`)."""


def selection_weights(rows, keep) -> np.ndarray:
    """Evidence weights w_i ∝ exp(−ΔC_i/2) of the selection rows ``rows[i]`` for i in ``keep`` (C the selection
    criterion Q + c·p of :mod:`gyrojax.noise.gmwm_select`; Q is a J statistic, −2 ln L up to a constant for
    Gaussian ν̂², so these are Buckland et al.'s (1997) Akaike weights with the calibrated penalty c in place of
    2), summing to 1."""
    c = np.array([rows[i]["criterion"] for i in keep], float)
    w = np.exp(-(c - c.min()) / 2.0)
    return w / w.sum()


def mata_interval(values, stds, weights, level: float = headline.TWO_SIGMA) -> tuple[float, float]:
    """Model-averaged tail-area Wald interval (Turek & Fletcher 2012, "MATA-Wald"; on ln of the figure) of a
    positive figure estimated by several models: (θ_L, θ_U) with

        Σ_i w_i [1 − Φ((ln θ̂_i − ln θ_L)/s_i)] = α/2,   Σ_i w_i Φ((ln θ̂_i − ln θ_U)/s_i) = α/2,

    α = 1 − ``level``, s_i = std_i/θ̂_i (the delta method in ln, as :func:`log_interval`), w_i the models'
    weights. A model whose figure is 0 (``values[i]`` None or ≤ 0: e.g. no random walk, so no K) is a point mass
    at 0: it puts its weight in the lower tail, and θ_L is 0 when that weight is α/2 or more. With one model it is
    :func:`log_interval`. Unlike a variance (Buckland et al. 1997, [Σ w_i √(s_i² + (θ̂_i − θ̄)²)]²) it needs no
    centre and no figure for the models that lack one, and keeps the skew of a mixture of two separated fits.

    Turek, D. & Fletcher, D. (2012), Model-averaged Wald confidence intervals, Comput. Stat. Data Anal. 56,
    2809–2815; Buckland, S. T., Burnham, K. P. & Augustin, N. H. (1997), Model selection: an integral part of
    inference, Biometrics 53, 603–618."""
    from scipy.optimize import brentq

    a = (1.0 - level) / 2.0
    w = np.asarray(weights, float)
    pos = np.array([v is not None and v > 0 for v in values])
    lv = np.array([math.log(v) if p else 0.0 for v, p in zip(values, pos)])
    sv = np.array([max(float(sd) / v, 1e-12) if p else 1.0 for v, sd, p in zip(values, stds, pos)])
    w0 = float(w[~pos].sum())
    lv, sv, wp = lv[pos], sv[pos], w[pos]
    if not wp.size or wp.sum() <= a:
        return 0.0, 0.0
    span = lv.min() - 40.0 * sv.max(), lv.max() + 40.0 * sv.max()

    def upper_tail(x):  # Σ w_i Φ((ln θ̂_i − x)/s_i) − α/2, falling in x
        return float(wp @ tails.norm_cdf((lv - x) / sv)) - a

    def lower_tail(x):  # w0 + Σ w_i [1 − Φ((ln θ̂_i − x)/s_i)] − α/2, rising in x
        return w0 + float(wp @ tails.norm_sf((lv - x) / sv)) - a

    hi = math.exp(brentq(upper_tail, *span, xtol=1e-12))
    lo = 0.0 if w0 >= a else math.exp(brentq(lower_tail, *span, xtol=1e-12))
    return lo, hi


def candidate_fits(nm: NoiseSpec, est) -> list:
    """(weight, fit) of every candidate of ``nm``'s selection (``info["selection"]``) that the record identifies
    and that passes its own J test (:func:`gyrojax.noise.gmwm_select.passes_j_test`; the chosen model always),
    refitted on the same scales of the wavelet variance ``est`` (the one ``nm`` was selected on) with its own
    efficient weights; weights :func:`selection_weights`. [] when ``nm`` was not selected (a model given by
    name)."""
    from dataclasses import replace

    from gyrojax.noise import gmwm_select as sel
    from gyrojax.noise.gmwm import fit_spec
    from gyrojax.noise.gmwm_model import ModelSpec

    rows = nm.info.get("selection")
    if not rows:
        return []
    k = int(np.searchsorted(est.m * est.dt, nm.info["tau_min_s"] * (1 - 1e-9)))
    est = replace(est, m=est.m[k:], nu2=est.nu2[k:], counts=est.counts[k:])
    keep, fits = [], []
    for i, r in enumerate(rows):
        if r["rejected"]:
            continue
        f = nm if r["model"] == nm.info["model"] else fit_spec(ModelSpec.parse(r["model"]), est, method=nm.method)
        if f is nm or sel.passes_j_test(f):
            keep.append(i)
            fits.append(f)
    return list(zip(selection_weights(rows, keep), fits))


def with_selection(figs: dict, cands: list, tau_min: float, tau_max: float, curve_b_tau: float | None) -> dict:
    """The chosen model's read-offs ``figs`` (:func:`derived`) with intervals that carry the selection: per figure
    of :data:`SELECTION_FIGURES` read, ``ci`` the MATA-Wald interval (:func:`mata_interval`) over the candidates
    ``cands`` (:func:`candidate_fits`), each read as :func:`derived` reads it (B at ``curve_b_tau`` where a
    candidate's ADEV has no minimum, as the headline does; ``tau_min``, ``tau_max``, ``curve_b_tau`` in s), ``std``
    value·ln(θ_U/θ_L)/4 (the ±2σ width in ln; value·ln(θ_U/value)/2 when θ_L = 0); ``std_given_model`` and
    ``ci_given_model`` the chosen model's own. Unchanged with fewer than two candidates.

    With the selection in the loop the chosen model's own ±2σ intervals cover less than their level (a spurious
    quantization term, a dropped random walk); this one carries the selection, and MATA rather than Buckland's
    unconditional variance, which over-covers (coverage: benchmarks/study_noise_readoff_coverage.py). It costs a
    refit of each candidate."""
    if len(cands) < 2:
        return figs
    reads = [derived(f, tau_min, tau_max) for _, f in cands]
    w = [wi for wi, _ in cands]
    out = dict(figs)
    for name in SELECTION_FIGURES:
        v = figs.get(name, {})
        if v.get("value") is None or not v.get("std"):
            continue
        vals, stds = [], []
        for (_, f), r in zip(cands, reads):
            c = r[name]
            if c["value"] is None and name == "bias_instability" and curve_b_tau is not None:
                c = read_at(f, curve_b_tau, 1.0 / BI_FACTOR, "deg/h")
            vals.append(c["value"])
            stds.append(c.get("std") or 0.0)
        if name == "arw" and any(x is None for x in vals):  # every model has a white term: one not read is left out
            keep = [j for j, x in enumerate(vals) if x is not None]
            vals, stds, w_n = [vals[j] for j in keep], [stds[j] for j in keep], [w[j] for j in keep]
            w_n = list(np.asarray(w_n) / np.sum(w_n))
        else:
            w_n = w
        lo, hi = mata_interval(vals, stds, w_n)
        val = v["value"]
        lo, hi = min(lo, val), max(hi, val)
        std = val * (math.log(hi / lo) / 4.0 if lo > 0 else math.log(hi / val) / 2.0)
        out[name] = {**v, "std": float(std), "ci": [float(lo), float(hi)], "std_given_model": v["std"]}
        out[name].update(ci_given_model=v.get("ci"), ci_method="MATA-Wald over the selection's candidates")
    return out


# ---- adequacy --------------------------------------------------------------------------------------------------


def adequacy(taus_s, adev, low, high, model_adev, min_tau_s: float = 0.0, max_half_width: float = 0.15) -> dict:
    """Per-τ check of a model's ADEV against the empirical confidence interval [low, high] (deg/h).

    Returns ``inside`` (per τ), ``ratio`` model/empirical, the τ outside, the largest |ratio − 1| over the τ
    ≥ ``min_tau_s`` whose interval half-width (relative) is under ``max_half_width`` (the well-measured τ), and
    ``band_units``: the misfit in units of the band on the model's side, (model − σ̂)/(high − σ̂) above σ̂ and
    (σ̂ − model)/(σ̂ − low) below, signed (|u| ≤ 1 inside the band), with its largest |u| over the well-measured τ.
    """
    taus_s, adev, low, high, model_adev = (np.asarray(a, float) for a in (taus_s, adev, low, high, model_adev))
    inside = (model_adev >= low) & (model_adev <= high)
    ratio = model_adev / adev
    half = (high - low) / (2.0 * adev)
    good = (taus_s >= min_tau_s) & (half < max_half_width)
    worst = float(np.max(np.abs(ratio[good] - 1.0))) if good.any() else float("nan")
    with np.errstate(divide="ignore", invalid="ignore"):
        units = np.where(model_adev >= adev, (model_adev - adev) / (high - adev), -(adev - model_adev) / (adev - low))
    return {
        "band_units": [float(x) for x in units],
        "max_band_units_well_measured": float(np.max(np.abs(units[good]))) if good.any() else float("nan"),
        "inside": [bool(x) for x in inside],
        "ratio": [float(x) for x in ratio],
        "n_outside": int((~inside).sum()),
        "taus_outside_s": [float(t) for t in taus_s[~inside]],
        "max_rel_deviation_well_measured": worst,
    }


# ---- the report of ``gyrojax noise`` ---------------------------------------------------------------------------

ADEQUACY_CI = 0.95
"""Confidence level of the empirical band the model's ADEV is checked against."""


def noise_report(
    segments,
    tau0: float,
    m_list=None,
    method: str = "gmwm",
    model: str = "auto",
    notes=(),
    gauss_markov: bool = False,
    mask_glitches: bool = True,
    robust: bool = False,
    selection_ci: bool = True,
):
    """Everything ``gyrojax noise --json`` prints, as a dict, plus the (AllanResult, IEEE 952 NoiseSpec, fitted
    GMWM/AVLR NoiseSpec or None).

    The empirical ADEV with ±1σ intervals and the IEEE 952 read-off (:mod:`gyrojax.noise.allan`), the model's
    ADEV at the same τ with its standard error, the per-τ check against the empirical 95 % band
    (:func:`adequacy`, :func:`verdict_line`), the derived ARW / bias instability / RRW and the model itself.

    ``segments`` rate series (deg/h) at ``tau0`` s; ``m_list`` averaging factors (default log-spaced). Spikes and
    stuck stretches are found and (``mask_glitches``) masked first (:mod:`gyrojax.noise.glitch`: ``glitches`` in
    the output, a sentence in ``notes``). ``robust``: nothing masked, the model fitted by the robust GMWM
    (:mod:`gyrojax.noise.robust_wv`; ``wavelet_variance`` in the output names the estimator and its efficiency).
    ``selection_ci``: the headline model figures' intervals carry the model selection (:func:`with_selection`;
    ``derived`` keeps the chosen model's own). Spectral lines (sinusoids, which no model term is) are searched in
    the analysed series (:mod:`gyrojax.noise.lines`): ``spectral_lines`` (per line frequency in Hz, amplitude in
    deg/h, the τ range in s of the ADEV it reaches), ``spectral_line_search`` (the Welch settings, band and level),
    a sentence in ``notes``, and the verdict names a line whose τ range holds the misfit.
    """
    from gyrojax.noise import allan as allan_mod
    from gyrojax.noise import glitch, robust_wv
    from gyrojax.noise import lines as lines_mod
    from gyrojax.noise.gmwm import WaveletVariance, fit_wv

    notes = list(notes)
    if robust and method not in ("gmwm", "avlr"):
        raise NoiseModelError(f"the robust estimate is a GMWM or AVLR fit, not {method!r}")
    mask_glitches = mask_glitches and not robust
    cleaned, found = glitch.clean(segments, tau0)
    if glitch.note(found):
        notes.append(glitch.note(found, masked=mask_glitches, robust=robust))
        if mask_glitches:
            segments = cleaned

    res, ieee = allan_mod.analyze(segments, tau0, m_list, gauss_markov=gauss_markov)
    est = nm = None
    if method in ("gmwm", "avlr"):
        est = WaveletVariance.of(segments, tau0, robust=robust)
        nm = fit_wv(est, model, method)
    elif method != "ieee952":
        raise NoiseModelError(f"method must be gmwm, avlr or ieee952, got {method!r}")
    extra = {}
    if robust:  # the curve too is the robust one (σ²_A = 2ν̂²_R with its own interval): table, band, read-offs
        classical = res
        res, info = robust_wv.robust_allan(segments, tau0, res.m, nm)
        ieee = allan_mod.fit_noise_model(res.taus_s, res.avar, res.edf, gauss_markov=gauss_markov)
        notes.append(
            "robust: the Allan deviation, its band and the curve read-offs are the robust wavelet variance's "
            f"(sqrt(2 nu2_R), Tukey biweight, {info['outlier_samples']} outlier samples treated as missing); the "
            "classical curve is in classical_adev_deg_per_h"
        )
        eff = nm.info["wavelet_variance"]["efficiency"]
        differ = robust_wv.disagreement_note(
            res.taus_s,
            np.interp(res.taus_s, classical.taus_s, classical.avar),
            np.interp(res.taus_s, classical.taus_s, classical.edf),
            res.avar,
            eff,
        )
        if differ:
            notes.append(differ)
        extra["curve_estimator"] = "robust wavelet variance (sqrt(2 nu2_R))"
        extra["classical_adev_deg_per_h"] = [float(x) for x in np.interp(res.taus_s, classical.taus_s, classical.adev)]
    search = lines_mod.find_lines(segments, tau0)
    spectral = lines_mod.with_reach(search, res.taus_s, res.avar, res.edf, "deg/h")
    if lines_mod.note(spectral, search):
        notes.append(lines_mod.note(spectral, search))
    extra["glitches"] = {**found, "masked": bool(mask_glitches)}
    extra["spectral_lines"] = spectral
    extra["spectral_line_search"] = {k: v for k, v in search.items() if k != "lines"}
    out = variance_report(res, ieee, nm, est, notes, method=method, selection_ci=selection_ci, extra=extra)
    return out, res, ieee, nm


def variance_report(res, ieee, nm, est, notes, *, method: str, selection_ci: bool = True, extra=None) -> dict:
    """The part of :func:`noise_report` that needs no samples, only the variances: from the Allan deviation
    ``res`` (:class:`~gyrojax.noise.allan.AllanResult`), its IEEE 952 term fit ``ieee``, the GMWM/AVLR model
    ``nm`` (or None for ``method`` ieee952) and the wavelet variance ``est`` it was selected on — the model's ADEV
    with its standard error, the adequacy band and verdict, the derived and headline figures (with the selection's
    intervals) and the notes. ``extra``: entries of the output made from the samples (glitches, spectral lines),
    placed first; their verdict cause (a spectral line) is read from ``extra["spectral_lines"]``."""
    from gyrojax.noise import allan as allan_mod

    notes = list(notes)
    extra = dict(extra or {})
    spectral = extra.get("spectral_lines", [])
    if nm is not None:
        model_adev = nm.adev(res.taus_s)
        model_std = adev_std(nm, res.taus_s)
    else:
        model_adev = ieee.adev(res.taus_s)
        model_std = np.full(len(res.taus_s), np.nan)
    low95, high95 = allan_mod.confidence_interval(res.adev, res.edf, ADEQUACY_CI)
    adq = adequacy(res.taus_s, res.adev, low95, high95, model_adev)
    out = allan_mod.noise_json(res, ieee)
    out["method"] = method
    for k in ("curve_estimator", "classical_adev_deg_per_h"):
        if k in extra:
            out[k] = extra.pop(k)
    out["adev_model_deg_per_h"] = [float(x) for x in model_adev]
    out["adev_model_std"] = [None if not np.isfinite(x) else float(x) for x in model_std]
    out["adequacy"] = {"ci": ADEQUACY_CI, "low": [float(x) for x in low95], "high": [float(x) for x in high95], **adq}
    out.update({k: extra[k] for k in ("glitches",) if k in extra})
    out["wavelet_variance"] = nm.info["wavelet_variance"] if nm is not None else None
    out.update({k: v for k, v in extra.items() if k != "glitches"})
    tau_fit = None if nm is None else nm.info.get("tau_min_s")
    short = nm.info.get("short_scales", "") if nm else ""
    out["adequacy"]["verdict"] = verdict_line(res.taus_s, adq, tau_fit, short, spectral)
    if nm is not None:
        out["derived"] = derived(nm, float(res.taus_s.min()), float(res.taus_s.max()))
        out["model"] = {**nm.to_json(), "parameters": nm.parameters()}
        model_figs = {**out["derived"], **_direct(nm)}
    else:
        model_figs = {k: v for k, v in _direct(ieee).items()}
    curve = headline.curve_readoffs(res)
    b = curve["bias_instability"]
    if nm is not None and model_figs["bias_instability"]["value"] is None and b.get("kind") == "read":
        # the model has no minimum of its own (e.g. a sum of Gauss–Markov terms): read it where the curve is flat
        at_b = read_at(nm, b["tau_s"], 1.0 / BI_FACTOR, "deg/h")
        model_figs["bias_instability"] = {**at_b, "kind": "at the curve's minimum"}
    if nm is not None and selection_ci:
        cands = candidate_fits(nm, est)
        b_tau = b["tau_s"] if b.get("kind") == "read" else None
        model_figs = with_selection(model_figs, cands, float(res.taus_s.min()), float(res.taus_s.max()), b_tau)
    for v in model_figs.values():
        if v.get("ci") is not None:
            v["ci_level"] = headline.TWO_SIGMA
    out["headline"] = headline.compare(model_figs, curve)
    b_terms = ieee.bias_instability
    b_head = out["headline"]["bias_instability"]["curve"]
    if b_terms > 0 and b_head["value"] is not None and abs(b_terms - b_head["value"]) > 0.1 * b_head["value"]:
        notes.append(
            f"terms.bias_instability {b_terms:.4g} deg/h is the IEEE 952 least-squares term fit; the curve's "
            f"flat-minimum read-off (headline) is {b_head['value']:.4g} deg/h at tau = {b_head['tau_s']:.3g} s"
        )
    b_floor = nm.bias_instability if nm is not None else 0.0
    b_model = out["headline"]["bias_instability"]["model"]
    if b_floor > 0 and b_model["value"] is not None and abs(b_floor - b_model["value"]) > 0.1 * b_model["value"]:
        notes.append(
            f"model.bias_instability {b_floor:.4g} deg/h is the model's flicker floor alone; the headline model B "
            f"{b_model['value']:.4g} deg/h is IEEE 952's read-off sigma_min/0.664 of the whole model's ADEV (white "
            "and random walk included)"
        )
    notes += [f"{k}: {v['note']}" for k, v in out["headline"].items() if v["note"]]
    if nm is not None and nm.info.get("j_test"):  # gmwm_select's adequacy gate found no candidate that passes
        notes.append(f"model {nm.info['model']}: {nm.info['j_test']}; it is the least-criterion identified one")
    out["notes"] = notes
    return out


def _direct(spec: NoiseSpec) -> dict:
    """Read-offs that are model parameters themselves: Q and R of a model that has them (and, for the IEEE 952
    term fit, N, B, K), with their standard errors."""
    names = {"quantization": "quantization", "rate_ramp": "rate_ramp"}
    if spec.method == "ieee952":
        names.update(white="arw", bias_instability="bias_instability", random_walk="rrw")
    out = {}
    for k, figure in names.items():
        v = getattr(spec, k)
        if v > 0:
            std = spec.std(k) if k in spec.cov_names else float("nan")
            std = std if math.isfinite(std) else 0.0
            out[figure] = {"value": float(v), "std": std, "ci": log_interval(float(v), std), "unit": UNITS[k]}
            out[figure]["tau_s"] = None
    return out


def verdict_line(taus_s, adq: dict, tau_fit_s: float | None = None, cause: str = "", lines=()) -> str:
    """One line: the model inside the empirical band at every τ, or where it is not, by how much (the largest
    |model/empirical − 1| among those τ, and that misfit in half-widths of the band on the model's side,
    ``band_units`` of :func:`adequacy`) and, when they all lie below the shortest τ the fit used
    (``tau_fit_s``), the cause named there (``cause``: e.g. the sensor's own filter); a spectral line of ``lines``
    (:func:`gyrojax.noise.lines.with_reach`) whose τ range holds those τ (s) is named too
    (:func:`gyrojax.noise.lines.cause`)."""
    from gyrojax.noise import lines as lines_mod

    n = len(taus_s)
    k = adq["n_outside"]
    if k == 0:
        units = adq.get("band_units")
        size = f" (largest misfit {np.max(np.abs(units)):.2g} of the band's half-width)" if units else ""
        return f"model inside the empirical {100 * ADEQUACY_CI:.0f} % band at all {n} taus{size}"
    taus = np.asarray(taus_s, float)
    out_mask = ~np.asarray(adq["inside"], bool)
    dev = np.abs(np.asarray(adq["ratio"], float)[out_mask] - 1.0)
    worst = int(np.argmax(dev))
    t_out = taus[out_mask]
    expected = (1 - ADEQUACY_CI) * n
    tag = "POOR FIT" if k > max(1.0, 2.0 * expected) else "fit"
    units = adq.get("band_units")
    size = f", {abs(np.asarray(units)[out_mask][worst]):.3g}x the band's half-width there" if units else ""
    line = (
        f"{tag}: model outside the empirical {100 * ADEQUACY_CI:.0f} % band at {k} of {n} taus "
        f"(tau {t_out.min():.3g} to {t_out.max():.3g} s), by up to {100 * dev[worst]:.2g} % "
        f"(at tau = {t_out[worst]:.3g} s{size})"
    )
    if tau_fit_s and cause and np.all(t_out < tau_fit_s * (1 + 1e-9)):
        line += f"; all at or below the fitted range: {cause}"
    elif tau_fit_s and cause and np.any(t_out < tau_fit_s):
        line += f"; partly below the fitted range ({cause})"
    by_line = lines_mod.cause(list(lines), t_out)
    if by_line:
        line += f"; {by_line}"
    return line
