"""A plain reference analysis of hand sessions and turntable campaigns: numpy and scipy only, written from the
conventions, sharing no code with gyrojax's physics, noise or inference. It says, for a record whose truth is known,
what a careful analyst with the true noise model would conclude — each planted effect detectable, each null clean —
and so is what gyrojax's diagnosis is judged against.

**The linear Gaussian model.** y = X β + e, e ~ N(0, V), whitened by the Cholesky factor L of V (V = L Lᵀ; ỹ = L⁻¹y,
X̃ = L⁻¹X):

* GLS: β̂ = (X̃ᵀX̃)⁻¹X̃ᵀỹ (Aitken 1935).
* Score (Lagrange-multiplier) test of columns H beside X₀, V known: r̃₀ the whitened residual under H₀, H̃⊥ = (I − P₀)H̃,
  u = H̃⊥ᵀ r̃₀, LM = uᵀ(H̃⊥ᵀH̃⊥)⁻¹u, exactly χ²_k under H₀ (Rao 1948); with V known the score, Wald and likelihood-ratio
  statistics of a linear hypothesis coincide (Engle 1984, Handbook of Econometrics II ch. 13).
* Noncentrality of a planted θ on H: λ = θᵀH̃⊥ᵀH̃⊥θ; the power of the first Holm step of a family of F tests,
  P(χ²_k(λ) > χ²_{k,1−α/F}) (scipy.stats.ncx2), is a lower bound on the chance that Holm finds it.
* Holm's step-down adjustment (Holm 1979, Scand. J. Statist. 6, 65–70).
* REML of variance components V(θ) = V₀ + Σ θ_i D_i, θ_i ≥ 0 (Patterson & Thompson 1971, Biometrika 58, 545):
  −2ℓ_R = log|V| + log|XᵀV⁻¹X| + r̂ᵀV⁻¹r̂ (r̂ the GLS residual), minimised over √θ by L-BFGS-B. REML likelihoods of
  one fixed-effect design are comparable between covariance models (the walk against the independent scatter).
* Forward selection as a diagnosis loop: the candidate of smallest Holm p (ties, p underflowing, by log p) is held
  in the model while its Holm p < α, and the rest are tested again beside it.
* A knee fitted by the profile of |T − T_k| over a grid: the sup of the score statistic over the grid has no χ²
  law (Davies 1987, Biometrika 74, 33–43); its null law is drawn from the Gaussian score process u(T_k) ~ N(0, G),
  G = H̃⊥ᵀH̃⊥ over the grid.

**Hand sessions** (conventions §9.3). The data are the rests' means of each gyro channel (rows 3k + c, rest k, channel
c). The model of rest k: b_c + Σ_j G_cj a_kj (bias and g-sensitivity; the vertical Earth rate Ω sin φ u with
u = a/|a| is ∝ a and rides in G, as §9.3 says). V₀: the white noise of a mean, σ²/n_k I, and the horizontal Earth
rate of an unknown heading, (Ω cos φ)²/2 (I − u uᵀ) (§9.3). The drift between rests adds, per channel:
independent scatter τ² I; a walk of steps σ_s² min(k, l) (rests k, l of one record); a rate random walk K² times
the covariance of the rests' means of a Wiener process (for rests [a_k, b_k] before [a_l, b_l], in h from the
record's first sample: (a_k + b_k)/2; for one rest a_k + (b_k − a_k)/3). The moves (scale factor, misalignment)
carry almost no bias information and are not used. Candidates per channel c (§6 through the channel's IA, OA, SA of
§9.3): ``bias_trend[c]`` (t, h), ``time_quadratic[c]`` ((t − t_mid)², h²), the six g² terms ``D_II[c]`` …
``D_OS[c]``, and with two records ``bias_turn_on[c]`` (1 on the second record's rests).

**Turntable records** (conventions §2–§6; the instrument inputs by tests/power.py, also written from the conventions
alone): y = S_nom i − ω_I (deg/h), the model's columns from §6, the candidates the §6 effects a static test excites
(g² terms, ``bias_trend``, ``bias_temperature``, ``sf_error``, ``ia_misalignment``) and the shapes
``temperature_hinge`` (|T − 20 °C|, seed 001's two slopes about 20 °C), ``temperature_quadratic`` ((T − 20)²) and
``time_quadratic``; V = σ_w² I + σ_gm² exp(−|t_i − t_j|/τ) (§6 white and gauss_markov, σ_w = 60 N/√Δt deg/h).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import linalg, optimize, special, stats

from . import power as pw

CHANNELS = ("x", "y", "z")
AXES = {"x": (0, 1, 2), "y": (1, 2, 0), "z": (2, 0, 1)}  # §9.3: (IA, OA, SA) of each channel
WIE_DPH = 7.2921150e-5 * 180 / np.pi * 3600  # §1, deg/h
G2 = ("II", "OO", "SS", "IO", "IS", "OS")
ALPHA = 0.01


# ---- the linear Gaussian machinery -------------------------------------------------------------------------------


def whitener(v):
    """A function A ↦ L⁻¹A for V = L Lᵀ (V a matrix, or a scalar variance for V = v I)."""
    if np.ndim(v) == 0:
        s = float(np.sqrt(v))
        return lambda a: np.asarray(a, float) / s
    chol = linalg.cholesky(np.asarray(v, float), lower=True)
    return lambda a: linalg.solve_triangular(chol, np.asarray(a, float), lower=True)


def _orth(x):
    """An orthonormal basis of the column space of x (rank by the singular values)."""
    if x.shape[1] == 0:
        return x
    u, s, _ = np.linalg.svd(x, full_matrices=False)
    return u[:, s > 1e-10 * s[0]]


def perp(x0w, hw):
    """H̃⊥ = (I − P₀) H̃ (whitened columns)."""
    q = _orth(x0w)
    return hw - q @ (q.T @ hw)


def score_test(yw, x0w, hw):
    """(LM, df, p) of the whitened columns ``hw`` beside ``x0w`` with V known (module doc)."""
    hp = perp(x0w, hw)
    rw = perp(x0w, yw[:, None])[:, 0]
    qh = _orth(hp)
    df = qh.shape[1]
    if df == 0:
        return 0.0, 0, 1.0
    u = qh.T @ rw
    lm = float(u @ u)
    return lm, df, float(stats.chi2.sf(lm, df))


def noncentrality(x0w, hw, theta):
    """λ = ‖(I − P₀) H̃ θ‖² (module doc)."""
    v = perp(x0w, hw) @ np.atleast_1d(np.asarray(theta, float))
    return float(v @ v)


def power(lam, df, alpha=ALPHA, family=1):
    """P(χ²_df(λ) > χ²_{df, 1−α/family}): the first Holm step, a lower bound on detection."""
    return float(stats.ncx2.sf(stats.chi2.isf(alpha / family, df), df, lam))


def log_chi2_sf(x: float, df: int) -> float:
    """log P(χ²_df > x), past scipy's underflow by the asymptotic series of the upper incomplete gamma function,
    log Q(a, z) ≈ (a − 1) log z − z − log Γ(a) + log(1 + (a − 1)/z + (a − 1)(a − 2)/z²), a = df/2, z = x/2
    (Abramowitz & Stegun 6.5.32)."""
    out = float(stats.chi2.logsf(x, df))
    if np.isfinite(out) or df <= 0:
        return out
    return log_chi2_sf_asymptotic(x, df)


def log_chi2_sf_asymptotic(x: float, df: int) -> float:
    """The asymptotic series of :func:`log_chi2_sf` alone (large x)."""
    a, z = 0.5 * df, 0.5 * x
    return float((a - 1) * np.log(z) - z - special.gammaln(a) + np.log1p((a - 1) / z + (a - 1) * (a - 2) / z**2))


def holm(p):
    """Holm's step-down adjusted p-values, in the input order."""
    p = np.asarray(p, float)
    m = len(p)
    order = np.argsort(p)
    adj = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adj
    return out


