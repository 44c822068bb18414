"""The power of the triad diagnosis' score test for a planted effect, from the session's design alone.

Written from the conventions (§4, §6 and the triad page) with numpy and scipy's rotations, no gyrojax code. Each
coefficient of channel c adds f(t) (deg/h) to the indicated rate of channel c, its regressor f from conventions §6
on the channel's inputs (IA, OA, SA cyclic: x (x, y, z), y (y, z, x), z (z, x, y)):

* a static pose's mean: the mean of f over the pose, standard deviation √(q/n + τ_b²) (q the white noise's
  variance per sample, τ_b the fit's stated per-pose bias scatter);
* a gravity-to-gravity move: the attitude error at the end of the move that f causes when integrated with the
  true rates, ε = Σ_l A_lᵀ e_c f̄_l dt (A_l the rotation after step l, first order), seen by the move's residual in
  the plane ⟂ the final Up (ε × u), standard deviation √(q n dt² + τ_m²) per component (τ_m the fit's stated
  per-move angle noise).

The noncentrality of the candidate beside the model's coefficients is λ = ‖(I − P₀) X θ‖² over the whitened rows,
taken as n λ / (n + λ) (n the rows less the model's rank: the score statistic's σ̃² comes from the residual the
missing effect inflates, the LM = n R² form of tests/power.py); ``power`` is P(χ²_k(m λ) > χ²_{k, 1−α/F}) for a
family of F tests and a margin m (the rotations are taken as the indicated ones, and the fit's variance components
absorb part of a missing effect; measured statistic / noncentrality 0.9–1.0 for E_A and E_2, 0.44–0.78 for D_T).
"""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.spatial.transform import Rotation

FRAMES = {"x": (0, 1, 2), "y": (1, 2, 0), "z": (2, 0, 1)}
PPM, ARCSEC = 1e-6, np.pi / 180 / 3600
DPH = np.pi / 180 / 3600  # deg/h in rad/s
LINEAR = ("D_F", "D_I", "D_O", "D_S", "E_SF", "M_O", "M_S")


def regressor(coef: str, channel: str, w_dph, a_g, t_h):
    """f(t) (deg/h per coefficient unit) of one coefficient on one channel (conventions §6)."""
    i, o, s = FRAMES[channel]
    wi = w_dph[:, i]
    table = {
        "D_F": np.ones(len(t_h)),
        "D_I": a_g[:, i],
        "D_O": a_g[:, o],
        "D_S": a_g[:, s],
        "E_SF": PPM * wi,
        "M_O": ARCSEC * w_dph[:, o],
        "M_S": ARCSEC * w_dph[:, s],
        "E_A": PPM * np.abs(wi),
        "E_2": PPM * wi * (wi / 3600.0),
        "D_T": t_h,
    }
    return table[coef]


def _rows(record, coefs, noise_dps: float, tau_b_dph: float, tau_m_deg: float) -> np.ndarray:
    """Whitened rows (n_rows, len(coefs)) of the coefficients ``coefs`` = [(name, channel)]."""
    cols = record.columns
    t = np.asarray(record.time_s, float)
    w = np.stack([np.asarray(cols[f"gyro_{c}_dps"], float) for c in "xyz"], axis=1) * 3600.0
    a = np.stack([np.asarray(cols[f"acc_{c}_g"], float) for c in "xyz"], axis=1)
    seg = np.asarray(cols["segment"]).astype(int)
    q = (noise_dps * 3600.0) ** 2
    dt = float(np.median(np.diff(t)))
    rows = []
    for spec in record.meta["segments"]:
        sel = np.flatnonzero(seg == spec["label"])
        if spec["type"] == "static":
            sd = np.sqrt(q / len(sel) + tau_b_dph**2)
            wv = np.zeros((len(sel), 3))  # at rest the body turns with the Earth only: negligible beside the moves
            for ch in "xyz":
                row = np.zeros(len(coefs))
                for k, (name, c) in enumerate(coefs):
                    if c == ch:
                        row[k] = regressor(name, ch, wv, a[sel], t[sel] / 3600.0).mean() / sd
                rows.append(row)
        elif spec["type"] == "move":
            lo, hi = max(sel[0] - 1, 0), min(sel[-1] + 2, len(t))
            wr = np.radians(w[lo:hi] / 3600.0)
            steps = 0.5 * (wr[1:] + wr[:-1]) * dt
            incr = Rotation.from_rotvec(steps)
            after = [Rotation.identity()] * len(steps)  # A_l: the rotation of the steps after step l
            acc_r = Rotation.identity()
            for lidx in range(len(steps) - 1, -1, -1):
                after[lidx] = acc_r
                acc_r = incr[lidx] * acc_r
            mats = np.stack([r.as_matrix() for r in after])  # (L, 3, 3)
            u_to = a[seg == spec["to"]].mean(axis=0)
            u_to /= np.linalg.norm(u_to)
            sd = np.sqrt((noise_dps * np.pi / 180) ** 2 * (hi - lo) * dt**2 + np.radians(tau_m_deg) ** 2)
            block = np.zeros((3, len(coefs)))
            for k, (name, ch) in enumerate(coefs):
                f = regressor(name, ch, w[lo:hi], a[lo:hi], t[lo:hi] / 3600.0) * DPH
                fbar = 0.5 * (f[1:] + f[:-1]) * dt
                e = np.zeros(3)
                e["xyz".index(ch)] = 1.0
                eps = np.einsum("lji,j,l->i", mats, e, fbar)  # Σ A_lᵀ e_c f̄_l
                block[:, k] = np.cross(eps, u_to) / sd
            rows.extend(block)
    return np.array(rows)


def noncentrality(record, planted: dict, noise_dps: float, tau_b_dph=0.0, tau_m_deg=0.0) -> float:
    """λ of the planted coefficients {"E_A[x]": value} beside the linear model of every channel (module doc)."""
    model = [(n, c) for c in "xyz" for n in LINEAR]
    hidden = [(k.split("[")[0], k[-2]) for k in planted]
    rows = _rows(record, model + hidden, noise_dps, tau_b_dph, tau_m_deg)
    j0, xh = rows[:, : len(model)], rows[:, len(model) :]
    v = xh @ np.array(list(planted.values()))
    u, s, _ = np.linalg.svd(j0 / np.linalg.norm(j0, axis=0).clip(1e-300), full_matrices=False)
    u = u[:, s > 1e-10 * s[0]]
    res = v - u @ (u.T @ v)
    lam, n = float(res @ res), rows.shape[0] - u.shape[1]
    return n * lam / (n + lam)  # σ̃² from the residual the effect inflates: the LM = n R² form (tests/power.py)


MARGIN = 0.9  # the share of the noncentrality counted on for effects of the rates ...
SLOW_MARGIN = 0.5  # ... and for a trend, which the per-pose bias scatter competes with (measured 0.44–0.78)


def power(lam: float, k: int, alpha: float, family: int, margin: float = MARGIN) -> float:
    """P(χ²_k(margin·λ) > χ²_{k, 1−α/family}): a lower bound on the chance that the planted effect is found."""
    crit = stats.chi2.isf(alpha / family, k)
    return float(stats.ncx2.sf(crit, k, margin * lam))
