"""Subspaces of a whitened regressor system: orthonormal bases of column spaces (rank-tolerant), the part of one
span orthogonal to another, and the whitened system of a diagnosis held as the triangle of one QR (every test of
:mod:`gyrojax.inference.diagnose` and :mod:`gyrojax.inference.adequacy` is an inner product of its columns)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNSEEN = 1e-6
"""|X⊥| / |X| below which a span holds a set of columns: no direction of it is left (:func:`perp_basis`); a
candidate or shape the model spans that closely is not tested, it is indistinguishable from the model."""


def basis(a: np.ndarray, tol: float = 1e-7) -> np.ndarray:
    """Orthonormal basis (dimensionless) of the column space of ``a`` (columns normalised first; directions whose
    singular value is below ``tol`` × the largest are dropped, ``tol`` ≥ 1e-7).

    By the eigen-decomposition of the small Gram matrix and a QR re-orthonormalisation (Cholesky-QR2 in spirit):
    several times cheaper than the SVD of the tall matrix, which the diagnosis would otherwise do dozens of times.
    """
    if a.ndim == 1:
        a = a[:, None]
    if a.shape[1] == 0:
        return np.zeros((a.shape[0], 0))
    norms = np.sqrt((a * a).sum(axis=0))
    live = norms > 0
    if not live.any():
        return np.zeros((a.shape[0], 0))
    z = a[:, live] / norms[live]
    ev, vec = np.linalg.eigh(z.T @ z)
    keep = ev > max(tol, 1e-7) ** 2 * ev[-1]
    if not keep.any():
        return np.zeros((a.shape[0], 0))
    u = z @ (vec[:, keep] / np.sqrt(ev[keep]))
    # one more Gram pass restores orthonormality to machine precision (CholQR2)
    return _cholqr(u)


def _cholqr(u: np.ndarray) -> np.ndarray:
    """Q of u = QR by the Cholesky factor of the small Gram matrix: u (Lᵀ)⁻¹ by the inverse of the p×p triangle (a
    general solve against the tall matrix cost ten times more)."""
    ch = np.linalg.cholesky(u.T @ u)
    return u @ np.linalg.inv(ch).T


def perp(u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x`` less its projection on the orthonormal columns ``u``."""
    return x - u @ (u.T @ x) if u.shape[1] else x


def perp_basis(u: np.ndarray, x: np.ndarray, tol: float = UNSEEN) -> np.ndarray:
    """Orthonormal basis (dimensionless) of the part of span(``x``) orthogonal to the orthonormal ``u``: the
    directions whose size is at least ``tol`` of ``x``'s own columns.

    Sizes are measured against the columns of ``x`` before the projection: a column that ``u`` spans up to
    rounding (cos 2θ beside D_OO's a_O²) leaves a residue of 1e-16 of itself, which normalised on its own would be a
    direction of rounding errors, neither orthogonal to ``u`` nor a shape of the data.
    """
    if x.ndim == 1:
        x = x[:, None]
    norms = np.sqrt((x * x).sum(axis=0))
    live = norms > 0
    if not live.any():
        return np.zeros((x.shape[0], 0))
    z = perp(u, x[:, live] / norms[live])
    ev, vec = np.linalg.eigh(z.T @ z)
    keep = ev > tol**2
    if not keep.any():
        return np.zeros((x.shape[0], 0))
    b = perp(u, z @ (vec[:, keep] / np.sqrt(ev[keep])))  # a second projection: orthogonal to u to rounding
    return _cholqr(b)


def compress(m: np.ndarray) -> np.ndarray:
    """The triangle R of m = QR (Householder QR, Q not formed; (min(n, k), k) for m (n, k)): RᵀR = mᵀm, so every
    inner product, norm, projection and canonical correlation between columns of ``m`` is the same computed on
    the columns of R (Q has orthonormal columns), in k rows instead of n. The tests of a diagnosis touch the tall
    whitened system only through such quantities: one QR of it replaces dozens of passes over its rows."""
    if m.shape[1] == 0:
        return np.zeros((0, 0))
    return np.linalg.qr(m, mode="r")


@dataclass
class WhitenedSystem:
    """Residual, regressors (model p0 columns, then the candidates') and shapes, whitened by one noise model, stacked
    over the records and held as the rows of :func:`compress` (dimensionless); ``n`` is the number of whitened
    measurements they stand for (the degrees of freedom count them, not the rows kept)."""

    r: np.ndarray
    j: np.ndarray
    x: np.ndarray
    shape_cols: list
    p0: int
    n: int = 0

    @classmethod
    def of(cls, rw: np.ndarray, jw: np.ndarray, xw: np.ndarray, shape_cols: list, p0: int) -> "WhitenedSystem":
        """From the tall whitened residual ``rw`` (n,), regressors ``jw`` (n, p) and shapes ``xw`` (n, q)."""
        p = jw.shape[1]
        rr = compress(np.column_stack([rw, jw, xw]))
        return cls(rr[:, 0], rr[:, 1 : 1 + p], rr[:, 1 + p :], shape_cols, p0, len(rw))