def reml(y, x, v0, parts, start=None):
    """REML of θ ≥ 0 in V = v0 + Σ θ_i parts_i: (θ̂, −2ℓ_R at θ̂) (module doc; constants dropped)."""
    y, x = np.asarray(y, float), np.asarray(x, float)

    def neg2l(s):
        v = v0 + sum(si * si * d for si, d in zip(s, parts))
        chol = linalg.cholesky(v, lower=True)
        xw = linalg.solve_triangular(chol, x, lower=True)
        yw = linalg.solve_triangular(chol, y, lower=True)
        q, r = np.linalg.qr(xw)
        res = yw - q @ (q.T @ yw)
        return 2 * np.log(np.diag(chol)).sum() + 2 * np.log(np.abs(np.diag(r))).sum() + res @ res

    if not parts:
        return np.zeros(0), float(neg2l([]))
    scale = np.sqrt(np.mean(np.diag(v0)))
    starts = [start] if start is not None else []
    starts += [np.full(len(parts), f * scale) for f in (0.3, 1.0, 3.0)]
    best = None
    for s0 in starts:
        r = optimize.minimize(
            neg2l, np.sqrt(np.asarray(s0, float) ** 2), method="L-BFGS-B", bounds=[(0, None)] * len(parts)
        )
        if best is None or r.fun < best.fun:
            best = r
    return best.x**2, float(best.fun)


