"""Turntable kinematics: the gimbal chain, platform attitude and angular rate (CONVENTIONS §3).

A table has k axes, outermost first; axis i has unit vector u_i written in L with every angle at zero.

    C(θ) = R(u_1, θ_1) · … · R(u_k, θ_k),   R(u, θ) = I + sin θ [u×] + (1 − cos θ) [u×]²
    ω_LP = Σ_i θ̇_i · R(u_1, θ_1) … R(u_{i−1}, θ_{i−1}) u_i      (in L)
    ω_IP = Ω + ω_LP

Functions take one sample (angles of shape (k,)); batch with ``jax.vmap``.
"""

import jax.numpy as jnp


def skew(v):
    """The cross-product matrix [v×], so that [v×] w = v × w."""
    x, y, z = v[0], v[1], v[2]
    zero = jnp.zeros_like(x)
    return jnp.stack([jnp.stack([zero, -z, y]), jnp.stack([z, zero, -x]), jnp.stack([-y, x, zero])])


def rotation(u, theta):
    """Rotation by ``theta`` (rad) about the unit vector ``u``, right-hand rule (Rodrigues)."""
    k = skew(u)
    return jnp.eye(3) + jnp.sin(theta) * k + (1.0 - jnp.cos(theta)) * (k @ k)


def chain(axes, angles):
    """Partial products of the gimbal chain.

    Returns ``(C, outer)`` where C = R(u_1,θ_1)…R(u_k,θ_k) and ``outer[i]`` = R(u_1,θ_1)…R(u_{i−1},θ_{i−1})
    (identity for i = 0), shape (k, 3, 3). ``axes`` (k, 3) unit vectors in L, ``angles`` (k,) in rad.
    """
    c = jnp.eye(3)
    outer = []
    for i in range(axes.shape[0]):
        outer.append(c)
        c = c @ rotation(axes[i], angles[i])
    return c, jnp.stack(outer)


def platform_attitude(axes, angles):
    """C(θ): platform coordinates → L coordinates (CONVENTIONS §3); ``angles`` in rad, ``axes`` unit vectors in L."""
    return chain(axes, angles)[0]


def platform_rate(axes, angles, rates):
    """ω_LP in L (rad/s) for table angles (rad) and angle rates (rad/s)."""
    _, outer = chain(axes, angles)
    return jnp.einsum("i,ijk,ik->j", rates, outer, axes)


def platform_state(axes, angles, rates, base=None):
    """Attitude C and platform rate ω_LP in L (rad/s), with an optional base misorientation.

    ``angles`` in rad, ``rates`` (angle rates) in rad/s, ``axes`` unit vectors in L.

    ``base`` is a 3×3 matrix premultiplying every table axis and the platform attitude (CONVENTIONS §6,
    ``table_tilt`` / ``table_azimuth``: base = I + [δ×]). Premultiplying each axis u_i → B u_i and the chain
    by B is, to first order in δ, the same as C → B C and ω_LP → B ω_LP, which is how it is applied here
    (exactly as the contract words it: both the axes and the attitude are premultiplied).
    """
    c, outer = chain(axes, angles)
    w = jnp.einsum("i,ijk,ik->j", rates, outer, axes)
    if base is not None:
        c = base @ c
        w = base @ w
    return c, w
