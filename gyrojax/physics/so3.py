"""The rotation group SO(3): the cross-product matrix, the exponential, its inverse (the logarithm) and its right
Jacobian, for stacks of rotation vectors (..., 3) in rad, right-hand rule (conventions §3). One implementation for both
array kinds: JAX arrays (and traces) are computed by ``jax.numpy``, anything else by ``numpy``, so a simulation or a
check loop in numpy pays no dispatch and a fit or design differentiates through the same formulas.

    exp([v×]) = I + sin θ/θ [v×] + (1 − cos θ)/θ² [v×]²                                   (Rodrigues, θ = |v|)
    J_r(v)    = I − (1 − cos θ)/θ² [v×] + (θ − sin θ)/θ³ [v×]²,   exp([(v + δ)×]) ≈ exp([v×]) exp([(J_r δ)×])

Both are written as c₀ I + c₁ [v×] + c₂ v vᵀ (using [v×]² = v vᵀ − θ² I), the coefficients by their Taylor series
near θ = 0, where the closed forms divide zero by zero: values and derivatives of every order stay finite at v = 0,
so a fit or a design may differentiate through an attitude that passes the identity.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

EXP_SERIES_BELOW = 1e-16
"""θ² (rad²) below which the exponential's coefficients are taken from their series (exact there to rounding)."""
JR_SERIES_BELOW = 1e-8
"""θ² (rad²) below which the right Jacobian's coefficients are taken from their series: the closed form
(θ − sin θ)/θ³ loses its digits to cancellation first; both forms agree to rounding at the switch."""


def _namespace(*arrays):
    """``jax.numpy`` when any of ``arrays`` is a JAX array or trace, ``numpy`` otherwise."""
    return jnp if any(isinstance(v, jax.Array) for v in arrays) else np


LEVI_CIVITA = np.array(
    [[[0, 0, 0], [0, 0, 1], [0, -1, 0]], [[0, 0, -1], [0, 0, 0], [1, 0, 0]], [[0, 1, 0], [-1, 0, 0], [0, 0, 0]]],
    dtype=float,
)
"""ε_ijk: [v×]_ij = −ε_ijk v_k."""


def hat(v):
    """[v×] of vectors ``v`` (..., 3): (..., 3, 3), so that [v×] w = v × w (each entry 0 or ±v_k, exactly)."""
    if _namespace(v) is jnp:  # one broadcast product: XLA compiles it in half the time of a stack of the entries
        return (-LEVI_CIVITA * v[..., None, None, :]).sum(axis=-1)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([o, -z, y, z, o, -x, -y, x, o], axis=-1).reshape(v.shape[:-1] + (3, 3))


def compose(a, b):
    """a @ b of stacks of 3×3 matrices (..., 3, 3) as broadcast products: XLA's CPU batched dot of many small
    matrices costs far more than their arithmetic."""
    return (a[..., :, :, None] * b[..., None, :, :]).sum(axis=-2)


def _combine(v, small_at: float, coefficients):
    """c₀ I + c₁ [v×] + c₂ v vᵀ with (c₀, c₁, c₂) = ``coefficients(xp, θ², θ, small)``, ``small`` where θ² ≤
    ``small_at`` (θ is then 1, a placeholder the series forms do not use)."""
    xp = _namespace(v)
    v = xp.asarray(v, dtype=float)
    th2 = (v * v).sum(axis=-1)
    small = th2 <= small_at
    th = xp.sqrt(xp.where(small, 1.0, th2))
    c0, c1, c2 = coefficients(xp, th2, th, small)
    return (
        c0[..., None, None] * xp.eye(3)
        + c1[..., None, None] * hat(v)
        + c2[..., None, None] * (v[..., :, None] * v[..., None, :])
    )


