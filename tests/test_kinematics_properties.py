"""Properties of the gimbal chain and the site frame (conventions §2–§3), checked with hypothesis.

* C(θ) = R(u_1,θ_1)…R(u_k,θ_k) is a proper rotation for any unit axes (1–4 of them) and angles, and equals the
  same product built with scipy's rotation vectors.
* ω_LP is the angular rate of C: [ω_LP×] = Ċ Cᵀ, with Ċ from central differences along θ̇ and from
  ``jax.jacfwd`` (exact), and Ċ Cᵀ is skew-symmetric.
* Rotating the whole experiment (table axes, instrument triad, Earth rate and specific force) by one rotation Q
  leaves the instrument inputs unchanged. Through the public ``model.sensed`` (whose Ω and f are fixed by the
  latitude) this is checked in its three exact special cases: a rotation about Up keeps f (so the specific
  forces and the table-rate part of the rates are invariant); a rotation about East by Δ maps Ω(φ) to Ω(φ + Δ)
  (so the rates are invariant when the latitude moves by Δ); at a pole any rotation about Up keeps both.
* ``normal_gravity`` equals Somigliana's closed form written with the semi-axes,
  γ = (a γ_e cos²φ + b γ_p sin²φ)/√(a² cos²φ + b² sin²φ) (WGS-84: NIMA TR8350.2 eq. 4-1), at the equator, the
  pole and 45° (9.8061977693 m/s²), and the 1980 International Gravity Formula series to its truncation error.
"""

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gyrojax import units
from gyrojax.physics import frames, kinematics, model, so3

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True)

_attitude = jax.jit(kinematics.platform_attitude)
_rate = jax.jit(kinematics.platform_rate)
_state = jax.jit(kinematics.platform_state)
_dattitude = jax.jit(
    lambda axes, angles, rates: jax.jacfwd(lambda a: kinematics.platform_attitude(axes, a))(angles) @ rates
)
_sensed = jax.jit(model.sensed)

finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def unit_vectors(draw):
    v = np.array(draw(st.lists(st.floats(-1.0, 1.0, **finite), min_size=3, max_size=3)))
    n = np.linalg.norm(v)
    if n < 1e-3:
        v, n = np.array([0.0, 0.0, 1.0]), 1.0
    return v / n


@st.composite
def chains(draw, min_axes=1, max_axes=4):
    """(axes (k, 3), angles (k,), rates (k,)) with angles in ±4π rad and rates in ±2 rad/s."""
    k = draw(st.integers(min_axes, max_axes))
    axes = np.array([draw(unit_vectors()) for _ in range(k)])
    angles = np.array(draw(st.lists(st.floats(-4 * np.pi, 4 * np.pi, **finite), min_size=k, max_size=k)))
    rates = np.array(draw(st.lists(st.floats(-2.0, 2.0, **finite), min_size=k, max_size=k)))
    return axes, angles, rates


@st.composite
def rotations(draw):
    """A rotation matrix from a random quaternion (uniform enough for a property test)."""
    q = np.array(draw(st.lists(st.floats(-1.0, 1.0, **finite), min_size=4, max_size=4)))
    if np.linalg.norm(q) < 1e-3:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    return Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()


def triads():
    """A right-handed instrument triad (rows) from a random rotation."""
    return rotations().map(lambda r: r.T.copy())


def unskew(m):
    return np.array([m[2, 1], m[0, 2], m[1, 0]])


# ---- C(θ) is a rotation --------------------------------------------------------------------------------------


@SETTINGS
@given(chains())
def test_attitude_is_a_proper_rotation(chain):
    axes, angles, _ = chain
    c = np.asarray(_attitude(jnp.asarray(axes), jnp.asarray(angles)))
    np.testing.assert_allclose(c @ c.T, np.eye(3), rtol=0, atol=1e-12)
    assert abs(np.linalg.det(c) - 1.0) < 1e-12
    ref = np.eye(3)
    for u, t in zip(axes, angles, strict=True):
        ref = ref @ Rotation.from_rotvec(u * t).as_matrix()
    np.testing.assert_allclose(c, ref, rtol=0, atol=1e-12)


# ---- ω_LP is the rate of C -----------------------------------------------------------------------------------


