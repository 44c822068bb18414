"""Turntable kinematics: the gimbal chain, platform attitude and angular rate (conventions §3).

A table has k axes, outermost first; axis i has unit vector u_i written in L with every angle at zero.

    C(θ) = R(u_1, θ_1) · … · R(u_k, θ_k),   R(u, θ) = exp(θ [u×])   (:func:`gyrojax.physics.so3.rotation`)
    ω_LP = Σ_i θ̇_i · R(u_1, θ_1) … R(u_{i−1}, θ_{i−1}) u_i      (in L)
    ω_IP = Ω + ω_LP

The matrix functions below take one sample (angles of shape (k,)); batch them with ``jax.vmap``. The measurement
model evaluates the same chain for whole records at once in vector form (:func:`platform_inputs`): each rotation
acts on the three components elementwise (Rodrigues), from precomputed (cos θ_i, sin θ_i), with no 3×3 matrix and no
transcendental function per sample.
"""

import jax.numpy as jnp

from gyrojax.physics.so3 import hat, rotation


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
    """C(θ): platform coordinates → L coordinates (conventions §3); ``angles`` in rad, ``axes`` unit vectors in L."""
    return chain(axes, angles)[0]


def platform_rate(axes, angles, rates):
    """ω_LP in L (rad/s) for table angles (rad) and angle rates (rad/s)."""
    _, outer = chain(axes, angles)
    return jnp.einsum("i,ijk,ik->j", rates, outer, axes)


def platform_state(axes, angles, rates, base=None):
    """Attitude C and platform rate ω_LP in L (rad/s), with an optional base misorientation.

    ``angles`` in rad, ``rates`` (angle rates) in rad/s, ``axes`` unit vectors in L.

    ``base`` is a 3×3 matrix premultiplying every table axis and the platform attitude (conventions §6,
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


# ---- the chain in vector form, for many samples at once ----------------------------------------------------------


def rotate(u, c, s, v):
    """R(u, θ) v by Rodrigues, elementwise: v cos θ + (u × v) sin θ + u (u·v)(1 − cos θ).

    ``u`` a unit vector (3,); ``c``, ``s`` cos θ and sin θ (any shape); ``v`` three components of that shape.
    """
    x = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    d = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    return tuple(v[i] * c + x[i] * s + u[i] * d * (1.0 - c) for i in range(3))


def turn(c, s, eps):
    """(cos, sin) of θ + ε from those of θ, for a small angle ε (rad), with cos ε and sin ε by their Taylor series
    (exact to rounding for |ε| < 0.05 rad: the first omitted terms are below 1e-16 relative)."""
    e2 = eps * eps
    ce = 1.0 - e2 / 2.0 * (1.0 - e2 / 12.0 * (1.0 - e2 / 30.0 * (1.0 - e2 / 56.0)))
    se = eps * (1.0 - e2 / 6.0 * (1.0 - e2 / 20.0 * (1.0 - e2 / 42.0 * (1.0 - e2 / 72.0))))
    return c * ce - s * se, s * ce + c * se


def _matvec(m, v):
    return tuple(m[i, 0] * v[0] + m[i, 1] * v[1] + m[i, 2] * v[2] for i in range(3))


def platform_inputs(axes, trig, rates, delta, omega, force):
    """Inertial rate ω_P and specific force f_P in platform coordinates, for every sample (vector form).

    With B = I + [δ×] the base misorientation (``delta``, rad; :func:`platform_state`), C = B·R(u_1,θ_1)…R(u_k,θ_k)
    and ω_LP = B Σ_i θ̇_i R(u_1,θ_1)…R(u_{i−1},θ_{i−1}) u_i: ω_P = Cᵀ(Ω + ω_LP), f_P = Cᵀ f (conventions §3–§4).
    ``axes`` (k, 3) unit vectors in L; ``trig`` per axis (cos θ_i, sin θ_i), each (n,); ``rates`` per axis θ̇_i (n,)
    in rad/s; ``omega`` (Ω, rad/s) and ``force`` (f, m/s²) in L, (3,). Returns two 3-tuples of (n,) arrays, in the
    units of ``omega`` and ``force``.
    """
    k = axes.shape[0]
    n = trig[0][0].shape
    zero = jnp.zeros(n)
    w = (zero, zero, zero)
    for i in range(k):  # ω_LP without the base: θ̇_i R_1 … R_{i−1} u_i
        v = tuple(jnp.full(n, axes[i, j]) for j in range(3))
        for j in range(i - 1, -1, -1):
            v = rotate(axes[j], trig[j][0], trig[j][1], v)
        w = tuple(w[j] + rates[i] * v[j] for j in range(3))
    b = jnp.eye(3) + hat(delta)
    bw = _matvec(b, w)
    wi = _matvec(b.T, tuple(omega[j] + bw[j] for j in range(3)))  # Bᵀ(Ω + B ω_LP0)
    fb = b.T @ force
    fi = tuple(jnp.full(n, fb[j]) for j in range(3))
    for j in range(k):  # Cᵀ = R_kᵀ … R_1ᵀ: apply R_1ᵀ first
        wi = rotate(axes[j], trig[j][0], -trig[j][1], wi)
        fi = rotate(axes[j], trig[j][0], -trig[j][1], fi)
    return wi, fi
