"""Seed 003: ψ-angle closed form (eq. 3), three-fix reset (eq. 10) and its rank deficiency, velocity-reference LS
(eqs. 11-17). Misprints in the seed, named where the test meets them:
  eq. 10: right-hand side printed (δl1, δl1, δl2, δl2, δl3, δl3) — should alternate δl, δL; the 5th unknown is
          printed "ε_e/ξ_ie" (read ω_ie); the last row prints "cos ω_ie(t3 − t)" (read t3 − t1).
  eq. 13: the 2×2 matrix is printed without its inverse and with "½Σ2γ2" (read ½Σ sin 2γ2).
  eq. 15: printed Δε_2x (read Δε_2z).
"""

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from gyrojax import units
from gyrojax.seeds import marine

W = units.OMEGA_IE
LAT = np.deg2rad(31.0)
DEG_H = units.DEG_PER_H


def test_c_ned_to_qep_is_a_rotation_with_polar_axis_along_earth_axis():
    c = np.asarray(marine.c_ned_to_qep(LAT))
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(c) == pytest.approx(1.0)
    earth_axis_ned = np.array([np.cos(LAT), 0.0, -np.sin(LAT)])  # ω_ie in NED
    np.testing.assert_allclose(c @ earth_axis_ned, [0, 0, 1], atol=1e-15)


@pytest.mark.parametrize("hours", [0.5, 6.0, 30.0])
def test_closed_form_matches_numerical_integration(hours):
    psi0 = np.array([2e-4, -1.5e-4, 3e-4])  # rad
    eps = np.array([0.01, -0.02, 0.005]) * DEG_H  # rad/s
    t_end = hours * 3600.0
    ts = np.linspace(0, t_end, 13)
    sol = solve_ivp(
        lambda t, y: [W * y[1] + eps[0], -W * y[0] + eps[1], eps[2]],
        (0, t_end),
        psi0,
        t_eval=ts,
        rtol=1e-13,
        atol=1e-16,
        method="DOP853",
    )
    closed = np.asarray(marine.psi_closed_form(psi0, eps, ts))
    np.testing.assert_allclose(closed, sol.y.T, rtol=1e-9, atol=1e-9 * np.abs(sol.y).max())
    # and the generic right-hand side of eq. 2 is the component form used above
    np.testing.assert_allclose(marine.psi_rhs(psi0, eps), [W * psi0[1] + eps[0], -W * psi0[0] + eps[1], eps[2]])


def _printed_matrix(lat, t1, t2, t3):
    """Eq. 10 typed from the seed (with the t3 − t misprint read as t3 − t1)."""
    tl = np.tan(lat)
    rows = [[tl, 0, -1, 0, 0, 0], [0, 1, 0, 0, 0, 0]]
    for t in (t2, t3):
        tau = W * (t - t1)
        c, s = np.cos(tau), np.sin(tau)
        rows.append([tl * c, tl * s, -1, tl * s, tl * (1 - c), -tau])
        rows.append([-s, c, 0, -1 + c, s, 0])
    return np.array(rows)


def test_fix_matrix_equals_printed_equation_10():
    times = np.array([1000.0, 5 * 3600.0, 11 * 3600.0])
    np.testing.assert_allclose(marine.fix_matrix(LAT, times), _printed_matrix(LAT, *times), atol=1e-13)


@pytest.mark.parametrize("times_h", [(0, 4, 9), (0, 1, 2, 8, 13, 20)])
def test_rank_deficiency_and_null_vector(times_h):
    times = np.asarray(times_h) * 3600.0
    a = marine.fix_matrix(LAT, times)
    rank, null = marine.rank_and_null_space(a)
    assert rank == 5  # six unknowns, any number of position fixes
    v = np.asarray(null[:, 0])
    v = v / v[0]
    # null vector: ψ_q = a, ψ_e = 0, ψ_p = a tan L, ε_q = 0, ε_e = ω_ie a, ε_p = 0 — east drift vs initial angles
    np.testing.assert_allclose(v, [1, 0, np.tan(LAT), 0, 1, 0], atol=1e-9)
    # A heading observation (azimuth row of eq. 4) separates them.
    full = np.vstack([np.asarray(a), np.asarray(marine.heading_row(LAT, 0.0))])
    assert marine.rank_and_null_space(full)[0] == 6


def test_null_direction_is_an_equilibrium_seen_only_in_azimuth():
    a = 1e-4
    psi0 = np.array([a, 0.0, a * np.tan(LAT)])
    eps = np.array([0.0, W * a, 0.0])
    ts = np.linspace(0, 48 * 3600, 7)
    psi = np.asarray(marine.psi_closed_form(psi0, eps, ts))
    np.testing.assert_allclose(psi, np.tile(psi0, (7, 1)), atol=1e-16)
    obs = psi @ np.asarray(marine.observation_matrix(LAT)).T
    np.testing.assert_allclose(obs[:, :2], 0.0, atol=1e-16)  # δl = δL = 0 at all times
    np.testing.assert_allclose(obs[:, 2], -a / np.cos(LAT))  # but the azimuth error is −a/cos L