def sup_score(yw, x0w, hws, draws=20000, seed=0):
    """(sup LM, index of the sup, p) of one-column candidates ``hws`` (n, G) tested one at a time beside ``x0w``;
    p from the Gaussian score process (module doc)."""
    hp = perp(x0w, hws)
    rw = perp(x0w, yw[:, None])[:, 0]
    nrm = np.linalg.norm(hp, axis=0)
    z = (hp.T @ rw) / nrm  # standard normal under H₀ at each grid point
    lm = z * z
    corr = (hp.T @ hp) / np.outer(nrm, nrm)
    w, vec = np.linalg.eigh(corr)
    root = vec * np.sqrt(np.clip(w, 0, None))
    sim = np.random.default_rng(seed).standard_normal((draws, len(w))) @ root.T
    sup_null = np.max(sim * sim, axis=1)
    i = int(np.argmax(lm))
    return float(lm[i]), i, float((1 + np.sum(sup_null >= lm[i])) / (1 + draws))


# ---- records, read as files -------------------------------------------------------------------------------------


@dataclass
class RecordFiles:
    """A record read from its two files (conventions §5): ``meta`` (the JSON) and ``columns`` (name → array)."""

    meta: dict
    columns: dict = field(default_factory=dict)


def read_record(path) -> RecordFiles:
    """``NAME.json`` and ``NAME.csv`` (either path) with json and numpy."""
    p = Path(path)
    meta = json.loads(p.with_suffix(".json").read_text())
    head = p.with_suffix(".csv").read_text().split("\n", 1)[0].split(",")
    data = np.loadtxt(p.with_suffix(".csv"), delimiter=",", skiprows=1, ndmin=2)
    return RecordFiles(meta, {k: data[:, i] for i, k in enumerate(head)})


# ---- hand sessions --------------------------------------------------------------------------------------------


@dataclass
class Rests:
    """The rests of one or more triad records (module doc): gyro means ``y`` (K, 3) deg/h, accelerometer means ``a``
    (K, 3) g, sample counts ``n``, mean time ``t_h``, first and last sample time ``span_h`` (K, 2) from the record's
    first sample, record index ``record`` and rank within the record ``rank``."""

    y: np.ndarray
    a: np.ndarray
    n: np.ndarray
    t_h: np.ndarray
    span_h: np.ndarray
    record: np.ndarray
    rank: np.ndarray
    latitude_deg: float


