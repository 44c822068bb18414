"""Optical gyros: Sagnac numbers of Titterton §5.1.3/§5.1.5, IEEE 952 model (5.16), RLG lock-in (Adler equation).

Misprint noted: Titterton 5.11 prints the beat frequency first as "4AΩ/(cL)"; it is Δν = ν·4AΩ/(cL) = 4AΩ/(λL).
"""

import dataclasses

import jax
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gyrojax import units
from gyrojax.data.arrays import record_data
from gyrojax.data.plans import rate_ladder
from gyrojax.physics import effects
from gyrojax.physics.model import Model, predict
from gyrojax.seeds import optical
from gyrojax.simulation.simulator import simulate

ARCSEC = units.ARCSEC


def test_rlg_pulse_angle_book_numbers():
    # Titterton L2441: 632.8 nm, 30 cm path → 2.25″ per pulse; 50 mm → 13.5″.
    assert float(optical.rlg_triangle_pulse_angle(0.30)) / ARCSEC == pytest.approx(2.25, abs=0.02)
    assert float(optical.rlg_triangle_pulse_angle(0.05)) / ARCSEC == pytest.approx(13.5, abs=0.1)
    # (5.13) with the equilateral-triangle area (5.14) gives (5.15)
    path = 0.3
    area = 0.5 * (path / 3) ** 2 * np.sin(np.pi / 3)
    assert float(optical.rlg_pulse_angle(area, path)) == pytest.approx(float(optical.rlg_triangle_pulse_angle(path)))


def test_fog_sagnac_phase_book_example():
    # Titterton L2585-2591: R = 40 mm, L = 100 m, λ = 850 nm: 15 °/h → 0.0008°, 500 °/s → 98.6°.
    p1 = np.rad2deg(float(optical.fog_sagnac_phase(15 * units.DEG_PER_H, 0.04, 100.0)))
    p2 = np.rad2deg(float(optical.fog_sagnac_phase(np.deg2rad(500.0), 0.04, 100.0)))
    assert p1 == pytest.approx(0.0008, abs=0.00005)
    assert p2 == pytest.approx(98.6, abs=0.1)


def test_ieee952_output_terms():
    w = np.array([100.0, -20.0, 5.0])
    out = optical.ieee952_output(*w, scale_error=100e-6, m_y=2e-4, m_z=-3e-4, bias=0.5)
    assert float(out) == pytest.approx(100 * 1.0001 + (-20) * 2e-4 + 5 * (-3e-4) + 0.5, rel=1e-15)


def test_lockin_closed_form_dead_band():
    wl = 100.0
    w = np.array([-300.0, -100.0, -50.0, 0.0, 30.0, 99.9, 100.0, 150.0, 1e4])
    out = np.asarray(optical.lockin_output(w, wl))
    expected = np.where(np.abs(w) > wl, np.sign(w) * np.sqrt(np.clip(w**2 - wl**2, 0, None)), 0.0)
    np.testing.assert_allclose(out, expected, rtol=1e-15)
    assert np.all(out[np.abs(w) <= wl] == 0.0)
    # far above the band the output approaches the input (Ω − Ω_L²/2Ω)
    assert out[-1] == pytest.approx(1e4 - wl**2 / 2e4, rel=1e-8)
    # gradient is finite everywhere (0 inside the band)
    g = jax.vmap(jax.grad(lambda x: optical.lockin_output(x, wl)))(np.array([0.0, 50.0, 200.0]))
    assert np.all(np.isfinite(g)) and float(g[0]) == 0.0 and float(g[2]) == pytest.approx(200 / np.sqrt(3e4))


@pytest.mark.parametrize("ratio", [0.5, 0.99, 1.01, 1.5, 4.0])
def test_lockin_against_numerical_adler_equation(ratio):
    # Mean beat rate of ψ̇ = Ω − Ω_L sin ψ integrated by scipy over whole periods vs the closed form.
    wl = 1.0
    w = ratio * wl
    t_end = 400.0
    sol = solve_ivp(
        lambda t, y: [w - wl * np.sin(y[0])],
        (0, t_end),
        [0.0],
        rtol=1e-11,
        atol=1e-12,
        method="DOP853",
        dense_output=True,
    )
    if ratio <= 1:
        # locked: ψ settles at arcsin(Ω/Ω_L), no output
        assert np.sin(sol.y[0, -1]) == pytest.approx(ratio, abs=1e-6)
        rate = (sol.y[0, -1] - sol.sol(t_end - 50)[0]) / 50
        assert abs(rate) < 1e-6
    else:
        period = 2 * np.pi / np.sqrt(w**2 - wl**2)
        k = int((t_end - 10) // period)
        rate = (sol.sol(10 + k * period)[0] - sol.sol(10.0)[0]) / (k * period)
        assert rate == pytest.approx(float(optical.lockin_output(w, wl)), rel=1e-7)
    # our lax.scan RK4 integrator agrees with scipy
    psi = np.asarray(optical.adler_phase(w, wl, 0.01, 40000))
    np.testing.assert_allclose(psi[-1], sol.sol(400.0)[0], rtol=1e-7, atol=1e-7)


def test_lock_in_effect_through_model_predict():
    # A rate ladder about Up with IA up: the "rlg" model must output sign(ω)√(ω² − Ω_L²) of the true input.
    assert "lock_in" in effects.names("rlg")
    plan = rate_ladder(rates_dps=(0.01, 0.05, 1.0), seconds=2.0, dt_s=1.0, mountings=("axial",))
    rec = simulate(plan, {"coefficients": {}})[0]
    data = dataclasses.replace(record_data(rec), kind=optical.RLG)
    omega_l = 0.03 * 3600  # deg/h (0.03 deg/s)
    model = Model(("lock_in",), kind=optical.RLG)
    y = np.asarray(predict(model, np.array([omega_l]), data))
    w_in = np.asarray(predict(Model((), kind=optical.RLG), np.zeros(0), data))  # ω_I alone
    expected = np.where(np.abs(w_in) > omega_l, np.sign(w_in) * np.sqrt(np.clip(w_in**2 - omega_l**2, 0, None)), 0)
    np.testing.assert_allclose(y, expected, rtol=1e-12, atol=1e-9)
    assert np.any(y == 0.0) and np.any(np.abs(y) > 0)
