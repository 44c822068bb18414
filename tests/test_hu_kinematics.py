"""Hu's gravity and Earth-rate components (ch. 3 and its appendix 2) against gyrojax's instrument inputs.

For every mounting the book describes, the table geometry and the instrument triad are set up from the book's
*text* (the OCR of seed 002 has lost every figure, so "see Fig. 3-10" cannot be read; each set-up below quotes
the sentence it comes from), the book's printed components are transcribed in a small numpy function named
after the equation, converted to the signs of the conventions (conventions §2, §10), and compared with
:func:`gyrojax.physics.model.sensed` at many table angles and two latitudes (one of them southern, so sin φ < 0
is exercised) to ~1e-12.

Sign conversion (conventions §2, "Book sign note"): Hu writes the components of the *gravity* vector, positive
toward the ground, so his ``g_x = −a_I·g0`` when a_I (in g) is the specific force along IA; his ``g`` in the
formulas is the local gravity magnitude. Earth-rate components (ω_ex …) keep their sign. Hu's table angle θ is
"clockwise positive" with the table turning "opposite to the Earth's rotation": in the conventions' signs that is a
right-hand rotation about −ω_e, i.e. the table axis is ``u = −(0, cos φ, sin φ)`` and θ is used unchanged. Every
printed formula of 3-13…3-30 confirms this reading.

Checked (equation numbers as printed in seed 002):

* single-axis tumble, SDF gyro: 3-13, 3-15, and the vertical fixed positions 3-17, 3-19;
* single-axis tumble, TDF gyro: 3-22, 3-24, 3-27, 3-30;
* two-axis tumble: 3-47, the direction-cosine matrix 3-48, and 3-49 for several m:n;
* servo mountings: 3-60, 3-62 (IA vertical), 3-64, 3-69, 3-74, 3-79 (IA horizontal, four azimuths each),
  3-84, 3-86 (IA polar), and the servo relation 3-59 (θ̇ = −ω_ex − ω_d ⇔ ω_I + drift = 0, conventions §4);
* two-axis servo: the matrix 3-96, the rate relation 3-97 for an arbitrary table orientation, and its worked
  example 3-98…3-101;
* the 12 two-axis mountings of appendix 2 (附录二).

Seed findings (each asserted below):

* **Misprint in Hu appendix 2, mounting 3** (X→N, Y→E): the printed α̇ has ``ω_e cos φ cos θ_x``; geometry
  (and Hu's own general relation 3-97 with ω_eX = ω_e cos φ) gives ``ω_e cos φ cos θ_y``.
* In appendix 2 the parenthesised spin-axis labels (H→ζ, H→N, …) name the *line* of H, not its sense: the
  book defines OXYZ right-handed with H along OZ, and the printed formulas follow Z = X × Y, which is opposite
  to the label in mountings 2, 3, 6, 7, 9 and 12 (e.g. mounting 2, X→E, Y→ζ(up): Z points South, labelled "H→N").
* The OCR prints the polar-servo equation "IA south" with the number (3-34); the text that follows calls it
  (3-84), which is the number used here. No other equation listed in the brief was missing or unreadable.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax import units
from gyrojax.data import record
from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.physics import kinematics, model

G_SITE = 9.80155  # local gravity used in every check (Hu's "g"), m/s²
LATITUDES = (np.deg2rad(39.98), np.deg2rad(-33.87))
W_E = units.OMEGA_IE  # ω_e, rad/s
TOL = 1e-12

_rng = np.random.default_rng(20261122)
THETAS = np.concatenate([np.linspace(0.0, 2 * np.pi, 37), _rng.uniform(-4 * np.pi, 4 * np.pi, 64)])

# ENU directions
E, N, U = np.eye(3)
W, S, D = -E, -N, -U


def polar(phi):
    """Direction of ω_e in L: (0, cos φ, sin φ)."""
    return np.array([0.0, np.cos(phi), np.sin(phi)])


def meridian_i(phi):
    """Hu's I (appendix 2): in the meridian plane, ⟂ ω_e, with (E, ω_e, I) right-handed, so I = E × ω_e."""
    return np.cross(E, polar(phi))


_sensed = jax.jit(jax.vmap(model.sensed, in_axes=(None, None, None, None, 0, 0, None)))


