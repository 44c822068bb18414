"""The fewest dwell hours any static test on the lab's table needs to meet a campaign's requirements: a lower bound.

Positions x of the table (angles of its axes at one of its mountings) held T_x hours add information
Σ_x T_x·G_x/N², G_x = Σ_c h_xc h_xcᵀ (h_xc the regressor row of the universe's channel c at x — one for an SDF gyro
or an accelerometer, X and Y for a TDF gyro, read together while the table holds x; N the white noise in deg/√h: a
position mean over T hours has σ = N/√T) to the records' F₀. Each requirement j
(:mod:`gyrojax.adaptive.requirements`: a σ of the model, the detection of a watched candidate, the separation of an
alias) asks σ_j² = [F_K⁻¹]_ii ≤ S_j² for its coefficient i in its sub-model K. With H = Σ T_x and the design
ξ_x = T_x/H the requirements read max_j r_j(ξ, H) ≤ 1, r_j = [F_K⁻¹]_ii/S_j². Each r_j is convex in ξ (the inverse
of a matrix linear in ξ, read through a principal block), and so is Φ_λ = Σ_j λ_j r_j for weights λ_j ≥ 0 summing
to 1, with min_ξ max_j r_j ≥ min_ξ Φ_λ. For a convex function on the simplex the Frank–Wolfe gap bounds the minimum
from any design ξ:

    min Φ_λ ≥ Φ_λ(ξ) − (H/N²)·(max_x d_x − Σ_x ξ_x d_x),   d_x = Σ_j λ_j Σ_c (h_xc,K·F_K⁻¹e_i)²/S_j²,

so when that bound exceeds 1 no design of H hours meets every requirement, and the largest such H (bisection) is a
lower bound on the dwell any test needs — whatever its positions, count or order, and before any time to move and
settle. ξ comes from a multiplicative algorithm (Silvey, Titterington & Torsney) refined by the minimax itself, λ
from a linear programme that maximises the bound; they only make the bound tight, its validity does not rest on
them. The positions are a grid of the table's angles (:data:`GRID_DEG`), so the bound holds for designs on that grid
(the rows vary smoothly with the angles). A design whose information is singular in a sub-model (a coefficient no
position of its support sees) has every ratio infinite.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from gyrojax.adaptive.reach import mounting_rows
from gyrojax.optimize import bisect

GRID_DEG = 10.0
"""Step (deg) of the grid of each table axis' angles the bound is taken over."""
ITERATIONS = 400
SHARPNESS = 40.0
"""The multiplicative algorithm's weights λ_j ∝ r_j^SHARPNESS: a soft maximum of the requirements' ratios."""
SUPPORT = 80
"""Grid positions (the heaviest of the multiplicative algorithm's design) the minimax design is refined on."""
ROUNDS = 4
BRACKET = 0.98
"""The designs are refined (at most :data:`ROUNDS` times) until the bound is this share of the hours they need."""


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


def _directions(f0, h, xi, hours, white, need):
    """(r (R,), U (p, R)) of the requirements ``need`` = (masks (R, p), index (R,), targets (R,)) at design ``xi``
    over the positions ``h`` (K, c, p): r_j = [F_K⁻¹]_ii/S_j² and U's column j = F_K⁻¹e_i (zero outside K); r = ∞
    and U None where a sub-model's information is singular."""
    masks, index, targets = need
    f = f0 + hours * np.einsum("k,kcp,kcq->pq", xi, h, h) / white**2
    u = np.zeros((f.shape[0], len(index)))
    for m in np.unique(masks, axis=0):
        k = np.flatnonzero(m)
        try:
            inv = np.linalg.inv(f[np.ix_(k, k)])
        except np.linalg.LinAlgError:
            return np.full(len(index), np.inf), None
        for j in np.flatnonzero((masks == m).all(axis=1)):
            u[k, j] = inv[:, int(np.flatnonzero(k == index[j])[0])]
    r = u[index, np.arange(len(index))] / targets**2
    return (r, u) if np.all(r > 0) else (np.full(len(index), np.inf), None)


def _sensitivity(h, u, targets) -> np.ndarray:
    """D (K, R): D_xj = Σ_c (h_xc·U_j)²/S_j², the fall of r_j per unit weight at x (times N²/H)."""
    return (np.einsum("kcp,pr->kcr", h, u) ** 2).sum(axis=1) / targets**2