def rests(records) -> Rests:
    """The rests (static segments, §9.3) of triad records (paths, or records in memory with ``meta`` and
    ``columns``), in time order."""
    out = {k: [] for k in ("y", "a", "n", "t_h", "span_h", "record", "rank")}
    lat = None
    for ri, item in enumerate(records):
        rec = item if hasattr(item, "columns") else read_record(item)
        lat = rec.meta["site"]["latitude_deg"]
        cols = rec.columns
        t, seg = np.asarray(cols["time_s"], float), np.asarray(cols["segment"]).astype(int)
        g = np.column_stack([cols[f"gyro_{c}_dps"] for c in CHANNELS]) * 3600.0
        a = np.column_stack([cols[f"acc_{c}_g"] for c in CHANNELS])
        statics = [s["label"] for s in rec.meta["segments"] if s["type"] == "static"]
        statics.sort(key=lambda lab: t[seg == lab][0])
        for k, lab in enumerate(statics):
            sel = seg == lab
            out["y"].append(g[sel].mean(axis=0))
            out["a"].append(a[sel].mean(axis=0))
            out["n"].append(sel.sum())
            out["t_h"].append(t[sel].mean() / 3600.0)
            out["span_h"].append(((t[sel][0] - t[0]) / 3600.0, (t[sel][-1] - t[0]) / 3600.0))
            out["record"].append(ri)
            out["rank"].append(k)
    arr = {k: np.asarray(v, float) for k, v in out.items()}
    return Rests(
        arr["y"], arr["a"], arr["n"], arr["t_h"], arr["span_h"], arr["record"].astype(int), arr["rank"], float(lat)
    )


def _per_channel(block):
    """A (K, K) covariance of one channel's rests spread on the (3K, 3K) rows, channels independent."""
    return np.kron(block, np.eye(3))