@SETTINGS
@given(chains())
def test_platform_rate_is_the_derivative_of_attitude(chain):
    axes, angles, rates = chain
    ax, an, ra = jnp.asarray(axes), jnp.asarray(angles), jnp.asarray(rates)
    c = np.asarray(_attitude(ax, an))
    w = np.asarray(_rate(ax, an, ra))

    # exact: Ċ = Σ ∂C/∂θ_i θ̇_i by forward-mode autodiff
    omega_x = np.asarray(_dattitude(ax, an, ra)) @ c.T
    np.testing.assert_allclose(omega_x, -omega_x.T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(unskew(omega_x), w, rtol=0, atol=1e-12)

    # central differences along the path θ(t) = θ + t θ̇: error O(h² |θ̇|³) + O(ε/h)
    h = 1e-5
    cp = np.asarray(_attitude(ax, an + h * ra))
    cm = np.asarray(_attitude(ax, an - h * ra))
    omega_fd = (cp - cm) / (2 * h) @ c.T
    np.testing.assert_allclose(unskew(omega_fd), w, rtol=0, atol=1e-8)


# ---- rotating the whole experiment changes nothing -----------------------------------------------------------


def _inputs(axes, triad, omega, force, angles, rates):
    """Rate and force along the triad for an arbitrary Earth rate and specific force written in L."""
    c, w_lp = _state(jnp.asarray(axes), jnp.asarray(angles), jnp.asarray(rates))
    c = np.asarray(c)
    return triad @ c.T @ (omega + np.asarray(w_lp)), triad @ c.T @ force


@SETTINGS
@given(chains(), triads(), rotations(), st.floats(-np.pi / 2, np.pi / 2, **finite))
def test_inputs_invariant_under_a_common_rotation(chain, triad, q, phi):
    axes, angles, rates = chain
    rates = rates * 1e-3
    omega = np.asarray(frames.earth_rate_enu(jnp.asarray(phi)))
    force = np.array([0.0, 0.0, 9.8])
    w0, a0 = _inputs(axes, triad, omega, force, angles, rates)
    w1, a1 = _inputs(axes @ q.T, triad @ q.T, q @ omega, q @ force, angles, rates)
    np.testing.assert_allclose(w1 / units.OMEGA_IE, w0 / units.OMEGA_IE, rtol=0, atol=1e-10)
    np.testing.assert_allclose(a1, a0, rtol=0, atol=1e-12)


def _sensed_np(axes, triad, phi, angles, rates):
    w, a = _sensed(
        jnp.asarray(axes),
        jnp.asarray(triad),
        jnp.asarray(phi),
        jnp.asarray(9.80155),
        jnp.asarray(angles),
        jnp.asarray(rates),
        jnp.zeros(3),
    )
    return np.asarray(w), np.asarray(a)


def _about(axis, angle):
    return Rotation.from_rotvec(np.asarray(axis, dtype=float) * angle).as_matrix()


@SETTINGS
@given(chains(), triads(), st.floats(-np.pi, np.pi, **finite), st.floats(-1.5, 1.5, **finite))
def test_sensed_invariant_under_azimuth_rotation(chain, triad, psi, phi):
    """Q about Up keeps f = (0, 0, g): the specific forces and the table-rate part of the rates are invariant."""
    axes, angles, rates = chain
    q = _about([0, 0, 1], psi)
    w0, a0 = _sensed_np(axes, triad, phi, angles, rates)
    w1, a1 = _sensed_np(axes @ q.T, triad @ q.T, phi, angles, rates)
    np.testing.assert_allclose(a1, a0, rtol=0, atol=1e-12)
    z = np.zeros_like(rates)
    table0 = w0 - _sensed_np(axes, triad, phi, angles, z)[0]
    table1 = w1 - _sensed_np(axes @ q.T, triad @ q.T, phi, angles, z)[0]
    np.testing.assert_allclose(table1, table0, rtol=1e-11, atol=1e-6)  # deg/h, table rates up to 4e5 deg/h


@SETTINGS
@given(chains(), triads(), st.floats(-1.2, 1.2, **finite), st.floats(-0.35, 0.35, **finite))
def test_sensed_rates_invariant_under_meridian_rotation(chain, triad, phi, delta):
    """Q about East by Δ maps Ω(φ) to Ω(φ + Δ): the rates are invariant when the site moves by Δ in latitude."""
    axes, angles, rates = chain
    rates = rates * 1e-4
    q = _about([1, 0, 0], delta)
    w0, _ = _sensed_np(axes, triad, phi, angles, rates)
    w1, _ = _sensed_np(axes @ q.T, triad @ q.T, phi + delta, angles, rates)
    np.testing.assert_allclose(w1, w0, rtol=0, atol=1e-9)  # deg/h


@SETTINGS
@given(chains(), triads(), st.floats(-np.pi, np.pi, **finite), st.sampled_from([np.pi / 2, -np.pi / 2]))
def test_sensed_invariant_under_azimuth_rotation_at_a_pole(chain, triad, psi, phi):
    """At a pole Ω ∥ f, so any rotation about Up leaves every input unchanged."""
    axes, angles, rates = chain
    rates = rates * 1e-4
    q = _about([0, 0, 1], psi)
    w0, a0 = _sensed_np(axes, triad, phi, angles, rates)
    w1, a1 = _sensed_np(axes @ q.T, triad @ q.T, phi, angles, rates)
    np.testing.assert_allclose(w1, w0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a1, a0, rtol=0, atol=1e-12)


def test_invariance_checks_are_not_vacuous():
    """A rotation about North is *not* a symmetry of the site: rates and forces both change."""
    axes, triad = np.array([[0.0, 0.0, 1.0]]), np.eye(3)
    angles, rates = np.array([0.3]), np.array([0.0])
    q = _about([0, 1, 0], 0.2)
    w0, a0 = _sensed_np(axes, triad, 0.7, angles, rates)
    w1, a1 = _sensed_np(axes @ q.T, triad @ q.T, 0.7, angles, rates)
    assert np.max(np.abs(a1 - a0)) > 0.1 and np.max(np.abs(w1 - w0)) > 1.0


# ---- normal gravity --------------------------------------------------------------------------------------------

# WGS-84 (NIMA TR8350.2, table 3.1 and eq. 4-1), written here independently of gyrojax.units.
A_WGS84, B_WGS84 = 6378137.0, 6356752.3142
GAMMA_E, GAMMA_P = 9.7803253359, 9.8321849378


def somigliana(phi):
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    return (A_WGS84 * GAMMA_E * c2 + B_WGS84 * GAMMA_P * s2) / np.sqrt(A_WGS84**2 * c2 + B_WGS84**2 * s2)


def test_normal_gravity_equator_pole_and_45():
    g = lambda deg: float(frames.normal_gravity(jnp.asarray(np.deg2rad(deg))))
    assert abs(g(0.0) - 9.7803253359) < 1e-10
    assert abs(g(90.0) - 9.8321849378) < 1e-9  # the rounded WGS-84 constants agree to ~1e-10 here
    assert abs(g(-90.0) - 9.8321849378) < 1e-9
    assert abs(g(45.0) - somigliana(np.pi / 4)) < 1e-9
    assert abs(g(45.0) - 9.8061977693) < 1e-9


@settings(max_examples=50, deadline=None, derandomize=True)
@given(st.floats(-np.pi / 2, np.pi / 2, **finite))
def test_normal_gravity_matches_somigliana_and_igf1980(phi):
    g = float(frames.normal_gravity(jnp.asarray(phi)))
    assert abs(g - somigliana(phi)) < 1e-9
    assert abs(g - float(frames.normal_gravity(jnp.asarray(-phi)))) < 1e-14
    # International Gravity Formula 1980 (GRS80, truncated series): agrees to a few 1e-6 m/s²
    igf = 9.780327 * (1 + 0.0053024 * np.sin(phi) ** 2 - 0.0000058 * np.sin(2 * phi) ** 2)
    assert abs(g - igf) < 5e-6


# ---- the vector form the measurement model evaluates is the matrix chain ----------------------------------------


@SETTINGS
@given(chains(), st.lists(st.floats(-0.01, 0.01, **finite), min_size=3, max_size=3))
def test_vector_form_is_the_matrix_chain(chain, delta):
    """platform_inputs (Rodrigues on vectors, from cos/sin) = Cᵀ(Ω + ω_LP), Cᵀ f with C, ω_LP of the 3×3 matrix
    chain (platform_state, base B = I + [δ×]); and kinematics.turn is the rotation of (cos, sin) by a small angle."""
    axes, angles, rates = chain
    delta = np.array(delta)
    om, f = np.array([0.0, 5e-5, 4e-5]), np.array([0.0, 0.0, 9.8])
    c, w = (np.asarray(m) for m in _state(axes, angles, rates, jnp.eye(3) + so3.hat(jnp.asarray(delta))))
    trig = [(jnp.cos(a), jnp.sin(a)) for a in angles]
    wp, fp = kinematics.platform_inputs(jnp.asarray(axes), trig, list(jnp.asarray(rates)), jnp.asarray(delta), om, f)
    np.testing.assert_allclose(np.array(wp), c.T @ (om + w), rtol=0, atol=1e-13)
    np.testing.assert_allclose(np.array(fp), c.T @ f, rtol=0, atol=1e-12)
    for a in angles:
        for eps in (0.049, -1e-3, 1e-9):
            ct, st_ = kinematics.turn(np.cos(a), np.sin(a), eps)
            np.testing.assert_allclose([ct, st_], [np.cos(a + eps), np.sin(a + eps)], rtol=0, atol=2e-15)