def gyrojax_inputs(axes, triad, phi, angles, rates=None):
    """gyrojax's inputs along the triad for each row of ``angles`` (rad) and ``rates`` (rad/s).

    Returns (rate in rad/s, specific force in g); the rate is converted back from deg/h.
    """
    angles = np.asarray(angles, dtype=float).reshape(len(angles), -1)
    rates = np.zeros_like(angles) if rates is None else np.asarray(rates, dtype=float).reshape(angles.shape)
    w, a = _sensed(
        jnp.asarray(np.atleast_2d(axes), dtype=float),
        jnp.asarray(triad, dtype=float),
        jnp.asarray(phi),
        jnp.asarray(G_SITE),
        jnp.asarray(angles),
        jnp.asarray(rates),
        jnp.zeros(3),
    )
    return np.asarray(w) * units.DEG_PER_H, np.asarray(a)


def book_gravity_to_specific_force(g_book):
    """conventions §2 Book sign note: specific force in g = −(Hu's gravity component)/g0."""
    return -np.asarray(g_book) / units.G0


def assert_gravity(a_gyrojax, g_book):
    np.testing.assert_allclose(a_gyrojax, book_gravity_to_specific_force(g_book), rtol=0, atol=TOL)


def assert_rate(w_gyrojax, w_book):
    """Compare rates in units of ω_e (so the 1e-12 tolerance is relative to Earth rate)."""
    np.testing.assert_allclose(np.asarray(w_gyrojax) / W_E, np.asarray(w_book) / W_E, rtol=0, atol=TOL)


def triad_of(x, y):
    """Right-handed triad with rows x, y, x × y."""
    return np.array([x, y, np.cross(x, y)])


# =============================================================================================================
# Single-axis tumble, SDF gyro (Hu §3.4.2.1): x = IA, y = OA, z = SA.
# "转台轴平行于地球自转轴 … 陀螺仪的输出轴 y 平行于转台轴安装, 其输入轴与转台轴垂直, 初始时指东,
#  转台转角 θ 以顺时针方向增量为正", table turning at 10 ω_e opposite to the Earth.
# =============================================================================================================


def hu_3_13(theta, phi, g):
    """Hu (3-13): g_x = −g cos φ sin θ, g_y = −g sin φ, g_z = −g cos φ cos θ."""
    one = np.ones_like(theta)
    return np.stack([-g * np.cos(phi) * np.sin(theta), -g * np.sin(phi) * one, -g * np.cos(phi) * np.cos(theta)], -1)


def hu_3_15(theta, phi, g):
    """Hu (3-15), gyro turned 180° about x: g_x = −g cos φ sin θ, g_y = g sin φ, g_z = g cos φ cos θ."""
    one = np.ones_like(theta)
    return np.stack([-g * np.cos(phi) * np.sin(theta), g * np.sin(phi) * one, g * np.cos(phi) * np.cos(theta)], -1)


def tumble_sdf_mounting(eq, phi):
    """Table axis and (IA, OA, SA) at θ = 0 for 3-13 (OA along ω_e) and 3-15 (flipped about IA)."""
    p = polar(phi)
    oa = p if eq == "3-13" else -p
    return np.array([-p]), triad_of(E, oa)


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("eq, book", [("3-13", hu_3_13), ("3-15", hu_3_15)])
def test_single_axis_tumble_sdf_gravity(eq, book, phi):
    axes, triad = tumble_sdf_mounting(eq, phi)
    _, a = gyrojax_inputs(axes, triad, phi, THETAS)
    assert_gravity(a, book(THETAS, phi, G_SITE))


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("eq", ["3-13", "3-15"])
def test_single_axis_tumble_ia_sees_no_rate(eq, phi):
    """ "为避免陀螺仪感受转台的角速度 … 输入轴与转台轴垂直": IA sees neither the table rate nor ω_e, while OA
    (along the polar table axis) sees ω_e − 10 ω_e (3-13) or its negative (3-15)."""
    axes, triad = tumble_sdf_mounting(eq, phi)
    w, _ = gyrojax_inputs(axes, triad, phi, THETAS, np.full(THETAS.shape, 10 * W_E))
    assert_rate(w[:, 0], 0.0)
    assert_rate(w[:, 1], (-9 if eq == "3-13" else 9) * W_E)


@pytest.mark.parametrize("phi", LATITUDES)
def test_vertical_fixed_positions_3_17_3_19(phi):
    """Hu (3-17): table axis vertical, OA up, IA east, table still: g_x = g_z = 0, g_y = −g; (3-19) flipped
    about x: g_y = +g."""
    for oa, gy in ((U, -G_SITE), (D, G_SITE)):
        _, a = gyrojax_inputs([U], triad_of(E, oa), phi, THETAS)
        assert_gravity(a, np.broadcast_to([0.0, gy, 0.0], a.shape))


