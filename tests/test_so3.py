"""The one SO(3) exponential and logarithm (:mod:`gyrojax.physics.so3`) against scipy's rotation vectors, and its
derivatives against central finite differences, near the identity (θ from 1e-12 to 1e-3 rad, where the closed form
divides zero by zero) and far from it; the right Jacobian against its defining first-order property."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax.physics import so3

RNG = np.random.default_rng(3)
DIRECTIONS = RNG.standard_normal((4, 3))
DIRECTIONS /= np.linalg.norm(DIRECTIONS, axis=1)[:, None]
ANGLES = (0.0, 1e-12, 1e-9, 1e-8, 1e-6, 1e-3, 0.3, 2.0, 3.1, 7.0)


def vectors():
    return np.array([d * a for d in DIRECTIONS for a in ANGLES])


def test_exp_is_scipys_rotation_vector_rotation():
    v = vectors()
    got = np.asarray(so3.exp(jnp.asarray(v)))
    want = Rotation.from_rotvec(v).as_matrix()
    np.testing.assert_allclose(got, want, rtol=0, atol=4e-16 * 8)
    one = np.asarray(so3.exp(jnp.asarray(v[7])))  # a single vector as well as a stack
    np.testing.assert_array_equal(one, got[7])


def test_log_is_scipys_rotation_vector_at_every_angle():
    """Rotations at every angle of :data:`ANGLES` below π, at π and just below it, random ones and the face turns a
    hand protocol makes: scipy's rotation vector to rounding (at π, where ±v is one rotation, the same sign), in
    numpy and in JAX, and exp(log r) = r."""
    axes = RNG.standard_normal((50, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    v = np.concatenate(
        [
            vectors()[np.linalg.norm(vectors(), axis=1) < np.pi],
            axes * np.pi,
            axes * (np.pi - 1e-9),
            Rotation.random(200, random_state=5).as_rotvec(),
        ]
    )
    faces = np.array([[[0, 0, 1], [0, 1, 0], [-1, 0, 0]], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.eye(3)], float)
    r = np.concatenate([Rotation.from_rotvec(v).as_matrix(), faces, faces.transpose(0, 2, 1) @ faces[::-1]])
    want = Rotation.from_matrix(r).as_rotvec()
    got = so3.log(r)
    np.testing.assert_allclose(got, want, rtol=0, atol=8 * 4.5e-16 * np.pi)
    np.testing.assert_allclose(np.asarray(so3.log(jnp.asarray(r))), want, rtol=0, atol=8 * 4.5e-16 * np.pi)
    np.testing.assert_allclose(so3.exp(got), r, rtol=0, atol=8 * 2.3e-16 * np.pi)
    assert so3.log(r[0]).shape == (3,)


def test_rotation_of_axis_and_angle():
    got = np.asarray(so3.rotation(jnp.asarray(DIRECTIONS), jnp.asarray([0.5, -1.0, 2.5, 0.0])))
    want = Rotation.from_rotvec(DIRECTIONS * np.array([0.5, -1.0, 2.5, 0.0])[:, None]).as_matrix()
    np.testing.assert_allclose(got, want, rtol=0, atol=4e-15)


@pytest.mark.parametrize("angle", [0.0, 1e-10, 1e-6, 1e-4, 0.7, 3.0])
def test_exp_derivative_is_the_finite_difference(angle):
    """Forward and reverse mode agree with a central difference (step 1e-6, truncation ~1e-12) at every θ, and at
    θ = 0 the derivative is the generator: ∂ exp([v×])/∂v_i = [e_i×] (no NaN from 0/0)."""
    v0 = DIRECTIONS[1] * angle
    jac = np.asarray(jax.jacfwd(so3.exp)(jnp.asarray(v0)))  # (3, 3, 3): matrix entries × v_i
    rev = np.asarray(jax.jacrev(so3.exp)(jnp.asarray(v0)))
    h = 1e-6
    fd = np.stack(
        [
            (Rotation.from_rotvec(v0 + h * e).as_matrix() - Rotation.from_rotvec(v0 - h * e).as_matrix()) / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )
    assert np.all(np.isfinite(jac)) and np.all(np.isfinite(rev))
    np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rev, jac, rtol=0, atol=1e-15)
    if angle == 0.0:
        gen = np.stack([np.cross(e, np.eye(3)).T for e in np.eye(3)], axis=-1)  # [e_i×]: column k is e_i × e_k
        np.testing.assert_allclose(jac, gen, rtol=0, atol=0)


def test_second_derivative_is_finite_at_the_identity():
    """A design differentiates through rows that are themselves derivatives: the Hessian at 0 is finite, and equals
    that of the series I + [v×] + [v×]²/2 (the exponential to second order)."""
    hess = np.asarray(jax.jacfwd(jax.jacfwd(so3.exp))(jnp.zeros(3)))
    want = np.asarray(
        jax.jacfwd(jax.jacfwd(lambda v: jnp.eye(3) + so3.hat(v) + so3.hat(v) @ so3.hat(v) / 2))(jnp.zeros(3))
    )
    np.testing.assert_allclose(hess, want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("angle", [0.0, 1e-5, 1e-3, 0.4, 2.9])
def test_right_jacobian_is_the_first_order_perturbation(angle):
    """exp([(v + δ)×]) = exp([v×]) exp([(J_r δ)×]) to first order: the relative rotation's vector over δ, from
    scipy, against J_r δ (step 1e-7, second-order error ~1e-7 relative)."""
    v = DIRECTIONS[2] * angle
    jr = np.asarray(so3.right_jacobian(jnp.asarray(v)))
    h = 1e-7
    for e in np.eye(3):
        rel = Rotation.from_rotvec(v).inv() * Rotation.from_rotvec(v + h * e)
        np.testing.assert_allclose(jr @ e, rel.as_rotvec() / h, rtol=0, atol=3e-7)
