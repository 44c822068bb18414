"""Variance components of a triad fit: what the white-noise model of the segments leaves out, estimated by REML.

A hand session misfits in two ways the sample noise does not describe: each hand move leaves an angle error the
gyro model cannot explain (vibration beyond the bandwidth, a slipping grip, an unmodelled nonlinearity), and the
bias of a MEMS gyro moves a little between poses (turn-on-to-turn-on and thermal steps). Both are random effects
with one variance each, added to the covariance of the segment groups:

* every static pose's 3 rows: + τ_b² I₃ ((deg/h)², the per-pose bias scatter, indicated units);
* every move's 2 direction rows: + τ_m² I₂ (rad², the per-move angle noise about each horizontal axis).

They are estimated by restricted maximum likelihood (Patterson & Thompson 1971; Harville 1977) on the model
linearised at the fit: minimising −2ℓ_R(τ) = log|V(τ)| + log|Xᵀ V⁻¹ X| + min_δ (r − X δ)ᵀ V⁻¹ (r − X δ), which,
unlike ML, accounts for the degrees of freedom the coefficients take (a model that fits leaves τ̂ ≈ 0 and σ as
before). With τ̂ the fit is redone and its σ carry both components; χ² of the white-noise model is kept to say
how poor that model is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

LOG_RANGE = 30.0  # log τ² searched within ± this of its natural scale (exp(−30): a component of zero)
NEGLIGIBLE = 1e-3  # −2ℓ_R gain below which a component is zero (a likelihood-ratio statistic of 0.001: p ≈ 0.97)


@dataclass
class Group:
    """Rows of one segment: base covariance ``cov`` (d, d), residual ``r`` (d,) and Jacobian ``jac`` (d, p) at the
    fit (y − f and ∂f/∂θ, natural units), and the component that applies (``"pose"``, ``"move"`` or ``""``)."""

    cov: np.ndarray
    r: np.ndarray
    jac: np.ndarray
    kind: str


def whiten(groups, tau2: dict):
    """(whitened residual, whitened Jacobian, log|V|) of the groups with the components ``tau2`` added."""
    rs, js, logdet = [], [], 0.0
    for g in groups:
        v = g.cov + tau2.get(g.kind, 0.0) * np.eye(len(g.r))
        low = np.linalg.cholesky(v)
        rs.append(np.linalg.solve(low, g.r))
        js.append(np.linalg.solve(low, g.jac))
        logdet += 2.0 * float(np.log(np.diag(low)).sum())
    return np.concatenate(rs), np.concatenate(js), logdet


def reml_objective(groups, tau2: dict, col_scale: np.ndarray, rank_tol: float = 1e-10) -> float:
    """−2 ℓ_R (module doc, up to a constant) at ``tau2``; rank-deficient X is taken on its seen subspace."""
    e, x, logdet = whiten(groups, tau2)
    u, s, _ = np.linalg.svd(x / col_scale, full_matrices=False)
    keep = s > rank_tol * s[0]
    proj = u[:, keep].T @ e
    return logdet + 2.0 * float(np.log(s[keep]).sum()) + float(e @ e - proj @ proj)


def estimate_components(groups, kinds=("pose", "move")) -> tuple[dict, str]:
    """REML estimates of the variance components ``kinds`` present in ``groups`` (module doc): ({kind: τ̂²}, why),
    natural units ((deg/h)² for poses, rad² for moves); a component the data cannot tell from zero comes back 0.
    ``why`` is "" when the best start's search converged, else scipy's reason (the fit then says it did not)."""
    kinds = [k for k in kinds if sum(g.kind == k for g in groups) >= 2]
    if not kinds:
        return {}, ""
    scale = {k: float(np.mean([np.trace(g.cov) / len(g.r) for g in groups if g.kind == k])) for k in kinds}
    col_scale = np.linalg.norm(whiten(groups, {})[1], axis=0)
    col_scale[col_scale == 0] = 1.0

    def f(u):
        return reml_objective(groups, {k: scale[k] * np.exp(ui) for k, ui in zip(kinds, u)}, col_scale)

    best = None
    for start in (-LOG_RANGE, 0.0, 4.0):  # from zero, the noise's size and above: −2ℓ_R may have a boundary minimum
        sol = optimize.minimize(
            f,
            np.full(len(kinds), start),
            method="L-BFGS-B",
            bounds=[(-LOG_RANGE, 20.0)] * len(kinds),
            options={"ftol": 1e-15, "gtol": 1e-9, "maxiter": 500},
        )
        if best is None or sol.fun < best.fun:
            best = sol
    out = {k: float(scale[k] * np.exp(ui)) for k, ui in zip(kinds, best.x)}
    for k in kinds:  # a component that lowers −2ℓ_R by less than NEGLIGIBLE is zero (the σ then do not wander)
        if reml_objective(groups, {**out, k: 0.0}, col_scale) - best.fun < NEGLIGIBLE:
            out[k] = 0.0
    # L-BFGS-B's status 1 is its iteration/evaluation limit: stopped short. Status 2 (ABNORMAL_TERMINATION_IN_LNSRCH)
    # is a line search that could not lower −2ℓ_R any further at the precision of its finite-difference gradient,
    # which here happens at the minimum: it counts as converged.
    why = f"the variance components' REML search stopped: {best.message}" if best.status == 1 else ""
    return out, why