# =============================================================================================================
# Single-axis tumble, TDF gyro (Hu §3.4.2.2): x = outer gimbal, y = inner gimbal, z = spin; table as above.
# =============================================================================================================


def hu_3_22(theta, phi, g):
    """Hu (3-22): g_x = g cos φ cos θ, g_y = g cos φ sin θ, g_z = −g sin φ."""
    c = g * np.cos(phi)
    return np.stack([c * np.cos(theta), c * np.sin(theta), -g * np.sin(phi) * np.ones_like(theta)], -1)


def hu_3_24(theta, phi, g):
    """Hu (3-24): g_x = g cos φ cos θ, g_y = −g cos φ sin θ, g_z = g sin φ."""
    c = g * np.cos(phi)
    return np.stack([c * np.cos(theta), -c * np.sin(theta), g * np.sin(phi) * np.ones_like(theta)], -1)


def hu_3_27(theta, phi, g):
    """Hu (3-27): g_x = g cos φ sin θ, g_y = −g cos φ cos θ, g_z = −g sin φ."""
    c = g * np.cos(phi)
    return np.stack([c * np.sin(theta), -c * np.cos(theta), -g * np.sin(phi) * np.ones_like(theta)], -1)


def hu_3_30(theta, phi, g):
    """Hu (3-30): g_x = g cos φ sin θ, g_y = g cos φ cos θ, g_z = g sin φ."""
    c = g * np.cos(phi)
    return np.stack([c * np.sin(theta), c * np.cos(theta), g * np.sin(phi) * np.ones_like(theta)], -1)


def tumble_tdf_triad(eq, phi):
    """(X, Y, Z) at θ = 0.

    3-22: "转子轴 z 平行转台轴 … 平行地轴安装, 陀螺仪内环轴 y 指西"  → Z = ω_e, Y = W.
    3-24: "绕其初始时的 x_0 轴翻转 180° 即 y_0 → E, −z ∥ ω_e"        → Y = E, Z = −ω_e.
    3-27: "转子轴 z 平行转台轴与地轴 … 初始时 x 指西"                  → Z = ω_e, X = W.
    3-30: "绕其 x 轴的初始位置翻转 180°"                              → X = W, Z = −ω_e.
    """
    p = polar(phi)
    if eq == "3-22":
        return triad_of(np.cross(W, p), W)
    if eq == "3-24":
        return triad_of(np.cross(W, p), E)
    if eq == "3-27":
        return triad_of(W, np.cross(p, W))
    return triad_of(W, -np.cross(p, W))


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("eq, book", [("3-22", hu_3_22), ("3-24", hu_3_24), ("3-27", hu_3_27), ("3-30", hu_3_30)])
def test_single_axis_tumble_tdf_gravity(eq, book, phi):
    triad = tumble_tdf_triad(eq, phi)
    assert np.allclose(np.abs(triad[2]), np.abs(polar(phi)))  # spin along the table axis, as the text says
    _, a = gyrojax_inputs([-polar(phi)], triad, phi, THETAS)
    assert_gravity(a, book(THETAS, phi, G_SITE))
    # Spin along the (polar) table axis: neither sensing axis sees the table rate or ω_e.
    w, _ = gyrojax_inputs([-polar(phi)], triad, phi, THETAS, np.full(THETAS.shape, 10 * W_E))
    assert_rate(w[:, :2], 0.0)


# =============================================================================================================
# Two-axis tumble (Hu §3.4.3): outer axis ∥ OA (y0) ∥ ω_e, inner axis ∥ IA (x0), SA (z0) west;
# "令转台外, 内环轴相对基座角位置之比为 mθ/nθ".
# =============================================================================================================


def hu_3_47(phi, g):
    """Hu (3-47): g_x0 = −g cos φ, g_y0 = −g sin φ, g_z0 = 0."""
    return np.array([-g * np.cos(phi), -g * np.sin(phi), 0.0])


def hu_3_48(m_theta, n_theta):
    """Hu (3-48): rows are x, y, z in the basis (x0, y0, z0)."""
    cm, sm, cn, sn = np.cos(m_theta), np.sin(m_theta), np.cos(n_theta), np.sin(n_theta)
    return np.array([[cm, 0.0, -sm], [sn * sm, cn, sn * cm], [cn * sm, -sn, cn * cm]])


