"""The power of the diagnosis' score test for a hidden effect, computed from the records' design (issue 23).

For a campaign whose random drift is white with angle random walk N (deg/√h), each rebalance sample of the
indicated rate has standard deviation σ = 60 N / √Δt deg/h (IEEE 952 annex C; Δt the sample interval in s). The
score (Lagrange-multiplier) test of an effect with coefficients θ (k of them) beside the model's terms is, in large
samples, χ²_k with noncentrality

    λ = θᵀ (J_hᵀ M J_h) θ = θᵀ Cov(θ̂)⁻¹ θ,   M = I − J_0 (J_0ᵀ J_0)⁻¹ J_0ᵀ,

J_0 and J_h the whitened regressors of the model's and the hidden effect's coefficients, when the noise variance is
known. The score statistic of the diagnosis is computed with the noise estimated from the model's own residual,
which the missing effect inflates by the factor 1 + λ/n (n samples): its noncentrality is n λ / (n + λ) (the
LM = n R² form; Engle 1984, Handbook of Econometrics II, ch. 13), which is what :func:`noncentrality` returns. The
candidate is
significant when its Holm-adjusted p-value is below α; with m tests in the family the first Holm step is α/m, the
hardest, so ``power = P(χ²_k(λ) > χ²_{k, 1−α/m})`` is a lower bound on the probability that the candidate is found
significant (scipy.stats.ncx2).

The regressors are written here from conventions §2–§6 alone (numpy and scipy's rotations, no gyrojax code): the
instrument inputs from the record's table axes, angles, rates, latitude and gravity; each coefficient's regressor
from its contribution to ω_ind (conventions §6); the table-tilt angles by central differences of the indicated rate
(exact: ω_ind is linear in the small rotation).

The diagnosis estimates the noise model (white + Gauss–Markov) instead of knowing it, and a slow effect can pass in
part for colour. Measured on the campaigns of tests/test_diagnose.py (seed 11 and the vendored examples), its
statistic was 0.97–1.02 × the noncentrality below for every effect but the temperature sensitivity (0.63 ×: a slow
temperature profile resembles drift). :func:`power` therefore counts on 0.9 × the noncentrality for effects of the
instrument's inputs and the table set-up (``MARGIN``), and on half of it for the effects slow in time, which drift
can imitate (``SLOW_MARGIN``, :func:`margin`).
"""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.spatial.transform import Rotation

G0 = 9.80665
WIE = 7.2921150e-5
DPH = np.pi / 180 / 3600  # deg/h in rad/s
AS = np.pi / 180 / 3600  # arcsec in rad

COEFFICIENTS = {  # conventions §6: effect → its coefficients
    **{n: (n,) for n in ("D_F", "D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS", "D_IO", "D_IS", "D_OS")},
    "sf_error": ("E_SF",),
    "sf_asymmetry": ("E_A",),
    "sf_quadratic": ("E_2",),
    "ia_misalignment": ("M_O", "M_S"),
    "bias_trend": ("D_T",),
    "bias_temperature": ("D_TEMP",),
    "table_tilt": ("delta_E", "delta_N"),
    "table_azimuth": ("delta_U",),
}
SETUP = ("delta_E", "delta_N", "delta_U")
MARGIN = 0.9  # the share of the noncentrality the power counts on (module doc) ...
SLOW_MARGIN = 0.5  # ... and for effects slow in time
SLOW = ("bias_trend", "bias_temperature")


def _rates_dps(cols, name, angles_deg):
    """The table rate about one axis, deg/s: the record's column, or (constant-rate segments) from the angles."""
    if f"rate_{name}_dps" in cols:
        return np.asarray(cols[f"rate_{name}_dps"], float)
    t = np.asarray(cols["time_s"], float)
    seg = np.asarray(cols["segment"]) if "segment" in cols else np.zeros_like(t)
    out = np.zeros_like(t)
    for s in np.unique(seg):
        i = np.flatnonzero(seg == s)
        if len(i) > 1:
            out[i] = np.polyfit(t[i], angles_deg[i], 1)[0]
    return out


