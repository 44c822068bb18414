"""Comprehensive calibration (reset) of a marine INS: ψ-angle errors in the qep frame (seed 003).

**Frames** (003 eq. 1). qep: q equatorial (outward, in the meridian plane), e East, p polar (∥ Earth axis). It is
NED turned about E by 90° + L::

    C_NED^qep = [[−sin L, 0, −cos L], [0, 1, 0], [cos L, 0, −sin L]]

**ψ-angle error equation** (003 eq. 2) with the platform turning at Earth rate about p, ω_ip = (0, 0, ω_ie)::

    ψ̇ = −[ω_ip ×] ψ + ε   ⇔   ψ̇_q = ω_ie ψ_e + ε_q,  ψ̇_e = −ω_ie ψ_q + ε_e,  ψ̇_p = ε_p

and for constant drift ε, with Δ = t − t_0 (003 eq. 3)::

    ψ_q = ψ_q0 cos ω_ieΔ + ψ_e0 sin ω_ieΔ + (ε_q/ω_ie) sin ω_ieΔ + (ε_e/ω_ie)(1 − cos ω_ieΔ)
    ψ_e = −ψ_q0 sin ω_ieΔ + ψ_e0 cos ω_ieΔ − (ε_q/ω_ie)(1 − cos ω_ieΔ) + (ε_e/ω_ie) sin ω_ieΔ
    ψ_p = ψ_p0 + ε_p Δ

i.e. ψ(t) = Φ(Δ) ψ_0 + B(Δ) ε (003 eq. 7). **Observations** with height and level-velocity damping (003 eq. 4):
δl = tan L ψ_q − ψ_p (longitude), δL = ψ_e (latitude), φ_d = −ψ_q / cos L (azimuth).

**Three-fix reset** (003 eqs. 5–10). Position fixes (δl, δL) at t_1, t_2, t_3 give six equations in
u = (ψ_q, ψ_e, ψ_p at t_1, ε_q/ω_ie, ε_e/ω_ie, ε_p/ω_ie). The paper says the system is singular "because of the
east gyro drift" (003 l.34, truncated). :func:`fix_matrix` builds it for any number of fixes; its rank is 5 and its
null vector is u ∝ (1, 0, tan L, 0, 1, 0): an east drift ε_e = ω_ie a with ψ_q = a, ψ_p = a tan L is an
equilibrium of eq. 2 that leaves δl = δL = 0 for ever, so no number of position fixes can see it. It shows in the
azimuth φ_d = −a / cos L, so one heading reference (:func:`heading_row`) restores full rank. (Fixes spaced by
whole sidereal days lose more rank still: Φ returns to the identity there.)

**Velocity-reference scheme** for a space-stabilised INS (003 eqs. 11–17): velocity errors (eq. 11), least
squares for the apparent misalignment from δv_N (eqs. 12–13; the printed matrix lacks its inverse and a "sin"),
horizontal drifts from the window mean (eq. 14), the polar drift from δv_E (eq. 15; printed Δε_2x, read Δε_2z),
and corrections from one position fix at t_c (eqs. 16–17).

Units: SI (rad, rad/s, s, m). Position errors δl, δL in rad of longitude/latitude.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from gyrojax import units

EARTH_RADIUS_M = units.WGS84_A

__all__ = [
    "c_ned_to_qep",
    "drift_from_apparent_misalignment",
    "fix_matrix",
    "fix_observations",
    "heading_row",
    "observation_matrix",
    "polar_drift_from_east_velocity",
    "position_fix_corrections",
    "psi_closed_form",
    "psi_rhs",
    "rank_and_null_space",
    "solve_fixes",
    "transition",
    "velocity_errors",
    "velocity_reference_misalignment",
]


def c_ned_to_qep(lat):
    """Direction-cosine matrix NED → qep at latitude ``lat`` (rad), 003 eq. 1."""
    s, c = jnp.sin(lat), jnp.cos(lat)
    z = jnp.zeros_like(s)
    return jnp.array([[-s, z, -c], [z, z + 1.0, z], [c, z, -s]])


def psi_rhs(psi, eps, omega=units.OMEGA_IE):
    """ψ̇ = −[ω_ip×]ψ + ε with ω_ip = (0, 0, ω) in qep (003 eq. 2): ψ in rad, ε and ω in rad/s, ψ̇ in rad/s."""
    w = jnp.array([0.0, 0.0, omega])
    return -jnp.cross(w, psi) + eps


def transition(dt, omega=units.OMEGA_IE):
    """(Φ, B) with ψ(t_0 + Δ) = Φ ψ(t_0) + B ε for constant ε (003 eqs. 3 and 7).

    ``dt`` = Δ in s, ``omega`` in rad/s; Φ is dimensionless, B in s (ψ in rad, ε in rad/s).
    """
    c, s = jnp.cos(omega * dt), jnp.sin(omega * dt)
    z = jnp.zeros_like(c)
    phi = jnp.array([[c, s, z], [-s, c, z], [z, z, z + 1.0]])
    b = jnp.array([[s / omega, (1 - c) / omega, z], [-(1 - c) / omega, s / omega, z], [z, z, z + dt]])
    return phi, b


@jax.jit
def psi_closed_form(psi0, eps, dt, omega=units.OMEGA_IE):
    """ψ(t_0 + Δ) in rad from ψ(t_0) (rad) and constant drift ε (rad/s) (003 eq. 3); ``dt`` (s) may be an array."""
    psi0, eps = jnp.asarray(psi0, jnp.float64), jnp.asarray(eps, jnp.float64)

    def one(d):
        phi, b = transition(d, omega)
        return phi @ psi0 + b @ eps

    dt = jnp.asarray(dt, jnp.float64)
    return jax.vmap(one)(dt) if dt.ndim else one(dt)


def observation_matrix(lat):
    """Rows (δl, δL, φ_d) in terms of (ψ_q, ψ_e, ψ_p), 003 eq. 4; ``lat`` in rad, all angles in rad."""
    t, c = jnp.tan(lat), jnp.cos(lat)
    return jnp.array([[t, 0.0, -1.0], [0.0, 1.0, 0.0], [-1.0 / c, 0.0, 0.0]])


def _obs_rows(lat, dt, rows, omega):
    """Observation rows in u = (ψ(t_1), ε/ω) for a fix at t_1 + Δ."""
    phi, b = transition(dt, omega)
    h = observation_matrix(lat)[rows]
    return jnp.concatenate([h @ phi, h @ b * omega], axis=1)


@jax.jit
def fix_matrix(lat, times, omega=units.OMEGA_IE):
    """The 2m×6 matrix of m position fixes (δl, δL rows per fix), unknowns u = (ψ(t_1), ε/ω_ie) (003 eq. 10).

    ``times`` are the fix times (s), the first being t_1.
    """
    times = jnp.asarray(times, jnp.float64)
    blocks = jax.vmap(lambda t: _obs_rows(lat, t - times[0], jnp.array([0, 1]), omega))(times)
    return blocks.reshape(-1, 6)


@jax.jit
def heading_row(lat, dt, omega=units.OMEGA_IE):
    """The azimuth row φ_d at t_1 + Δ (003 eq. 4, third row) in the unknowns of :func:`fix_matrix`.

    ``lat`` in rad, ``dt`` = Δ in s, ``omega`` in rad/s.
    """
    return _obs_rows(lat, dt, jnp.array([2]), omega)


@jax.jit
def fix_observations(lat, times, psi1, eps, omega=units.OMEGA_IE):
    """Noise-free (δl, δL) in rad at each fix time, stacked like :func:`fix_matrix` rows (003 eqs. 4, 5, 7, 9).

    ``lat`` and ``psi1`` in rad, ``times`` in s, ``eps`` and ``omega`` in rad/s.
    """
    times = jnp.asarray(times, jnp.float64)
    psi = psi_closed_form(psi1, eps, times - times[0], omega)
    return (psi @ observation_matrix(lat)[:2].T).reshape(-1)


def rank_and_null_space(a, rtol=1e-10):
    """Numerical rank of ``a`` and an orthonormal basis of its null space (columns), by SVD."""
    a = jnp.asarray(a, jnp.float64)
    _, s, vt = jnp.linalg.svd(a)
    rank = int(jnp.sum(s > rtol * s[0]))
    return rank, vt[rank:].T


def solve_fixes(a, z):
    """Minimum-norm least-squares solution of a u = z, with the rank (a reset from fixes alone is rank 5)."""
    u, _, rank, _ = jnp.linalg.lstsq(jnp.asarray(a), jnp.asarray(z))
    return u, int(rank)


# ---- velocity-reference scheme (003 eqs. 11-17) -----------------------------------------------------------------


@jax.jit
def velocity_errors(t, gamma2, psi0, drift1, drift2z, lat, radius=EARTH_RADIUS_M, omega=units.OMEGA_IE):
    """(δv_N, δv_E) of a space-stabilised INS under velocity damping (003 eq. 11).

    Args:
      t: (n,) times (s). gamma2: (n,) rotation angle about −Z_p (rad).
      psi0: (Ψ_x(0), Ψ_y(0)) rad. drift1: (Δε_1x, Δε_1y) rad/s. drift2z: Δε_2z rad/s.
    """
    px = psi0[0] + drift1[0] * t
    py = psi0[1] + drift1[1] * t
    c, s = jnp.cos(gamma2), jnp.sin(gamma2)
    dvn = -radius * omega * (px * c + py * s)
    dve = radius * omega * jnp.sin(lat) * (-px * s + py * c) - radius * drift2z * jnp.cos(lat)
    return dvn, dve


@jax.jit
def velocity_reference_misalignment(dvn, gamma2, radius=EARTH_RADIUS_M, omega=units.OMEGA_IE):
    """Least-squares apparent misalignment (Ψ̄_x0, Ψ̄_y0) from δv_N samples (003 eqs. 12–13)::

    [Ψ̄_x0, Ψ̄_y0]ᵀ = [[Σcos²γ, ½Σsin2γ], [½Σsin2γ, Σsin²γ]]⁻¹ [−Σδv_N cosγ/(Rω), −Σδv_N sinγ/(Rω)]ᵀ

    ``dvn`` in m/s, ``gamma2`` in rad, ``radius`` in m, ``omega`` in rad/s; Ψ̄ in rad.
    """
    c, s = jnp.cos(gamma2), jnp.sin(gamma2)
    n = jnp.array(
        [[jnp.sum(c * c), 0.5 * jnp.sum(jnp.sin(2 * gamma2))], [0.5 * jnp.sum(jnp.sin(2 * gamma2)), jnp.sum(s * s)]]
    )
    rhs = -jnp.array([jnp.sum(dvn * c), jnp.sum(dvn * s)]) / (radius * omega)
    return jnp.linalg.solve(n, rhs)


def drift_from_apparent_misalignment(psi_bar, t1, t2):
    """Δε̂_1 = 2 Ψ̄ / (t_1 + t_2): the window mean of Δε·t over [t_1, t_2] is Δε (t_1 + t_2)/2 (003 eq. 14).

    Ψ̄ in rad, t_1 and t_2 in s; Δε̂_1 in rad/s.
    """
    return 2.0 * jnp.asarray(psi_bar) / (t1 + t2)


@jax.jit
def polar_drift_from_east_velocity(dve, gamma2, psi_bar, lat, radius=EARTH_RADIUS_M, omega=units.OMEGA_IE):
    """Δε̂_2z = −1/((n+1) R cos L) Σ[δv_E + Rω sin L (Ψ̄_x sinγ − Ψ̄_y cosγ)] (003 eq. 15).

    ``dve`` in m/s, ``gamma2``, ``psi_bar`` and ``lat`` in rad, ``radius`` in m, ``omega`` in rad/s; Δε̂_2z in rad/s.
    """
    corr = radius * omega * jnp.sin(lat) * (psi_bar[0] * jnp.sin(gamma2) - psi_bar[1] * jnp.cos(gamma2))
    return -jnp.mean(dve + corr) / (radius * jnp.cos(lat))


def position_fix_corrections(d_lat, d_lon, gamma_c, t_c, lat):
    """Drift corrections from one position fix at t_c (003 eq. 17, from eq. 16 with Δε̃_1x = Δε̃_1y)::

    Δε̃_1 = δL̃ / ((cos γ − sin γ) t_c)
    Δε̃_2z = [δL̃ tan L (1 + sin 2γ)/cos 2γ − δl̃] / t_c

    Singular at γ_2(t_c) = 45° (+k·180°), where the fix cannot see the common horizontal correction.
    ``d_lat``, ``d_lon``, ``gamma_c`` and ``lat`` in rad, ``t_c`` in s; corrections in rad/s.
    """
    c, s = jnp.cos(gamma_c), jnp.sin(gamma_c)
    e1 = d_lat / ((c - s) * t_c)
    e2z = (d_lat * jnp.tan(lat) * (1 + jnp.sin(2 * gamma_c)) / jnp.cos(2 * gamma_c) - d_lon) / t_c
    return e1, e2z