def hu_3_49(theta, m, n, phi, g):
    """Hu (3-49)."""
    cp, sp = np.cos(phi), np.sin(phi)
    gx = -g * cp * np.cos(m * theta)
    gy = 0.5 * g * cp * (np.cos((m + n) * theta) - np.cos((m - n) * theta)) - g * sp * np.cos(n * theta)
    gz = -0.5 * g * cp * (np.sin((m + n) * theta) + np.sin((m - n) * theta)) + g * sp * np.sin(n * theta)
    return np.stack([gx, gy, gz], -1)


def two_axis_tumble_mounting(phi):
    p = polar(phi)
    x0 = np.cross(p, W)  # IA completes (x0, y0 = ω_e, z0 = W) right-handed: x0 = y0 × z0
    return np.array([p, x0]), triad_of(x0, p)


MN = [(1, 1), (2, 1), (3, 2), (1, 3), (5, 3)]


@pytest.mark.parametrize("phi", LATITUDES)
def test_two_axis_tumble_3_47_3_48(phi):
    axes, triad = two_axis_tumble_mounting(phi)
    _, a0 = gyrojax_inputs(axes, triad, phi, np.zeros((1, 2)))
    assert_gravity(a0[0], hu_3_47(phi, G_SITE))
    t = triad  # rows x0, y0, z0 in L
    for mt, nt in _rng.uniform(-7, 7, size=(25, 2)):
        c = np.asarray(kinematics.platform_attitude(jnp.asarray(axes), jnp.array([mt, nt])))
        # row j of 3-48 = the carried axis C·(t_j) in the basis t, i.e. column j of t C tᵀ
        np.testing.assert_allclose((t @ c @ t.T).T, hu_3_48(mt, nt), rtol=0, atol=TOL)


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("m, n", MN)
def test_two_axis_tumble_3_49(m, n, phi):
    axes, triad = two_axis_tumble_mounting(phi)
    angles = np.stack([m * THETAS, n * THETAS], -1)
    rates = np.broadcast_to([m * 1e-3, n * 1e-3], angles.shape)
    w, a = gyrojax_inputs(axes, triad, phi, angles, rates)
    assert_gravity(a, hu_3_49(THETAS, m, n, phi, G_SITE))
    # "陀螺仪输入轴在试验过程中始终垂直于地球自转轴, 因而它不敏感地球的自转角速度 … 转台内环轴的旋转角速度直接
    #  被陀螺仪输入轴所敏感": ω_I is the inner-axis rate alone.
    assert_rate(w[:, 0], n * 1e-3)


# =============================================================================================================
# Single-axis servo mountings (Hu §3.5.3): IA ∥ table axis, "设转台转速矢量 θ̇ 的正方向总是和 x 轴的正向相同".
# =============================================================================================================


def hu_3_84(theta, phi, g):
    """Hu (3-84) (printed as "(3-34)" by the OCR), IA south along the polar axis, OA initially west:
    g_x = g sin φ, g_y = g cos φ sin θ, g_z = g cos φ cos θ; ω_ex = −ω_e."""
    one = np.ones_like(theta)
    c = g * np.cos(phi)
    return np.stack([g * np.sin(phi) * one, c * np.sin(theta), c * np.cos(theta)], -1), -W_E * one


def hu_3_86(theta, phi, g):
    """Hu (3-86), IA north along the polar axis, OA initially west:
    g_x = −g sin φ, g_y = −g cos φ sin θ, g_z = −g cos φ cos θ; ω_ex = ω_e."""
    one = np.ones_like(theta)
    c = g * np.cos(phi)
    return np.stack([-g * np.sin(phi) * one, -c * np.sin(theta), -c * np.cos(theta)], -1), W_E * one


def hu_omega_ex_horizontal(ia_name, phi):
    """Hu's ω_ex list for a horizontal IA (3-64, 3-69, 3-74, 3-79): 0 (E), ω_e cos φ (N), 0 (W), −ω_e cos φ (S)."""
    return {"E": 0.0, "N": W_E * np.cos(phi), "W": 0.0, "S": -W_E * np.cos(phi)}[ia_name]


HORIZONTAL = {"E": E, "N": N, "W": W, "S": S}