def inputs(record, delta_arcsec=(0.0, 0.0, 0.0)) -> dict:
    """Instrument inputs of each sample (conventions §2–§4): w_I, w_O, w_S in deg/h, a_I, a_O, a_S in g, t_h, T."""
    meta, cols = record.meta, record.columns
    lat = np.deg2rad(meta["site"]["latitude_deg"])
    omega = WIE * np.array([0.0, np.cos(lat), np.sin(lat)])
    f = np.array([0.0, 0.0, meta["site"]["gravity_mps2"]])
    d = np.asarray(delta_arcsec, float) * AS
    base = np.eye(3) + np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    axes = [np.asarray(a["axis_enu"], float) for a in meta["table"]["axes"]]
    names = [a["name"] for a in meta["table"]["axes"]]
    inst = meta["instrument"]
    ia, oa, sa = (np.asarray(inst[k], float) for k in ("ia", "oa", "sa"))
    n = len(cols["time_s"])
    c = np.broadcast_to(base, (n, 3, 3)).copy()
    w_lp = np.zeros((n, 3))
    for u, name in zip(axes, names):
        ang = np.asarray(cols[f"angle_{name}_deg"], float)
        rate = np.deg2rad(_rates_dps(cols, name, ang))
        w_lp += rate[:, None] * np.einsum("nij,j->ni", c, u)  # B R(u_1,θ_1)…R(u_{i−1},θ_{i−1}) u_i
        c = c @ Rotation.from_rotvec(np.outer(np.deg2rad(ang), u)).as_matrix()
    w_p = np.einsum("nij,ni->nj", c, omega + w_lp)  # Cᵀ(Ω + ω_LP): platform coordinates
    f_p = np.einsum("nij,i->nj", c, f)
    out = {f"w_{k}": w_p @ v / DPH for k, v in zip("IOS", (ia, oa, sa))}
    out |= {f"a_{k}": f_p @ v / G0 for k, v in zip("IOS", (ia, oa, sa))}
    out["t_h"] = np.asarray(cols["time_s"], float) / 3600
    out["T"] = np.asarray(cols["temperature_C"], float) if "temperature_C" in cols else np.full(n, 20.0)
    return out


def effect_part(x: dict, coefficients: dict) -> np.ndarray:
    """ω_ind − ω_I, deg/h, of the conventions §4/§6 model with these coefficients (report units)."""
    k = coefficients.get
    out = k("D_F", 0.0) + sum(k(f"D_{a}", 0.0) * x[f"a_{a}"] for a in "IOS")
    out = out + sum(k(f"D_{a}{b}", 0.0) * x[f"a_{a}"] * x[f"a_{b}"] for a, b in ("II", "OO", "SS", "IO", "IS", "OS"))
    w = x["w_I"]
    out = out + 1e-6 * (k("E_SF", 0.0) * w + k("E_A", 0.0) * np.abs(w) + k("E_2", 0.0) * w * w / 3600)
    out = out + AS * (k("M_O", 0.0) * x["w_O"] + k("M_S", 0.0) * x["w_S"])
    return out + k("D_T", 0.0) * x["t_h"] + k("D_TEMP", 0.0) * (x["T"] - 20.0)


def regressors(record, names, truth: dict) -> np.ndarray:
    """Columns ∂ω_ind/∂c for each coefficient c of ``names`` (effects), deg/h per report unit, at ``truth``."""
    x = inputs(record)
    cols = []
    for c in (c for n in names for c in COEFFICIENTS[n]):
        if c in SETUP:
            h = np.zeros(3)
            h[SETUP.index(c)] = 1.0  # arcsec; ω_ind is linear in the small rotation, so the difference is exact
            hi, lo = inputs(record, h), inputs(record, -h)
            cols.append((hi["w_I"] + effect_part(hi, truth) - lo["w_I"] - effect_part(lo, truth)) / 2)
        else:
            cols.append(effect_part(x, {c: 1.0}))
    return np.column_stack(cols)


def noncentrality(records, model, hidden, truth: dict, white_arw: float) -> float:
    """Noncentrality n λ / (n + λ) of the score test of effect ``hidden`` beside the effects ``model`` (module doc),
    white noise N = ``white_arw`` deg/√h; ``truth`` holds the coefficients in report units (set-up angles as
    ``delta_E``, ``delta_N``, ``delta_U`` in arcsec)."""
    j0, jh = [], []
    for r in records:
        sigma = 60.0 * white_arw / np.sqrt(np.median(np.diff(np.asarray(r.columns["time_s"], float))))
        j0.append(regressors(r, model, truth) / sigma)
        jh.append(regressors(r, [hidden], truth) / sigma)
    j0, jh = np.vstack(j0), np.vstack(jh)
    resid = jh - j0 @ np.linalg.lstsq(j0, jh, rcond=None)[0]
    theta = np.array([truth.get(c, 0.0) for c in COEFFICIENTS[hidden]])
    lam = float(theta @ (resid.T @ resid) @ theta)
    return len(j0) * lam / (len(j0) + lam)


def margin(hidden: str) -> float:
    """The share of the noncentrality :func:`power` counts on for effect ``hidden`` (module doc)."""
    return SLOW_MARGIN if hidden in SLOW else MARGIN


def power(lam: float, df: int, alpha: float, family: int, margin: float = SLOW_MARGIN) -> float:
    """P(χ²_df(margin·λ) > χ²_df quantile at 1 − α/family): the first Holm step, a lower bound on detection."""
    return float(stats.ncx2.sf(stats.chi2.isf(alpha / family, df), df, margin * lam))
