"""The least-squares core of every fit: ``identify.fit``, ``bigfit.fit_chunked`` and the Monte Carlo's per-draw fit.

J x ≈ r is solved in column-normalised form: with S = diag(‖J e_k‖) (a zero column is left unscaled) and Z = J S⁻¹,
x = S⁻¹ (ZᵀZ)⁻¹ Zᵀ r and (JᵀJ)⁻¹ = S⁻¹ (ZᵀZ)⁻¹ S⁻¹, so the conditioning seen by the solver measures the correlation of
the regressors, not their units. Methods: ``"svd"`` (Z = U Σ Vᵀ; singular values below ``rank_tol`` × the largest
are dropped, and a coefficient with weight > 0.05 in a dropped direction gets a NaN row and column of (JᵀJ)⁻¹: the
plan does not see it), ``"qr"`` and ``"cholesky"`` (of ZᵀZ; full rank assumed, fastest). :func:`lstsq_normal` takes
the normal equations (JᵀJ, Jᵀr) instead, for data accumulated in pieces (``"eigh"`` with the same rank cut, or
``"cholesky"``).

Written once for two array libraries: numpy arrays in → numpy (LAPACK, no compilation; the fits of records of any
length), JAX arrays or tracers in → ``jax.numpy`` (jit, ``vmap`` over draws, differentiable). The returned
``(JᵀJ)⁻¹`` is in the squared inverse units of the coefficients per unit of r²; multiply by σ² for a covariance.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import scipy.linalg

METHODS = ("svd", "qr", "cholesky")
NORMAL_METHODS = ("eigh", "cholesky")
UNSEEN_WEIGHT = 0.05
"""A coefficient whose weight in a dropped singular direction exceeds this has no finite variance (NaN)."""


def _libs(*arrays):
    """(array namespace, its scipy.linalg): numpy when every input is a numpy array or a number, else JAX."""
    if all(isinstance(a, (np.ndarray, np.generic, float, int)) for a in arrays):
        return np, scipy.linalg
    return jnp, jax.scipy.linalg


def column_scale(j):
    """S: the norm of each column of J (m, p); 1 for a zero column (units of J's columns)."""
    xp, _ = _libs(j)
    s = xp.sqrt(xp.sum(j * j, axis=0))
    return xp.where(s > 0, s, 1.0)


def _unseen_to_nan(xp, cov, vt, keep):
    """Rows and columns of coefficients with weight > UNSEEN_WEIGHT in a dropped direction (rows of vt) → NaN."""
    bad = xp.max(xp.where(keep[:, None], 0.0, xp.abs(vt)), axis=0) > UNSEEN_WEIGHT
    return xp.where(bad[:, None] | bad[None, :], xp.nan, cov)


def lstsq(j, r, method: str = "svd", rank_tol: float = 0.0):
    """Least squares J x ≈ r: (x, (JᵀJ)⁻¹) by ``method`` (module doc); ``j`` (m, p), ``r`` (m,) or (m, k) for k
    right-hand sides at once (x then (p, k)).

    Units: x in r's units per unit of J's columns; (JᵀJ)⁻¹ in the square of (1 / J's column units).
    ``rank_tol`` (dimensionless) applies to ``"svd"`` only.
    """
    if method not in METHODS:
        raise ValueError(f"lstsq: method must be one of {', '.join(METHODS)}, got {method!r}")
    xp, sla = _libs(j, r)
    p = j.shape[1]
    if p == 0:
        return xp.zeros((0,) + r.shape[1:]), xp.zeros((0, 0))
    sc = column_scale(j)
    z = j / sc
    sx = sc if r.ndim == 1 else sc[:, None]
    if method == "svd":
        u, s, vt = xp.linalg.svd(z, full_matrices=False)
        keep = s >= rank_tol * s[0]
        sinv = xp.where(keep, 1.0 / xp.where(keep, s, 1.0), 0.0)
        x = (vt.T * sinv) @ (u.T @ r) / sx
        inv = ((vt.T * sinv**2) @ vt) / xp.outer(sc, sc)
        if rank_tol > 0:
            inv = _unseen_to_nan(xp, inv, vt, keep)
        return x, inv
    if method == "qr":
        q, rr = xp.linalg.qr(z)
        x = sla.solve_triangular(rr, q.T @ r)
        rinv = sla.solve_triangular(rr, xp.eye(p))
        return x / sx, (rinv @ rinv.T) / xp.outer(sc, sc)
    c = sla.cho_factor(z.T @ z)
    return sla.cho_solve(c, z.T @ r) / sx, sla.cho_solve(c, xp.eye(p)) / xp.outer(sc, sc)


def lstsq_normal(gram, rhs, method: str = "eigh", rank_tol: float = 0.0):
    """Least squares from its normal equations JᵀJ x = Jᵀr: (x, (JᵀJ)⁻¹), ``gram`` (p, p), ``rhs`` (p,) or (p, k).

    Column-normalised like :func:`lstsq` (S² = diag JᵀJ). ``"eigh"``: eigenvalues of the normalised JᵀJ below
    ``rank_tol``² × the largest (singular values of J below ``rank_tol`` × the largest) are dropped, with the NaN rule
    of :func:`lstsq`; ``"cholesky"``: full rank assumed. Units as :func:`lstsq`.
    """
    if method not in NORMAL_METHODS:
        raise ValueError(f"lstsq_normal: method must be one of {', '.join(NORMAL_METHODS)}, got {method!r}")
    xp, sla = _libs(gram, rhs)
    p = gram.shape[0]
    if p == 0:
        return xp.zeros((0,) + rhs.shape[1:]), xp.zeros((0, 0))
    norms = xp.sqrt(xp.clip(xp.diagonal(gram), 0.0, None))
    sc = xp.where(norms > 0, norms, 1.0)
    sx = sc if rhs.ndim == 1 else sc[:, None]
    a = gram / xp.outer(sc, sc)
    b = rhs / sx
    if method == "cholesky":
        c = sla.cho_factor(a)
        return sla.cho_solve(c, b) / sx, sla.cho_solve(c, xp.eye(p)) / xp.outer(sc, sc)
    lam, v = xp.linalg.eigh(a)
    lam = xp.clip(lam, 0.0, None)
    keep = lam > rank_tol**2 * xp.max(lam)
    linv = xp.where(keep, 1.0 / xp.where(keep, lam, 1.0), 0.0)
    inv_n = (v * linv) @ v.T
    inv = inv_n / xp.outer(sc, sc)
    if rank_tol > 0:
        inv = _unseen_to_nan(xp, inv, v.T, keep)
    return inv_n @ b / sx, inv


__all__ = ["METHODS", "NORMAL_METHODS", "UNSEEN_WEIGHT", "column_scale", "lstsq", "lstsq_normal"]