def servo_fixed_mountings():
    """(eq, IA, OA-or-SA rule, Hu's (g_x, g_y, g_z) / g, Hu's ω_ex(φ)) for 3-60 … 3-79."""
    g = 1.0
    rows = [
        # 3-60: IA down ("输入轴在地垂线方向且指向下"): g_x = g, ω_ex = −ω_e sin φ; OA any horizontal direction.
        ("3-60", D, ("oa", N), (g, 0, 0), lambda phi: -W_E * np.sin(phi)),
        # 3-62: IA up: g_x = −g, ω_ex = ω_e sin φ.
        ("3-62", U, ("oa", N), (-g, 0, 0), lambda phi: W_E * np.sin(phi)),
    ]
    for name, ia in HORIZONTAL.items():
        wex = lambda phi, name=name: hu_omega_ex_horizontal(name, phi)
        rows += [
            ("3-64", ia, ("oa", U), (0, -g, 0), wex),  # OA up
            ("3-69", ia, ("oa", D), (0, g, 0), wex),  # OA down
            ("3-74", ia, ("sa", D), (0, 0, g), wex),  # SA down
            ("3-79", ia, ("sa", U), (0, 0, -g), wex),  # SA up
        ]
    return rows


def servo_triad(ia, rule):
    kind, v = rule
    if kind == "oa":
        return triad_of(ia, v)
    return np.array([ia, np.cross(v, ia), v])  # OA = SA × IA keeps IA × OA = SA


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("eq, ia, rule, g_book, wex", servo_fixed_mountings())
def test_servo_fixed_mountings(eq, ia, rule, g_book, wex, phi):
    triad = servo_triad(ia, rule)
    # Class 1 (IA vertical): valid "无论输入轴绕转台轴的转角如何"; class 2 (IA horizontal): exact at θ = 0
    # only ("只有在转台转角较小 … 才被认为是正确的").
    thetas = THETAS if eq in ("3-60", "3-62") else np.zeros(1)
    _, a = gyrojax_inputs([ia], triad, phi, thetas)
    assert_gravity(a, np.broadcast_to(np.asarray(g_book, dtype=float) * G_SITE, a.shape))
    # ω_ex is the Earth-rate component along IA = table axis: independent of θ in every class.
    w, _ = gyrojax_inputs([ia], triad, phi, THETAS)
    assert_rate(w[:, 0], wex(phi))


def polar_servo_mounting(eq, phi):
    """3-84: "输入轴指南, 输出轴的初始位置指西"; 3-86: "输入轴指北, 输出轴初始位置指西" (IA ∥ Earth axis)."""
    ia = -polar(phi) if eq == "3-84" else polar(phi)
    return np.array([ia]), triad_of(ia, W)


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("eq, book", [("3-84", hu_3_84), ("3-86", hu_3_86)])
def test_polar_servo_mountings(eq, book, phi):
    axes, triad = polar_servo_mounting(eq, phi)
    w, a = gyrojax_inputs(axes, triad, phi, THETAS)
    g_book, wex = book(THETAS, phi, G_SITE)
    assert_gravity(a, g_book)
    assert_rate(w[:, 0], wex)


@pytest.mark.parametrize("phi", LATITUDES)
def test_servo_relation_3_59(phi):
    """Hu (3-59): θ̇ = −ω_ex − ω_d. Driving the table at that rate must leave gyrojax's ω_I = −ω_d, i.e. the
    balance ω_I + drift = 0 of an untorqued gyro in servo mode (conventions §4)."""
    drift = _rng.normal(0, 3 * W_E, THETAS.shape)
    for eq in ("3-84", "3-86"):
        axes, triad = polar_servo_mounting(eq, phi)
        _, wex = (hu_3_84 if eq == "3-84" else hu_3_86)(THETAS, phi, G_SITE)
        w, _ = gyrojax_inputs(axes, triad, phi, THETAS, -wex - drift)
        assert_rate(w[:, 0], -drift)
    for _eq, ia, rule, _, wex in servo_fixed_mountings():
        w, _ = gyrojax_inputs([ia], servo_triad(ia, rule), phi, THETAS, -wex(phi) - drift)
        assert_rate(w[:, 0], -drift)


# =============================================================================================================
# Two-axis servo (Hu §3.5.6): OX outer, OY inner, OZ = OX × OY; gyro inner-gimbal frame oxyz coincides with
# OXYZ at zero ("陀螺仪的内环轴平行于测试转台的内环轴 … 陀螺仪的外环轴平行于转台的外环轴").
# =============================================================================================================


def hu_3_96_product(tx, ty):
    """Hu (3-96), A = A_yY · A_xX (table base → gyro frame)."""
    a_y = np.array([[np.cos(ty), 0, -np.sin(ty)], [0, 1, 0], [np.sin(ty), 0, np.cos(ty)]])
    a_x = np.array([[1, 0, 0], [0, np.cos(tx), np.sin(tx)], [0, -np.sin(tx), np.cos(tx)]])
    return a_y @ a_x