def test_three_fix_solution_is_off_by_the_null_vector_only():
    times = np.array([0.0, 3.0, 7.0]) * 3600
    psi1 = np.array([1e-4, -2e-4, 5e-5])
    eps = np.array([0.004, 0.008, -0.003]) * DEG_H
    z = marine.fix_observations(LAT, times, psi1, eps)
    a = marine.fix_matrix(LAT, times)
    u, rank = marine.solve_fixes(a, z)
    assert rank == 5
    truth = np.concatenate([psi1, eps / W])
    diff = np.asarray(u) - truth
    nv = np.array([1, 0, np.tan(LAT), 0, 1, 0])
    k = diff @ nv / (nv @ nv)
    np.testing.assert_allclose(diff, k * nv, atol=1e-12)  # error lies wholly along the null vector
    assert abs(k) > 1e-6  # and the east drift is indeed not recovered
    # ε_q, ε_p and ψ_e are recovered
    np.testing.assert_allclose(np.asarray(u)[[1, 3, 5]], truth[[1, 3, 5]], rtol=1e-8)


def test_velocity_reference_recovers_constant_misalignment_exactly():
    t = 3600.0 + np.arange(0, 3600.0, 10.0)
    gamma = 2 * np.pi * t / 900.0 + 0.3
    psi0 = np.array([3e-5, -7e-5])
    dvn, _ = marine.velocity_errors(t, gamma, psi0, (0.0, 0.0), 0.0, LAT)
    np.testing.assert_allclose(marine.velocity_reference_misalignment(dvn, gamma), psi0, rtol=1e-10)


def test_velocity_reference_recovers_simulated_drifts():
    t1, t2 = 4 * 3600.0, 8 * 3600.0
    t = np.arange(t1, t2 + 1, 5.0)
    gamma = 2 * np.pi * t / 600.0
    d1 = np.array([0.010, -0.007]) * DEG_H
    d2z = 0.005 * DEG_H
    dvn, dve = marine.velocity_errors(t, gamma, (0.0, 0.0), d1, d2z, LAT)
    psi_bar = marine.velocity_reference_misalignment(dvn, gamma)  # eq. 13
    est1 = np.asarray(marine.drift_from_apparent_misalignment(psi_bar, t1, t2))  # eq. 14
    # eq. 14 takes the LS constant of a ramp Δε·t to be its window mean: true to ~0.3 % for 24 turns of γ2
    np.testing.assert_allclose(est1, d1, rtol=5e-3)
    est2 = float(marine.polar_drift_from_east_velocity(dve, gamma, psi_bar, LAT))  # eq. 15
    assert est2 == pytest.approx(d2z, rel=1e-2)


def test_velocity_reference_with_noise_monte_carlo():
    # Doppler-log noise 0.05 m/s: the LS estimate of eq. 13 is unbiased with covariance σ²(AᵀA)⁻¹/(Rω)².
    rng = np.random.default_rng(0)
    t = np.arange(0, 7200.0, 10.0)
    gamma = 2 * np.pi * t / 1000.0
    psi0 = np.array([1e-4, 2e-4])
    dvn0, _ = marine.velocity_errors(t, gamma, psi0, (0.0, 0.0), 0.0, LAT)
    noise = rng.normal(0, 0.05, (300, t.size))
    est = np.asarray(jax.vmap(lambda e: marine.velocity_reference_misalignment(dvn0 + e, gamma))(noise))
    a = np.column_stack([np.cos(gamma), np.sin(gamma)])
    cov = 0.05**2 * np.linalg.inv(a.T @ a) / (marine.EARTH_RADIUS_M * W) ** 2
    assert np.all(np.abs(est.mean(0) - psi0) < 4 * np.sqrt(np.diag(cov) / 300))
    np.testing.assert_allclose(est.std(0), np.sqrt(np.diag(cov)), rtol=0.15)


@pytest.mark.parametrize("gamma_c", [0.2, 1.3, 2.5])
def test_position_fix_corrections_invert_equation_16(gamma_c):
    t_c, e1, e2z = 5 * 3600.0, 0.003 * DEG_H, -0.002 * DEG_H
    c, s = np.cos(gamma_c), np.sin(gamma_c)
    # eq. 16 with δΨ̃_x = δΨ̃_y = Δε̃_1 t_c
    d_lat = -e1 * t_c * s + e1 * t_c * c
    d_lon = np.tan(LAT) * (e1 * t_c * c + e1 * t_c * s) - e2z * t_c
    got1, got2 = marine.position_fix_corrections(d_lat, d_lon, gamma_c, t_c, LAT)
    assert float(got1) == pytest.approx(e1, rel=1e-10)
    assert float(got2) == pytest.approx(e2z, rel=1e-9)


@settings(max_examples=25, deadline=None)
@given(
    lat_deg=st.floats(-70, 70),
    gaps_h=st.lists(st.floats(0.2, 30.0), min_size=2, max_size=5),
)
def test_rank_five_for_any_latitude_and_fix_times(lat_deg, gaps_h):
    lat = np.deg2rad(lat_deg)
    times = np.concatenate([[0.0], np.cumsum(gaps_h)]) * 3600
    rank, null = marine.rank_and_null_space(marine.fix_matrix(lat, times), rtol=1e-9)
    assert rank == 5
    v = np.asarray(null[:, 0])
    nv = np.array([1, 0, np.tan(lat), 0, 1, 0]) / np.sqrt(2 + np.tan(lat) ** 2)
    assert abs(abs(v @ nv) - 1) < 1e-8