def design(f0, h, hours, white, need) -> np.ndarray:
    """A design ξ (K,) on the grid rows ``h`` for ``hours`` of dwell that nearly minimises max_j r_j of the
    requirements ``need`` (:func:`_directions`): the multiplicative algorithm on the soft maximum, then the minimax
    itself (SLSQP, epigraph form) on its support."""
    from scipy import optimize

    targets = need[2]
    k = h.shape[0]
    xi = np.full(k, 1.0 / k)
    best, best_r = xi, math.inf
    for _ in range(ITERATIONS):
        r, u = _directions(f0, h, xi, hours, white, need)
        if u is None:
            break
        if r.max() < best_r:  # the weights chase the largest ratio and can overshoot: keep the best iterate
            best, best_r = xi, r.max()
        log_r = np.log(np.maximum(r, 1e-300))
        lam = np.exp((log_r - log_r.max()) * SHARPNESS)
        d = _sensitivity(h, u, targets) @ (lam / lam.sum())
        xi = xi * np.sqrt(d / (xi @ d))
        xi /= xi.sum()
    xi = best
    keep = np.argsort(xi)[::-1][:SUPPORT]
    hk, c = h[keep], hours / white**2

    def ratios(v):
        return _directions(f0, hk, v[:-1], hours, white, need)

    def cons(v):
        return v[-1] - ratios(v)[0]

    def cons_jac(v):
        r, u = ratios(v)
        if u is None:  # a singular trial point: no direction to give (the result is checked below)
            return np.column_stack([np.zeros((len(r), len(keep))), np.ones(len(r))])
        g = _sensitivity(hk, u, targets) * c  # −∂r_j/∂ξ_x, (K, R)
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
    out[keep] = np.maximum(res.x[:-1], 0.0) if np.all(np.isfinite(res.x)) and res.x[:-1].max() > 0 else x0[:-1]
    out /= out.sum()
    # the refined design where it is better than the multiplicative one on the whole grid (on a truncated support
    # a sub-model can be nearly singular, and SLSQP lose its way)
    return out if _directions(f0, h, out, hours, white, need)[0].max() <= best_r else best


def gap_bound(f0, h, xi, hours, white, need) -> float:
    """A lower bound on min over designs of max_j r_j of the requirements ``need`` (:func:`_directions`) at ``hours``
    of dwell, from the design ``xi``: the Frank–Wolfe bound of Φ_λ maximised over λ (a linear programme; module
    doc). Valid for any ξ."""
    from scipy import optimize

    r, u = _directions(f0, h, xi, hours, white, need)
    if u is None:  # a singular design certifies nothing
        return -math.inf
    dd = _sensitivity(h, u, need[2])  # D_xj: d_x = Σ_j λ_j D_xj
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


def dwell_lower_bound(f0, h, white: float, need, cap: float = 1.0e4) -> tuple[float, float]:
    """(lower, achieved): the largest dwell H (h) at which :func:`gap_bound` still exceeds 1 — every static test on
    the grid needs more to meet the requirements ``need`` (:func:`_directions`; or targets (p,) alone: the σ of every
    coefficient in the whole model) — and the dwell at which the design found meets every one (an upper bound; the
    two bracket the fewest hours). ``cap`` when the bound is beyond it."""
    if not isinstance(need, tuple):
        targets = np.asarray(need, dtype=float)
        need = (np.ones((targets.size, f0.shape[0])), np.arange(targets.size), targets)

    def worst(xi, hh):
        return float(_directions(f0, h, xi, hh, white, need)[0].max())

    # the hours a rough design needs, then the design near them and the bound it certifies
    k = h.shape[0]
    flat = np.full(k, 1.0 / k)
    at_cap = worst(flat, cap)
    if at_cap > 1.0 and (at_cap == math.inf or gap_bound(f0, h, flat, cap, white, need) > 1.0):
        return cap, math.inf  # (the whole grid singular in a sub-model: so is every design on it)
    _, up = bisect(lambda hh: worst(flat, hh) <= 1.0, 0.0, cap)
    lo = 0.0
    for _ in range(ROUNDS):  # the design at the hours the last one needed, until the bracket closes
        xi = design(f0, h, up, white, need)
        if worst(xi, up) > 1.0:
            break  # no better than the design before: the bracket stays as it is
        _, up = bisect(lambda hh: worst(xi, hh) <= 1.0, 0.0, up)
        lo = max(lo, bisect(lambda hh: gap_bound(f0, h, xi, hh, white, need) <= 1.0, 0.0, up)[0])
        if lo >= BRACKET * up:
            break
    return lo, up


def table_hours_bound(records, requirements, universe, lab, white: float) -> dict:
    """What any campaign that starts with ``records`` needs of static dwell on ``lab``'s table to meet
    ``requirements`` (:class:`~gyrojax.adaptive.requirements.Requirement` s over the model ``universe``: the σ
    targets of the final model, the detection of the watched candidates outside it, the separation of an alias), at
    white noise ``white`` (deg/√h; a drift's Gauss–Markov terms only add to it, so the bound holds for them too):
    ``dwell_lower`` h (no test does with less, module doc) and ``dwell_design`` h (a design on the grid that meets them
    with that dwell: the bracket's upper end). No move or settle time enters, so every campaign needs more."""
    from gyrojax.adaptive.requirements import arrays
    from gyrojax.noise.spec import NoiseSpec
    from gyrojax.planning.fisher import record_fisher

    f0 = record_fisher(universe, list(records), NoiseSpec(white=white))
    lo, up = dwell_lower_bound(f0, grid_rows(universe, lab), white, arrays(requirements, universe))
    kinds = sorted({r.kind for r in requirements})
    return {"dwell_lower": lo, "dwell_design": up, "grid_deg": GRID_DEG, "white": white, "requirements": kinds}