def hu_3_96_expanded(tx, ty):
    """Hu (3-96), the printed product."""
    cx, sx, cy, sy = np.cos(tx), np.sin(tx), np.cos(ty), np.sin(ty)
    return np.array([[cy, sx * sy, -cx * sy], [0, cx, sx], [sy, -cy * sx, cx * cy]])


def hu_3_97(tx, ty, rx, ry, wex, wey, wez):
    """Hu (3-97): α̇ = θ̇x cos θy + ω_ex cos θy + ω_ey sin θx sin θy − ω_ez cos θx sin θy,
    β̇ = θ̇y + ω_ey cos θx + ω_ez sin θx (ω_e components in the table base frame OXYZ)."""
    cx, sx, cy, sy = np.cos(tx), np.sin(tx), np.cos(ty), np.sin(ty)
    alpha = rx * cy + wex * cy + wey * sx * sy - wez * cx * sy
    beta = ry + wey * cx + wez * sx
    return alpha, beta


def test_two_axis_servo_matrix_3_96():
    ex, ey = np.eye(3)[:2]
    for tx, ty in _rng.uniform(-7, 7, size=(50, 2)):
        a = hu_3_96_product(tx, ty)
        np.testing.assert_allclose(hu_3_96_expanded(tx, ty), a, rtol=0, atol=TOL)
        c = np.asarray(kinematics.platform_attitude(jnp.asarray([ex, ey]), jnp.array([tx, ty])))
        np.testing.assert_allclose(c.T, a, rtol=0, atol=TOL)


@pytest.mark.parametrize("phi", LATITUDES)
def test_two_axis_servo_rates_3_97_any_orientation(phi):
    n = THETAS.size
    angles = _rng.uniform(-7, 7, size=(n, 2))
    rates = _rng.normal(0, 20 * W_E, size=(n, 2))
    omega = W_E * polar(phi)
    for base in Rotation.random(6, random_state=7).as_matrix():
        x_axis, y_axis, z_axis = base.T  # OX, OY, OZ in L
        w, _ = gyrojax_inputs([x_axis, y_axis], np.array([x_axis, y_axis, z_axis]), phi, angles, rates)
        alpha, beta = hu_3_97(*angles.T, *rates.T, omega @ x_axis, omega @ y_axis, omega @ z_axis)
        assert_rate(w[:, 0], alpha)
        assert_rate(w[:, 1], beta)


@pytest.mark.parametrize("phi", LATITUDES)
def test_two_axis_servo_example_3_98_to_3_101(phi):
    """Fig. 3-37: "转台外环轴 OX 指东且在水平面内, 内环轴 OY 在当地地垂线方向, 则 Z 在水平面内指南"."""
    x_axis, y_axis = E, U
    triad = triad_of(x_axis, y_axis)
    np.testing.assert_allclose(triad[2], S, atol=TOL)
    omega = W_E * polar(phi)
    # (3-98): ω_ex = 0, ω_ey = ω_e sin φ, ω_ez = −ω_e cos φ
    assert_rate(triad @ omega, [0.0, W_E * np.sin(phi), -W_E * np.cos(phi)])
    n = THETAS.size
    tx, ty = _rng.uniform(-7, 7, size=(2, n))
    rx, ry = _rng.normal(0, 20 * W_E, size=(2, n))
    w, a = gyrojax_inputs([x_axis, y_axis], triad, phi, np.stack([tx, ty], -1), np.stack([rx, ry], -1))
    # (3-99)
    cp, sp = np.cos(phi), np.sin(phi)
    assert_rate(w[:, 0], rx * np.cos(ty) + W_E * sp * np.sin(tx) * np.sin(ty) + W_E * cp * np.cos(tx) * np.sin(ty))
    assert_rate(w[:, 1], ry + W_E * sp * np.cos(tx) - W_E * cp * np.sin(tx))
    # (3-100) at zero angles and (3-101)
    _, a0 = gyrojax_inputs([x_axis, y_axis], triad, phi, np.zeros((1, 2)))
    assert_gravity(a0[0], [0.0, -G_SITE, 0.0])
    g = G_SITE
    g101 = np.stack([-g * np.sin(tx) * np.sin(ty), -g * np.cos(tx), g * np.sin(tx) * np.cos(ty)], -1)
    assert_gravity(a, g101)