def triad_covariances(r: Rests, noise_dps: float) -> dict:
    """V₀ (white noise of the means + horizontal Earth rate) and the drift components ``scatter``, ``steps``,
    ``rrw`` (per unit variance: (deg/h)², (deg/h)² per step, (deg/h/√h)²) over the rows 3k + c (module doc)."""
    k = len(r.n)
    q = (noise_dps * 3600.0) ** 2
    u = r.a / np.linalg.norm(r.a, axis=1, keepdims=True)
    h2 = (WIE_DPH * np.cos(np.radians(r.latitude_deg))) ** 2 / 2
    v0 = np.zeros((3 * k, 3 * k))
    for i in range(k):
        v0[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = q / r.n[i] * np.eye(3) + h2 * (np.eye(3) - np.outer(u[i], u[i]))
    same = r.record[:, None] == r.record[None, :]
    steps = np.minimum(r.rank[:, None], r.rank[None, :]) * same
    a0, b0 = r.span_h[:, 0], r.span_h[:, 1]
    mid = 0.5 * (a0 + b0)
    rrw = np.where(b0[:, None] <= a0[None, :], mid[:, None], mid[None, :])  # the earlier rest's mid time
    np.fill_diagonal(rrw, a0 + (b0 - a0) / 3)
    return {"v0": v0, "scatter": np.eye(3 * k), "steps": _per_channel(steps), "rrw": _per_channel(rrw * same)}


def _spread(col, c):
    """One channel's (K,) column on the (3K,) rows."""
    out = np.zeros(3 * len(col))
    out[CHANNELS.index(c) :: 3] = col
    return out


def triad_design(r: Rests):
    """(X₀, candidates): the bias and g-sensitivity columns of every channel (12), and the candidates of the module
    doc, each {name: (3K, k) columns}."""
    x0 = []
    for c in CHANNELS:
        x0.append(_spread(np.ones(len(r.n)), c))
        x0.extend(_spread(r.a[:, j], c) for j in range(3))
    cand = {}
    t_mid = 0.5 * (r.t_h.min() + r.t_h.max())
    for c in CHANNELS:
        i = dict(zip("IOS", AXES[c]))
        cand[f"bias_trend[{c}]"] = _spread(r.t_h, c)[:, None]
        cand[f"time_quadratic[{c}]"] = _spread((r.t_h - t_mid) ** 2, c)[:, None]
        for pq in G2:
            cand[f"D_{pq}[{c}]"] = _spread(r.a[:, i[pq[0]]] * r.a[:, i[pq[1]]], c)[:, None]
        if r.record.max() > 0:
            cand[f"bias_turn_on[{c}]"] = _spread((r.record > 0).astype(float), c)[:, None]
    return np.column_stack(x0), cand


@dataclass
class Reference:
    """One reference analysis: the variance components (by name), −2ℓ_R, every candidate's LM, its degrees of
    freedom, p and Holm p."""

    components: dict
    neg2l: float
    lm: dict
    df: dict
    p: dict
    p_holm: dict

    def log_p(self, name) -> float:
        """log p of one candidate (ranks candidates whose p underflows)."""
        return log_chi2_sf(self.lm[name], self.df[name])

    @property
    def smallest_holm(self):
        """(name, Holm p) of the most significant candidate."""
        name = min(self.p_holm, key=lambda n: (self.p_holm[n], self.log_p(n)))
        return name, self.p_holm[name]

    def significant(self, alpha=ALPHA):
        return sorted((k for k, v in self.p_holm.items() if v < alpha), key=self.log_p)


def _tested(yw, xw, candidates: dict, wh, held=()):
    """{name: (LM, df, p)} of every candidate not ``held``, whitened by ``wh``, beside ``xw``."""
    return {n: score_test(yw, xw, wh(h)) for n, h in candidates.items() if n not in held}


def _reference(components, n2l, tested: dict) -> Reference:
    lm, df, p = ({n: t[i] for n, t in tested.items()} for i in range(3))
    return Reference(dict(components), n2l, lm, df, p, dict(zip(p, holm(list(p.values())))))


def analyse(y, x0, v0, parts: dict, candidates: dict, components=None, extra_x=()):
    """The reference analysis of y: variance components ``parts`` by REML (or fixed ``components``), then the
    score test of each candidate beside X₀ (and ``extra_x`` names of candidates held in the model), Holm."""
    x = np.column_stack([x0] + [candidates[n] for n in extra_x])
    names = list(parts)
    if components is None:
        theta, n2l = reml(y, x, v0, [parts[n] for n in names])
        components = dict(zip(names, theta))
    else:
        n2l = float("nan")
    v = v0 + sum(components[n] * parts[n] for n in names)
    wh = whitener(v)
    return _reference(components, n2l, _tested(wh(y), wh(x), candidates, wh, extra_x))


def forward(test, candidates, alpha=ALPHA, steps=4):
    """Forward selection as a diagnosis loop: ``test(held)`` → Reference of the candidates beside X₀ and the names
    ``held``; the most significant one is held while its Holm p < α. Returns [(name, LM, Holm p)] of what was
    taken, and the last Reference (what nothing more explains)."""
    taken, held = [], []
    for _ in range(steps):
        ref = test(tuple(held))
        name, p = ref.smallest_holm
        if p >= alpha:
            break
        taken.append((name, ref.lm[name], p))
        held.append(name)
    else:
        ref = test(tuple(held))
    return taken, ref


def triad_select(records, noise_dps: float, drift: str, components=None, alpha=ALPHA):
    """:func:`forward` over the triad candidates, the components re-estimated by REML at each step (or fixed)."""
    r = rests(records)
    cov = triad_covariances(r, noise_dps)
    x0, cand = triad_design(r)
    parts = {n: cov[n] for n in drift.split("+") if n != "none"}
    return forward(lambda held: analyse(r.y.ravel(), x0, cov["v0"], parts, cand, components, held), cand, alpha)


def triad_reference(paths, noise_dps: float, drift: str, components=None, extra_x=(), names=None):
    """The reference analysis of triad records with drift model ``drift``: ``"scatter"``, ``"steps"``, ``"rrw"``,
    ``"steps+scatter"`` or ``"none"``; components by REML unless given ({name: variance}); ``names`` restricts the
    candidates tested (and the Holm family) to those."""
    r = rests(paths)
    cov = triad_covariances(r, noise_dps)
    x0, cand = triad_design(r)
    if names is not None:
        cand = {n: cand[n] for n in list(names) + list(extra_x)}
    parts = {n: cov[n] for n in drift.split("+") if n != "none"}
    return analyse(r.y.ravel(), x0, cov["v0"], parts, cand, components, extra_x)


def triad_noncentrality(records, noise_dps: float, components: dict, planted: dict, beside=()) -> float:
    """λ of the planted candidates {name: value} (deg/h per unit) beside X₀ and the candidates ``beside``, at the
    true variance components {"steps" | "rrw" | "scatter": variance} (module doc)."""
    r = rests(records)
    cov = triad_covariances(r, noise_dps)
    x0, cand = triad_design(r)
    wh = whitener(cov["v0"] + sum(v * cov[n] for n, v in components.items()))
    x = np.column_stack([x0] + [cand[n] for n in beside])
    h = np.column_stack([cand[n] for n in planted])
    return noncentrality(wh(x), wh(h), list(planted.values()))


def triad_gls(records, noise_dps: float, components: dict, held=()) -> dict:
    """GLS (Aitken) of the rests beside X₀ and the candidates ``held`` at the given variance components {"steps" |
    "rrw" | "scatter": variance}: {name of a held candidate's column: (β̂, σ)} in deg/h per unit."""
    r = rests(records)
    cov = triad_covariances(r, noise_dps)
    x0, cand = triad_design(r)
    wh = whitener(cov["v0"] + sum(v * cov[n] for n, v in components.items()))
    x = np.column_stack([x0] + [cand[n] for n in held])
    xw = wh(x)
    beta = np.linalg.lstsq(xw, wh(r.y.ravel()), rcond=None)[0]
    sd = np.sqrt(np.diag(np.linalg.inv(xw.T @ xw)))
    k = x0.shape[1]
    return {n: (float(beta[k + i]), float(sd[k + i])) for i, n in enumerate(held)}


def walk_against_scatter(paths, noise_dps: float):
    """−2ℓ_R of the scatter-only, steps-only and both-components models (same fixed effects): the data's preference
    for a walk, and the nested likelihood ratio of the walk beside the scatter (boundary: p = ½ P(χ²₁ > LR))."""
    r = rests(paths)
    cov = triad_covariances(r, noise_dps)
    x0, _ = triad_design(r)
    y = r.y.ravel()
    out = {}
    for name, parts in (("scatter", ["scatter"]), ("steps", ["steps"]), ("both", ["scatter", "steps"])):
        theta, out[name] = reml(y, x0, cov["v0"], [cov[p] for p in parts])
        out[f"{name}_components"] = dict(zip(parts, theta))
    lr = max(out["scatter"] - out["both"], 0.0)
    out["lr_walk"] = lr
    out["p_walk"] = 0.5 * float(stats.chi2.sf(lr, 1))
    return out


def rest_residual_lag1(paths, noise_dps: float, drift="scatter"):
    """Lag-1 autocorrelation, per channel, of the GLS residuals of the rest means (time order) under ``drift``."""
    r = rests(paths)
    cov = triad_covariances(r, noise_dps)
    x0, _ = triad_design(r)
    y = r.y.ravel()
    parts = [cov[n] for n in drift.split("+")]
    theta, _ = reml(y, x0, cov["v0"], parts)
    v = cov["v0"] + sum(t * d for t, d in zip(theta, parts))
    wh = whitener(v)
    beta = np.linalg.lstsq(wh(x0), wh(y), rcond=None)[0]
    res = (y - x0 @ beta).reshape(-1, 3)
    res = res - res.mean(axis=0)
    return [float(res[1:, i] @ res[:-1, i] / (res[:, i] @ res[:, i])) for i in range(3)]


# ---- turntable records ------------------------------------------------------------------------------------------

TURNTABLE_NAMED = (
    *("D_II", "D_OO", "D_SS", "D_IO", "D_IS", "D_OS"),
    *("bias_trend", "bias_temperature", "sf_error", "ia_misalignment"),
)
"""The §6 effects a static turntable test excites, candidates of the reference (table tilt left out: its regressor
needs the kinematics differentiated)."""


@dataclass
class Turntable:
    """Turntable records as the reference sees them: y = S_nom i − ω_I (deg/h), the inputs ``x`` (tests/power.py),
    the sample times (s) and the sample interval of each row."""

    y: np.ndarray
    x: dict
    time_s: np.ndarray
    dt_s: np.ndarray


def turntable(paths) -> Turntable:
    """Turntable records read as files (rebalance mode, §4–§5)."""
    ys, xs, ts, dts = [], [], [], []
    for path in paths:
        rec = read_record(path)
        x = pw.inputs(rec)
        ys.append(rec.columns["current_mA"] * rec.meta["scale_factor_deg_per_h_per_mA"] - x["w_I"])
        xs.append(x)
        t = rec.columns["time_s"]
        ts.append(t)
        dts.append(np.full(len(t), np.median(np.diff(t))))
    x = {k: np.concatenate([d[k] for d in xs]) for k in xs[0]}
    return Turntable(np.concatenate(ys), x, np.concatenate(ts), np.concatenate(dts))


def turntable_columns(tt: Turntable, names) -> np.ndarray:
    """The §6 regressors of the effects ``names`` (deg/h per report unit) and of the shapes of the module doc."""
    x, cols = tt.x, []
    for n in names:
        if n == "temperature_hinge":
            cols.append(np.abs(x["T"] - 20.0))
        elif n == "temperature_quadratic":
            cols.append((x["T"] - 20.0) ** 2)
        elif n == "time_quadratic":
            th = x["t_h"]
            cols.append((th - 0.5 * (th.min() + th.max())) ** 2)
        else:
            cols.extend(pw.effect_part(x, {c: 1.0}) for c in pw.COEFFICIENTS[n])
    return np.column_stack(cols)


def turntable_covariance(tt: Turntable, white_arw: float, gauss_markov=None):
    """V of §6's white (N deg/√h: σ² = (60 N)²/Δt) and gauss_markov ((σ deg/h, τ s)) drift: a scalar when white."""
    q = (60.0 * white_arw) ** 2 / tt.dt_s
    if gauss_markov is None:
        return float(q[0]) if np.ptp(q) == 0 else np.diag(q)
    sd, tau = gauss_markov
    return np.diag(q) + sd * sd * np.exp(-np.abs(tt.time_s[:, None] - tt.time_s[None, :]) / tau)


SHAPES = ("temperature_hinge", "temperature_quadratic", "time_quadratic")
KNEES = np.arange(12.0, 30.01, 0.5)
"""The knee grid of the fitted hinge, °C."""


def turntable_reference(paths, model, white_arw, gauss_markov=None, knees=KNEES):
    """The reference analysis of turntable records at the true noise: every named candidate and shape tested
    beside ``model`` (Holm), each shape also beside every named candidate (and the two temperature shapes each beside
    the other), and the hinge's knee fitted (sup score over ``knees`` beside the model and the linear temperature
    term)."""
    tt = turntable(paths)
    v = turntable_covariance(tt, white_arw, gauss_markov)
    wh = whitener(v)
    x0 = turntable_columns(tt, model)
    yw, x0w = wh(tt.y), wh(x0)
    named = [n for n in TURNTABLE_NAMED if n not in model and not (n == "bias_temperature" and np.ptp(tt.x["T"]) == 0)]
    lm, p, beside_named = {}, {}, {}
    for n in named + list(SHAPES):
        lm[n], _, p[n] = score_test(yw, x0w, wh(turntable_columns(tt, [n])))
    xall = wh(np.column_stack([x0, turntable_columns(tt, named)]))
    for n in SHAPES:
        beside_named[n] = score_test(yw, xall, wh(turntable_columns(tt, [n])))[0]
    for a, b in (("temperature_hinge", "temperature_quadratic"), ("temperature_quadratic", "temperature_hinge")):
        xab = np.column_stack([xall, wh(turntable_columns(tt, [b]))])
        beside_named[f"{a} beside {b}"] = score_test(yw, xab, wh(turntable_columns(tt, [a])))[0]
    adj = dict(zip(p, holm(list(p.values()))))
    out = {"lm": lm, "p": p, "p_holm": adj, "lm_beside_named": beside_named, "named": named}
    if np.ptp(tt.x["T"]) > 0:
        base = model if "bias_temperature" in model else list(model) + ["bias_temperature"]
        xb = wh(turntable_columns(tt, base))
        hinge = wh(np.column_stack([np.abs(tt.x["T"] - k) for k in knees]))
        sup, i, p_sup = sup_score(yw, xb, hinge)
        out |= {"knee_sup_lm": sup, "knee_p": p_sup, "knee_grid_best": float(knees[i])}
        out |= fit_knee(tt, base, wh, float(knees[i]))
    return out


def turntable_select(paths, model, white_arw, gauss_markov=None, alpha=ALPHA):
    """:func:`forward` over the turntable candidates (named and shapes) at the true noise."""
    tt = turntable(paths)
    wh = whitener(turntable_covariance(tt, white_arw, gauss_markov))
    named = [n for n in TURNTABLE_NAMED if n not in model and not (n == "bias_temperature" and np.ptp(tt.x["T"]) == 0)]
    cand = {n: turntable_columns(tt, [n]) for n in named + list(SHAPES)}
    x0 = turntable_columns(tt, model)
    yw = wh(tt.y)

    def test(held):
        xw = wh(np.column_stack([x0] + [cand[n] for n in held]))
        return _reference({}, float("nan"), _tested(yw, xw, cand, wh, held))

    return forward(test, cand, alpha)


def turntable_noncentrality(paths, model, white_arw, gauss_markov, planted: dict, beside_named=True) -> float:
    """λ of the planted effects and shapes {name: value} (one coefficient each) beside ``model`` and, with
    ``beside_named``, every named candidate the records excite (module doc), at the true noise."""
    tt = turntable(paths)
    wh = whitener(turntable_covariance(tt, white_arw, gauss_markov))
    named = [n for n in TURNTABLE_NAMED if n not in model and n not in planted] if beside_named else []
    x = wh(turntable_columns(tt, list(model) + named))
    return noncentrality(x, wh(turntable_columns(tt, list(planted))), list(planted.values()))


def fit_knee(tt: Turntable, base, wh, start: float) -> dict:
    """The knee T_k of e + … + D_HINGE |T − T_k| by GLS profile (bounded search within 1 °C of ``start``) and its σ from
    the Gauss–Newton Jacobian (the derivative of |T − T_k| in T_k is −sign(T − T_k))."""
    xb = turntable_columns(tt, base)
    yw = wh(tt.y)
    temp = tt.x["T"]

    def rss(k):
        xw = wh(np.column_stack([xb, np.abs(temp - k)]))
        beta = np.linalg.lstsq(xw, yw, rcond=None)[0]
        res = yw - xw @ beta
        return float(res @ res), beta

    r = optimize.minimize_scalar(lambda k: rss(k)[0], bounds=(start - 1.0, start + 1.0), method="bounded")
    k = float(r.x)
    _, beta = rss(k)
    jac = wh(np.column_stack([xb, np.abs(temp - k), -beta[-1] * np.sign(temp - k)]))
    cov = np.linalg.inv(jac.T @ jac)
    return {"knee_C": k, "knee_std_C": float(np.sqrt(cov[-1, -1])), "hinge": float(beta[-1])}