def _exp_coefficients(xp, th2, th, small):
    safe = xp.where(small, 1.0, th2)
    a = xp.where(small, 1.0 - th2 / 6.0, xp.sin(th) / th)
    b = xp.where(small, 0.5 - th2 / 24.0, (1.0 - xp.cos(th)) / safe)
    return 1.0 - b * th2, a, b


def exp(v):
    """The rotation exp([v×]) of rotation vectors ``v`` (..., 3) rad: (..., 3, 3) (module doc)."""
    return _combine(v, EXP_SERIES_BELOW, _exp_coefficients)


def _right_jacobian_coefficients(xp, th2, th, small):
    safe = xp.where(small, 1.0, th2)
    c1 = xp.where(small, 0.5 - th2 / 24.0, (1.0 - xp.cos(th)) / safe)
    c2 = xp.where(small, 1.0 / 6.0 - th2 / 120.0, (th - xp.sin(th)) / (safe * th))
    return 1.0 - c2 * th2, -c1, c2


def right_jacobian(v):
    """J_r(v) of rotation vectors ``v`` (..., 3) rad: (..., 3, 3) (module doc)."""
    return _combine(v, JR_SERIES_BELOW, _right_jacobian_coefficients)


def rotation(axis, angle):
    """R(n, α) = exp([α n×]): the rotation by ``angle`` (rad, shape (...)) about the unit vector ``axis`` (..., 3)."""
    xp = _namespace(axis, angle)
    return exp(xp.asarray(axis, dtype=float) * xp.asarray(angle, dtype=float)[..., None])


def log(r):
    """The rotation vector v (..., 3) rad, |v| ≤ π, of rotations ``r`` (..., 3, 3): exp([v×]) = r.

    Through the unit quaternion (w, x, y, z), w ≥ 0, whose largest component is found first and the others from the
    sums and differences of r's off-diagonal entries divided by it (Shepperd 1978: no square root of a small number,
    exact to rounding at every angle); at π, where ±v are one rotation, the largest axis component is positive. Then
    θ = 2 atan2(|(x, y, z)|, w) and v = θ/sin(θ/2)·(x, y, z), the factor by its series 2 + θ²/12 + 7θ⁴/2880 below
    θ = 10⁻³ rad."""
    xp = _namespace(r)
    r = xp.asarray(r, dtype=float)
    d0, d1, d2 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    tr = d0 + d1 + d2
    s01, s02, s12 = r[..., 0, 1] + r[..., 1, 0], r[..., 0, 2] + r[..., 2, 0], r[..., 1, 2] + r[..., 2, 1]
    a0, a1, a2 = r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]
    # each row is 4 q_k (x, y, z, w) with q_k the pivot: x, y, z, then w (ties go to the axes)
    rows = xp.stack(
        [
            xp.stack([1.0 + 2.0 * d0 - tr, s01, s02, a0], axis=-1),
            xp.stack([s01, 1.0 + 2.0 * d1 - tr, s12, a1], axis=-1),
            xp.stack([s02, s12, 1.0 + 2.0 * d2 - tr, a2], axis=-1),
            xp.stack([a0, a1, a2, 1.0 + tr], axis=-1),
        ],
        axis=-2,
    )
    pivot = xp.argmax(xp.stack([d0, d1, d2, tr], axis=-1), axis=-1)
    q = xp.take_along_axis(rows, pivot[..., None, None], axis=-2)[..., 0, :]
    q = q / xp.sqrt((q * q).sum(axis=-1))[..., None]
    q = xp.where(q[..., 3:] < 0.0, -q, q)
    xyz, w = q[..., :3], q[..., 3]
    theta = 2.0 * xp.arctan2(xp.sqrt((xyz * xyz).sum(axis=-1)), w)
    small = theta <= 1e-3
    t2 = theta * theta
    scale = xp.where(small, 2.0 + t2 / 12.0 + 7.0 * t2 * t2 / 2880.0, theta / xp.sin(xp.where(small, 1.0, theta) / 2.0))
    return scale[..., None] * xyz