# ---- Appendix 2: the twelve two-axis mountings --------------------------------------------------------------


def _appendix2(phi):
    """Appendix 2 as printed: {case: (X direction, Y direction, labelled H line, α̇(…), β̇(…))}.

    α̇, β̇ take (θx, θy, θ̇x, θ̇y) and return rad/s; ω = ω_e. ζ = local vertical (up), I = E × ω_e.
    """
    w, cp, sp = W_E, np.cos(phi), np.sin(phi)
    p, i_ = polar(phi), meridian_i(phi)
    c, s = np.cos, np.sin
    return {
        1: (
            E,
            N,
            U,
            lambda x, y, rx, ry: rx * c(y) + w * cp * s(x) * s(y) - w * sp * c(x) * s(y),
            lambda x, y, rx, ry: ry + w * cp * c(x) + w * sp * s(x),
        ),
        2: (
            E,
            U,
            N,
            lambda x, y, rx, ry: rx * c(y) + w * sp * s(x) * s(y) + w * cp * c(x) * s(y),
            lambda x, y, rx, ry: ry + w * sp * c(x) - w * cp * s(x),
        ),
        3: (
            N,
            E,
            U,
            lambda x, y, rx, ry: rx * c(y) + w * sp * c(x) * s(y) + w * cp * c(x),  # printed
            lambda x, y, rx, ry: ry - w * sp * s(x),
        ),
        4: (
            N,
            U,
            E,
            lambda x, y, rx, ry: rx * c(y) + w * cp * c(y) + w * sp * s(x) * s(y),
            lambda x, y, rx, ry: ry + w * sp * c(x),
        ),
        5: (E, p, i_, lambda x, y, rx, ry: rx * c(y) + w * s(x) * s(y), lambda x, y, rx, ry: ry + w * c(x)),
        6: (E, i_, p, lambda x, y, rx, ry: rx * c(y) + w * c(x) * s(y), lambda x, y, rx, ry: ry - w * s(x)),
        7: (
            U,
            N,
            E,
            lambda x, y, rx, ry: rx * c(y) + w * sp * c(y) + w * cp * s(x) * s(y),
            lambda x, y, rx, ry: ry + w * cp * c(x),
        ),
        8: (
            U,
            E,
            N,
            lambda x, y, rx, ry: rx * c(y) + w * sp * c(y) - w * cp * c(x) * s(y),
            lambda x, y, rx, ry: ry + w * cp * s(x),
        ),
        9: (p, E, i_, lambda x, y, rx, ry: rx * c(y) + w * c(y), lambda x, y, rx, ry: ry + 0 * x),
        10: (p, i_, E, lambda x, y, rx, ry: rx * c(y) + w * c(y), lambda x, y, rx, ry: ry + 0 * x),
        11: (i_, E, p, lambda x, y, rx, ry: rx * c(y) - w * c(x) * s(y), lambda x, y, rx, ry: ry + w * s(x)),
        12: (i_, p, E, lambda x, y, rx, ry: rx * c(y) + w * s(x) * s(y), lambda x, y, rx, ry: ry + w * c(x)),
    }


def _appendix2_samples():
    n = THETAS.size
    angles = _rng.uniform(-7, 7, size=(n, 2))
    rates = _rng.normal(0, 20 * W_E, size=(n, 2))
    return angles, rates


def independent_alpha_beta(x_axis, y_axis, phi, angles, rates):
    """Rates about the gyro's x and y, derived without gyrojax: scipy rotations for the two gimbals, the outer
    rate about the fixed X, the inner rate about the carried Y (Hu's 3-94 axes), Earth rate added in L."""
    omega = W_E * polar(phi)
    out = []
    for (tx, ty), (rx, ry) in zip(angles, rates, strict=True):
        r_outer = Rotation.from_rotvec(tx * x_axis).as_matrix()
        r = r_outer @ Rotation.from_rotvec(ty * y_axis).as_matrix()
        w_inertial = omega + rx * x_axis + ry * (r_outer @ y_axis)
        out.append([w_inertial @ (r @ x_axis), w_inertial @ (r @ y_axis)])
    return np.array(out).T


