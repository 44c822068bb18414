"""The fewest dwell hours any static test on the lab's table needs to bring a model's σ to target: a lower bound.

Positions x of the table (angles of its axes at one of its mountings) held T_x hours add information
Σ_x T_x·G_x/N², G_x = Σ_c h_xc h_xcᵀ (h_xc the regressor row of the model's channel c at x — one for an SDF gyro or an
accelerometer, X and Y for a TDF gyro, read together while the table holds x; N the white noise in deg/√h: a
position mean over T hours has σ = N/√T) to the records' F₀. With H = Σ T_x and the design ξ_x = T_x/H, the requirement
σ_j² = [F⁻¹]_jj ≤ S_j² for every coefficient j reads max_j r_j(ξ, H) ≤ 1, r_j = [F⁻¹]_jj/S_j². Each r_j is convex
in ξ, and so is Φ_λ = Σ_j λ_j r_j for weights λ_j ≥ 0 summing to 1, with min_ξ max_j r_j ≥ min_ξ Φ_λ. For a convex
function on the simplex the Frank–Wolfe gap bounds the minimum from any design ξ:

    min Φ_λ ≥ Φ_λ(ξ) − (H/N²)·(max_x d_x − Σ_x ξ_x d_x),   d_x = Σ_j λ_j Σ_c (F⁻¹h_xc)_j²/S_j²,

so when that bound exceeds 1 no design of H hours meets every target, and the largest such H (bisection) is a lower
bound on the dwell any test needs — whatever its positions, count or order, and before any time to move and settle.
ξ comes from a multiplicative algorithm (Silvey, Titterington & Torsney) refined by the minimax itself, λ from a
linear programme that maximises the bound; they only make the bound tight, its validity does not rest on them.
The positions are a grid of the table's angles
(:data:`GRID_DEG`), so the bound holds for designs on that grid (the rows vary smoothly with the angles). A design
whose information is singular (a coefficient no position of its support sees) has every ratio infinite.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from gyrojax.adaptive.reach import mounting_rows
from gyrojax.optimize import bisect

GRID_DEG = 10.0
"""Step (deg) of the grid of each table axis' angles the bound is taken over."""
ITERATIONS = 200
SUPPORT = 60
"""Grid positions (the heaviest of the multiplicative algorithm's design) the minimax design is refined on."""


def grid_rows(uni, lab) -> np.ndarray:
    """Regressor rows (K, c, p) of every grid position at every mounting the lab allows, channel by channel, report
    units."""
    axes = []
    for lim in lab.limited():
        lo, hi = (0.0, 360.0 - GRID_DEG) if lim is None else lim
        axes.append(np.arange(lo, hi + 1e-9, GRID_DEG))
    ang = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
    h = mounting_rows(uni)(lab.table().template, jnp.asarray(lab.mountings()), jnp.deg2rad(jnp.asarray(ang)))
    h = np.asarray(h)  # (mountings, channels, positions, p)
    return np.transpose(h, (0, 2, 1, 3)).reshape(-1, h.shape[1], uni.size)


def _ratios(f0, h, xi, hours, white, targets):
    """(r, F⁻¹) of the design ``xi`` over the positions ``h`` (K, c, p); r = ∞ and F⁻¹ None where F is singular."""
    f = f0 + hours * np.einsum("k,kcp,kcq->pq", xi, h, h) / white**2
    try:
        inv = np.linalg.inv(f)
    except np.linalg.LinAlgError:
        return np.full(len(targets), np.inf), None
    r = np.diag(inv) / targets**2
    return (r, inv) if np.all(r > 0) else (np.full(len(targets), np.inf), None)


def _sensitivity(h, inv, targets) -> np.ndarray:
    """D (K, p): D_xj = Σ_c (F⁻¹h_xc)_j²/S_j², the fall of r_j per unit weight at x (times N²/H)."""
    return (np.einsum("kcp,pq->kcq", h, inv) ** 2).sum(axis=1) / targets**2


def design(f0, h, hours, white, targets) -> np.ndarray:
    """A design ξ (K,) on the grid positions ``h`` (K, c, p) for ``hours`` of dwell that nearly minimises max_j r_j:
    the multiplicative algorithm on the soft maximum, then the minimax itself (SLSQP, epigraph form) on its support
    (the multiplicative design itself where its support alone does not see every coefficient)."""
    from scipy import optimize

    k = h.shape[0]
    xi = np.full(k, 1.0 / k)
    for _ in range(ITERATIONS):
        r, inv = _ratios(f0, h, xi, hours, white, targets)
        if inv is None:
            return xi
        lam = np.exp((r - r.max()) * 20.0 / max(r.max(), 1e-300))
        d = _sensitivity(h, inv, targets) @ (lam / lam.sum())
        xi = xi * np.sqrt(d / (xi @ d))
        xi /= xi.sum()
    keep = np.argsort(xi)[::-1][:SUPPORT]
    hk, c = h[keep], hours / white**2

    def ratios(v):
        return _ratios(f0, hk, v[:-1], hours, white, targets)

    def cons(v):
        return v[-1] - ratios(v)[0]

    def cons_jac(v):
        r, inv = ratios(v)
        g = _sensitivity(hk, inv, targets) * c  # −∂r_j/∂ξ_x, (K, p)
        return np.column_stack([g.T, np.ones(len(r))])

    x0 = np.append(xi[keep] / xi[keep].sum(), 0.0)
    x0[-1] = ratios(x0)[0].max()
    if not np.isfinite(x0[-1]):
        return xi
    res = optimize.minimize(
        lambda v: v[-1],
        x0,
        jac=lambda v: np.eye(len(v))[-1],
        method="SLSQP",
        bounds=[(0.0, 1.0)] * len(keep) + [(0.0, None)],
        constraints=[
            {"type": "ineq", "fun": cons, "jac": cons_jac},
            {"type": "eq", "fun": lambda v: v[:-1].sum() - 1.0, "jac": lambda v: np.append(np.ones(len(keep)), 0.0)},
        ],
        options={"maxiter": 200},
    )
    out = np.zeros(k)
    v = res.x if np.all(np.isfinite(res.x)) else x0
    out[keep] = np.maximum(v[:-1], 0.0)
    return out / out.sum()


