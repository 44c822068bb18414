"""Variance components of a triad fit: what the white-noise model of the segments leaves out, estimated by REML.

A hand session misfits in two ways the sample noise does not describe: each hand move leaves an angle error the
gyro model cannot explain (vibration beyond the bandwidth, a slipping grip, an unmodelled nonlinearity), and the
bias of a MEMS gyro moves a little between poses (turn-on-to-turn-on and thermal steps). Both are random effects
with one variance each, added to the covariance of the segment groups:

* every static pose's 3 rows: + τ_b² I₃ ((deg/h)², the per-pose bias scatter, indicated units);
* every move's 2 direction rows: + τ_m² I₂ (rad², the per-move angle noise about each horizontal axis);
* a bias that walks from segment to segment (persisting steps at each move, or a rate random walk sampled at paced
  poses): the bias of the k-th segment in time order is b₀ + Σ_{j≤k} w_j with independent steps w_j of variance
  τ_w² per channel, so segments k and l covary by τ_w² min(k, l) I₃ ((deg/h)² per pose; b₀ is the fitted bias). An
  in-run walk does not outlive a power-off: with records of several power-ups, each walks from its own turn-on bias
  (the fitted b₀, and its ``bias_turn_on`` step where fitted), k and l counted from its first segment and segments of
  different power-ups independent. Its covariance couples every segment, so with it the rows are whitened as one
  dense matrix.

They are estimated by restricted maximum likelihood (Patterson & Thompson 1971; Harville 1977) on the model
linearised at the fit: minimising −2ℓ_R(τ) = log|V(τ)| + log|Xᵀ V⁻¹ X| + min_δ (r − X δ)ᵀ V⁻¹ (r − X δ), which,
unlike ML, accounts for the degrees of freedom the coefficients take (a model that fits leaves τ̂ ≈ 0 and σ as
before). With τ̂ the fit is redone and its σ carry the components; χ² of the white-noise model is kept to say
how poor that model is. The walk is kept only where its likelihood ratio against the independent components is
significant (:func:`select_components`): the one rule by which the fit's σ carry it and the diagnosis names it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from gyrojax import tails
from gyrojax.optimize import difference_curvature, minimize

LOG_RANGE = 30.0  # log τ² searched within ± this of its natural scale (exp(−30): a component of zero)
MAX_STEPS = 200  # iterations of each start's search at most
FTOL = 1e-15  # predicted decrease of −2ℓ_R below which the search has converged: its rounding
NEGLIGIBLE = 1e-3  # −2ℓ_R gain below which a component is zero (a likelihood-ratio statistic of 0.001: p ≈ 0.97)


@dataclass
class Group:
    """Rows of one segment: base covariance ``cov`` (d, d), residual ``r`` (d,) and Jacobian ``jac`` (d, p) at the
    fit (y − f and ∂f/∂θ, natural units), and the component that applies (``"pose"``, ``"move"`` or ``""``)."""

    cov: np.ndarray
    r: np.ndarray
    jac: np.ndarray
    kind: str
    step: float | None = None  # where the bias walk applies: its clock (the segment's ordinal in time order; a move
    # between segments k and k + 1 is at k + ½); None where it does not
    bias_rows: np.ndarray | None = None  # (d, 3) the rows' change per deg/h of each channel's bias (None: I₃)
    power_up: int = 0  # the power-up (record) of the rows: the walk restarts at each (module doc)


class _Stacked:
    """The groups stacked by row count (one batched Cholesky per size; rows in the groups' order)."""

    def __init__(self, groups):
        self.n = len(groups)
        sizes = np.array([len(g.r) for g in groups])
        self.offsets = np.concatenate([[0], np.cumsum(sizes)])
        self.blocks = []
        for d in sorted(set(sizes.tolist())):
            idx = np.flatnonzero(sizes == d)
            rows = (self.offsets[idx][:, None] + np.arange(d)).reshape(-1)
            self.blocks.append(
                {
                    "rows": rows,
                    "cov": np.stack([groups[i].cov for i in idx]),
                    "rj": np.stack([np.column_stack([groups[i].r, groups[i].jac]) for i in idx]),
                    "kinds": np.array([groups[i].kind for i in idx]),
                    "d": d,
                }
            )
        self.n_rows = int(self.offsets[-1])

    def whiten(self, tau2: dict):
        """(e, x, log|V|, the Cholesky factors of each block) with ``tau2`` added (:func:`whiten`)."""
        out = np.empty((self.n_rows, self.blocks[0]["rj"].shape[2] if self.blocks else 1))
        logdet, lows = 0.0, []
        for b in self.blocks:
            add = np.array([tau2.get(k, 0.0) for k in b["kinds"]])
            low = np.linalg.cholesky(b["cov"] + add[:, None, None] * np.eye(b["d"]))
            out[b["rows"]] = np.linalg.solve(low, b["rj"]).reshape(-1, out.shape[1])
            logdet += 2.0 * float(np.log(np.diagonal(low, axis1=1, axis2=2)).sum())
            lows.append(low)
        return out[:, 0], out[:, 1:], logdet, lows


class _Dense:
    """The groups as one covariance (rows in the groups' order): the walk couples every segment (module doc)."""

    def __init__(self, groups):
        sizes = np.array([len(g.r) for g in groups])
        self.offsets = np.concatenate([[0], np.cumsum(sizes)])
        n = int(self.offsets[-1])
        self.n_rows = n
        self.base = np.zeros((n, n))
        self.kinds = {}
        for g, lo in zip(groups, self.offsets[:-1]):
            sl = slice(lo, lo + len(g.r))
            self.base[sl, sl] = g.cov
            self.kinds.setdefault(g.kind, np.zeros(n))[sl] = 1.0
        self.rj = np.concatenate([np.column_stack([g.r, g.jac]) for g in groups])
        self.walk = walk_covariance(groups, self.offsets)

    def covariance(self, tau2: dict) -> np.ndarray:
        """V(τ²): the base covariance and every component."""
        v = self.base + tau2.get("walk", 0.0) * self.walk
        for k, rows in self.kinds.items():
            v[np.diag_indices(self.n_rows)] += tau2.get(k, 0.0) * rows
        return v

    def whiten(self, tau2: dict):
        """(e, x, log|V|, L⁻¹) with ``tau2`` added: L Lᵀ = V(τ²)."""
        low = np.linalg.cholesky(self.covariance(tau2))
        inv = linalg.solve_triangular(low, np.eye(self.n_rows), lower=True)
        out = inv @ self.rj
        return out[:, 0], out[:, 1:], 2.0 * float(np.log(np.diag(low)).sum()), inv

    def component(self, k: str) -> np.ndarray:
        """Z_k = ∂V/∂τ_k²."""
        return self.walk if k == "walk" else np.diag(self.kinds.get(k, np.zeros(self.n_rows)))


def whiten_rows(groups, tau2: dict) -> tuple[np.ndarray, np.ndarray]:
    """(L⁻¹ r, L⁻¹ J) of all the groups at once, L Lᵀ = V(τ²) with every component, the walk included."""
    e, x, _logdet, _inv = _Dense(groups).whiten(tau2)
    return e, x


def walk_covariance(groups, offsets) -> np.ndarray:
    """∂V/∂τ_w² of the bias walk (module doc): min(k, l) G_k G_lᵀ between the rows of groups of one power-up at
    clocks k and l (counted from its first), 0 between power-ups, G a group's change per unit of each channel's bias
    (I₃ for a segment mean; for a move, the change of its two direction rows, carried along the move as the fit
    carries a bias)."""
    n = int(offsets[-1])
    walking = [
        (g.step, lo, np.eye(3) if g.bias_rows is None else g.bias_rows, g.power_up)
        for g, lo in zip(groups, offsets[:-1])
        if g.step is not None
    ]
    if not walking:
        return np.zeros((n, n))
    first: dict = {}
    for k, _, _, p in walking:
        first[p] = min(first.get(p, k), k)
    rows = np.concatenate([lo + np.arange(len(b)) for _, lo, b, _ in walking])
    big_g = np.concatenate([b for _, _, b, _ in walking])  # (rows, 3)
    clock = np.concatenate([np.full(len(b), k - first[p]) for k, _, b, p in walking])
    power = np.concatenate([np.full(len(b), p) for _, _, b, p in walking])
    out = np.zeros((n, n))
    same = power[:, None] == power[None, :]
    out[np.ix_(rows, rows)] = np.minimum.outer(clock, clock) * same * (big_g @ big_g.T)
    return out


def _restricted(e, x, logdet: float, col_scale, rank_tol: float):
    """(−2ℓ_R, the whitened residual off X's seen columns, their orthonormal basis U) from the whitened residual
    ``e``, columns ``x`` (scaled by ``col_scale``) and log|V|: log|V| + log|XᵀV⁻¹X| + |(I − UUᵀ) e|²."""
    u, s, _ = np.linalg.svd(x / col_scale, full_matrices=False)
    keep = s > rank_tol * s[0]
    uk = u[:, keep]
    proj = uk.T @ e
    return logdet + 2.0 * float(np.log(s[keep]).sum()) + float(e @ e - proj @ proj), e - uk @ proj, uk


def _dense_objective_and_gradient(st: _Dense, tau2: dict, col_scale, kinds=(), rank_tol: float = 1e-10):
    """:func:`_objective_and_gradient` on the dense covariance: P = L⁻ᵀ (I − UUᵀ) L⁻¹, the same Harville (4.8)."""
    e, x, logdet, inv = st.whiten(tau2)
    value, e_perp, uk = _restricted(e, x, logdet, col_scale, rank_tol)
    if not kinds:
        return value, {}
    pr = inv.T @ e_perp
    iu = inv.T @ uk
    p_mat = inv.T @ inv - iu @ iu.T
    grad = {}
    for k in kinds:
        z = st.component(k)
        grad[k] = float((p_mat * z).sum() - pr @ z @ pr)
    return value, grad


def _objective_and_gradient(st: _Stacked, tau2: dict, col_scale, kinds=(), rank_tol: float = 1e-10):
    """−2 ℓ_R at ``tau2`` (:func:`reml_objective`) and its exact derivative by each τ_k² of ``kinds``: with
    P = V⁻¹ − V⁻¹X(XᵀV⁻¹X)⁺XᵀV⁻¹ (on X's seen subspace) and Z_k the rows of component k,
    ∂(−2ℓ_R)/∂τ_k² = tr(P Z_k) − rᵀ P Z_k P r (Harville 1977, eq. 4.8), summed over the groups of kind k."""
    e, x, logdet, lows = st.whiten(tau2)
    value, e_perp, uk = _restricted(e, x, logdet, col_scale, rank_tol)
    grad = dict.fromkeys(kinds, 0.0)
    for b, low in zip(st.blocks, lows):
        inv_t = np.swapaxes(np.linalg.inv(low), 1, 2)  # L⁻ᵀ of each group
        m, d = low.shape[0], b["d"]
        a = inv_t @ e_perp[b["rows"]].reshape(m, d, 1)  # L⁻ᵀ (I − UUᵀ) e = P r
        lu = inv_t @ uk[b["rows"]].reshape(m, d, -1)  # L⁻ᵀ U
        per_group = (inv_t**2).sum(axis=(1, 2)) - (lu**2).sum(axis=(1, 2)) - (a**2).sum(axis=(1, 2))
        for k in kinds:
            grad[k] += float(per_group[b["kinds"] == k].sum())
    return value, grad


def reml_objective(groups, tau2: dict, col_scale: np.ndarray, rank_tol: float = 1e-10) -> float:
    """−2 ℓ_R (module doc, up to a constant) at ``tau2``; rank-deficient X is taken on its seen subspace."""
    st = groups if isinstance(groups, (_Stacked, _Dense)) else _layout(groups, "walk" in tau2)
    return _objective(st)(st, tau2, col_scale, (), rank_tol)[0]


def _layout(groups, walk: bool):
    """The groups stacked by size, or as one dense covariance where the walk couples them."""
    return _Dense(groups) if walk else _Stacked(groups)


def _objective(st):
    return _dense_objective_and_gradient if isinstance(st, _Dense) else _objective_and_gradient


def estimate_components(groups, kinds=("pose", "move")) -> tuple[dict, str]:
    """REML estimates of the variance components ``kinds`` present in ``groups`` (module doc): ({kind: τ̂²}, why),
    natural units ((deg/h)² for poses, rad² for moves, (deg/h)² per pose for the walk); a component the data cannot
    tell from zero comes back 0.
    ``why`` is "" when the best start's search (:func:`gyrojax.optimize.minimize`) converged, else its reason (the
    fit then says it did not)."""
    walking = [g for g in groups if g.step is not None and g.bias_rows is None]  # the segments it walks along
    kinds = [k for k in kinds if sum(g.kind == k for g in groups) >= 2 or (k == "walk" and len(walking) >= 3)]
    if not kinds:
        return {}, ""
    carrying = {k: walking if k == "walk" else [g for g in groups if g.kind == k] for k in kinds}
    scale = {k: float(np.mean([np.trace(g.cov) / len(g.r) for g in carrying[k]])) for k in kinds}
    st = _layout(groups, "walk" in kinds)
    objective = _objective(st)
    col_scale = np.linalg.norm(st.whiten({})[1], axis=0)
    col_scale[col_scale == 0] = 1.0

    def f(u):  # −2ℓ_R and its exact gradient in u = log(τ²/scale): ∂/∂u_k = τ_k² ∂/∂τ_k²
        tau2 = {k: scale[k] * np.exp(ui) for k, ui in zip(kinds, u)}
        value, grad = objective(st, tau2, col_scale, kinds)
        return value, np.array([tau2[k] * grad[k] for k in kinds])

    best = None
    lo, hi = np.full(len(kinds), -LOG_RANGE), np.full(len(kinds), 20.0)
    for start in (-LOG_RANGE, 0.0, 4.0):  # from zero, the noise's size and above: −2ℓ_R may have a boundary minimum
        u0 = np.full(len(kinds), start)
        first = f(u0)
        steps = np.where(u0 + 1e-3 <= hi, 1e-3, -1e-3)
        grads = [f(u0 + steps[i] * np.eye(len(kinds))[i])[1] for i in range(len(kinds))]
        curvature = difference_curvature(grads, u0, first[1], steps)
        sol = minimize(f, u0, lo, hi, curvature, MAX_STEPS, FTOL, "the variance components' REML search", first)
        if best is None or sol.value < best.value:
            best = sol
    out = {k: float(scale[k] * np.exp(ui)) for k, ui in zip(kinds, best.x)}
    for k in kinds:  # a component that lowers −2ℓ_R by less than NEGLIGIBLE is zero (the σ then do not wander)
        if reml_objective(st, {**out, k: 0.0}, col_scale) - best.value < NEGLIGIBLE:
            out[k] = 0.0
    return out, best.reason


def boundary_p(lr: float) -> float:
    """The p-value of a variance component's likelihood ratio against zero, on the boundary of its parameter space:
    ½ P(χ²₁ > LR) (Self & Liang 1987)."""
    return 0.5 * float(tails.chi2_sf(lr, 1)) if lr > 0 else 1.0


def column_scale(groups) -> np.ndarray:
    """The norms of the columns of the groups' Jacobian whitened by their base covariance (the REML objective's
    column scaling)."""
    col = np.linalg.norm(np.concatenate([np.linalg.solve(np.linalg.cholesky(g.cov), g.jac) for g in groups]), axis=0)
    col[col == 0] = 1.0
    return col


def select_components(groups, alpha: float) -> tuple[dict, float]:
    """The variance components of ``groups`` by REML with the bias walk among them only where its profile likelihood
    ratio against no walk (the independent components re-estimated) is significant at ``alpha`` (boundary:
    :func:`boundary_p`): (τ̂², the walk's likelihood ratio, 0 where it was not estimated). The one rule by which the
    fit's σ and the diagnosis's tests take a walk."""
    tau2, _why = estimate_components(groups)
    with_walk, _why = estimate_components(groups, ("pose", "move", "walk"))
    if with_walk.get("walk", 0.0) <= 0.0:
        return tau2, 0.0
    col = column_scale(groups)
    lr = max(reml_objective(groups, tau2, col) - reml_objective(groups, with_walk, col), 0.0)
    return (with_walk if boundary_p(lr) < alpha else tau2), lr