@pytest.mark.parametrize("phi", LATITUDES)
@pytest.mark.parametrize("case", range(1, 13))
def test_appendix2_twelve_mountings(case, phi):
    x_axis, y_axis, _, alpha_book, beta_book = _appendix2(phi)[case]
    angles, rates = _appendix2_samples()
    w, _ = gyrojax_inputs([x_axis, y_axis], triad_of(x_axis, y_axis), phi, angles, rates)
    args = (*angles.T, *rates.T)
    assert_rate(w[:, 1], beta_book(*args))
    if case == 3:
        # misprint in Hu appendix 2, mounting 3 (X→N, Y→E): the printed α̇ term "ω_e cos φ cos θ_x" should read
        # "ω_e cos φ cos θ_y". Geometry (gyrojax and an independent scipy derivation) and Hu's own 3-97 with
        # ω_eX = ω_e cos φ agree on cos θ_y; the printed form is off by exactly ω_e cos φ (cos θ_x − cos θ_y).
        tx, ty = angles.T
        alpha_geom, _ = independent_alpha_beta(x_axis, y_axis, phi, angles, rates)
        alpha_97, _ = hu_3_97(tx, ty, *rates.T, W_E * np.cos(phi), 0.0, -W_E * np.sin(phi))
        assert_rate(alpha_geom, alpha_97)
        assert_rate(w[:, 0], alpha_geom)
        printed = alpha_book(*args)
        assert_rate(printed - alpha_geom, W_E * np.cos(phi) * (np.cos(tx) - np.cos(ty)))
        assert np.max(np.abs(printed - alpha_geom)) > 0.5 * W_E * np.cos(phi)
    else:
        assert_rate(w[:, 0], alpha_book(*args))


@pytest.mark.parametrize("phi", LATITUDES)
def test_appendix2_matches_independent_derivation(phi):
    """gyrojax against a derivation that shares no code with it, for all twelve mountings."""
    angles, rates = _appendix2_samples()
    for x_axis, y_axis, *_ in _appendix2(phi).values():
        w, _ = gyrojax_inputs([x_axis, y_axis], triad_of(x_axis, y_axis), phi, angles, rates)
        alpha, beta = independent_alpha_beta(x_axis, y_axis, phi, angles, rates)
        assert_rate(w[:, 0], alpha)
        assert_rate(w[:, 1], beta)


def test_appendix2_spin_labels_name_the_line_only():
    """OXYZ is right-handed ("OZ 与 OX、OY 构成右手坐标系") with H along OZ, and the printed formulas follow
    Z = X × Y. The parenthesised H label lies on that line in every mounting, but points the other way in
    mountings 2, 3, 6, 7, 9 and 12 — a labelling slip (or an unsigned label), not a formula error."""
    phi = LATITUDES[0]
    opposite = set()
    for case, (x_axis, y_axis, h_label, *_) in _appendix2(phi).items():
        cos_zh = np.cross(x_axis, y_axis) @ h_label
        assert abs(abs(cos_zh) - 1.0) < TOL, case
        if cos_zh < 0:
            opposite.add(case)
    assert opposite == {2, 3, 6, 7, 9, 12}


# ---- the record path ----------------------------------------------------------------------------------------


def test_record_path_reproduces_3_13():
    """The same 3-13 tumble written as a record (deg, deg/s) and read through ``model.instrument_inputs``."""
    phi = LATITUDES[0]
    axes, triad = tumble_sdf_mounting("3-13", phi)
    t = np.arange(THETAS.size, dtype=float)
    meta = {
        "format": record.FORMAT,
        "name": "hu-3-13",
        "site": {"latitude_deg": float(np.rad2deg(phi)), "gravity_mps2": G_SITE},
        "table": {"axes": [{"name": "polar", "axis_enu": axes[0].tolist()}]},
        "instrument": {"kind": "sdf-gyro", "ia": triad[0].tolist(), "oa": triad[1].tolist(), "sa": triad[2].tolist()},
        "mode": "rebalance",
        "scale_factor_deg_per_h_per_mA": 1.0,
        "servo_axis": None,
    }
    cols = {
        "time_s": t,
        "angle_polar_deg": np.rad2deg(THETAS),
        "rate_polar_dps": np.full(t.shape, np.rad2deg(10 * W_E)),
        "current_mA": np.zeros_like(t),
    }
    data = record_data(Record(meta, cols))
    x = model.instrument_inputs(data, {"delta": jnp.zeros(3), "encoder": jnp.zeros(4)})
    a = np.stack([np.asarray(x[k]) for k in ("a_I", "a_O", "a_S")], -1)
    assert_gravity(a, hu_3_13(THETAS, phi, G_SITE))
    assert_rate(np.asarray(x["w_I"]) * units.DEG_PER_H, 0.0)
    assert_rate(np.asarray(x["w_O"]) * units.DEG_PER_H, -9 * W_E)