def gap_bound(f0, h, xi, hours, white, targets) -> float:
    """A lower bound on min over designs of max_j r_j at ``hours`` of dwell, from the design ``xi``: the Frank–Wolfe
    bound of Φ_λ maximised over λ (a linear programme; module doc). Valid for any ξ."""
    from scipy import optimize

    r, inv = _ratios(f0, h, xi, hours, white, targets)
    if inv is None:  # a singular design certifies nothing
        return -math.inf
    dd = _sensitivity(h, inv, targets)  # D_xj: d_x = Σ_j λ_j D_xj
    e = xi @ dd
    c = hours / white**2
    p = len(r)
    # maximise Σ_j λ_j (r_j + c e_j) − c z  s.t.  z ≥ Σ_j λ_j D_xj for every x,  λ ≥ 0,  Σ λ = 1
    res = optimize.linprog(
        np.append(-(r + c * e), c),
        A_ub=np.column_stack([dd, -np.ones(len(dd))]),
        b_ub=np.zeros(len(dd)),
        A_eq=np.append(np.ones(p), 0.0)[None],
        b_eq=[1.0],
        bounds=[(0.0, None)] * p + [(None, None)],
        method="highs",
    )
    return float(-res.fun) if res.status == 0 else -math.inf


def dwell_lower_bound(f0, h, white: float, targets, cap: float = 1.0e4) -> tuple[float, float]:
    """(lower, achieved): the largest dwell H (h) at which :func:`gap_bound` still exceeds 1 — every static test on
    the grid needs more — and the dwell at which the design found meets every target (an upper bound; the two
    bracket the fewest hours). ``cap`` when the bound is beyond it."""
    targets = np.asarray(targets, dtype=float)

    def worst(xi, hh):
        return float(_ratios(f0, h, xi, hh, white, targets)[0].max())

    # the hours a rough design needs, then the design near them and the bound it certifies
    k = h.shape[0]
    flat = np.full(k, 1.0 / k)
    if not math.isfinite(worst(flat, cap)):  # every position of the grid together leaves a coefficient unseen
        return cap, math.inf
    if worst(flat, cap) > 1.0 and gap_bound(f0, h, flat, cap, white, targets) > 1.0:
        return cap, math.inf
    _, rough = bisect(lambda hh: worst(flat, hh) <= 1.0, 0.0, cap)
    xi = design(f0, h, rough, white, targets)
    _, up = bisect(lambda hh: worst(xi, hh) <= 1.0, 0.0, rough)
    xi = design(f0, h, up, white, targets)
    _, up2 = bisect(lambda hh: worst(xi, hh) <= 1.0, 0.0, max(up, rough))
    lo, _ = bisect(lambda hh: gap_bound(f0, h, xi, hh, white, targets) <= 1.0, 0.0, up2)
    return lo, up2


def table_hours_bound(records, terms, goal, lab, white: float) -> dict:
    """What any campaign that starts with ``records`` needs of static dwell on ``lab``'s table to bring every
    coefficient of the model ``terms`` to ``goal``'s σ target, at white noise ``white`` (deg/√h; a drift's
    Gauss–Markov terms only add to it, so the bound holds for them too): ``dwell_lower`` h (no test does with less,
    module doc) and ``dwell_design`` h (a design on the grid that meets the targets with that dwell: the bracket's
    upper end). Only the σ targets of the final model enter — no detection, no alias, no move or settle time — so
    a loop that must also find and rule out effects needs more."""
    from gyrojax.noise.spec import NoiseSpec
    from gyrojax.physics.model import Model
    from gyrojax.planning.fisher import record_fisher

    model = Model.of(terms, lab.kind)
    targets = np.array([goal.target(c) or math.inf for c in model.coefficient_names])
    f0 = record_fisher(model, list(records), NoiseSpec(white=white))
    lo, up = dwell_lower_bound(f0, grid_rows(model, lab), white, targets)
    return {"dwell_lower": lo, "dwell_design": up, "grid_deg": GRID_DEG, "white": white}
