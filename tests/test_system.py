"""Titterton ch. 12: Schuler loop (12.2-12.4), single-channel error propagation (Tables 12.3/12.4), rules of thumb.

Misprint noted: Table 12.4 prints the short-time vertical-gyro-bias entry (Ω cos L g δB_gD t⁴/24) without the minus
sign of its medium-time entry (−R_0 Ω cos L {t²/2 − (1 − cos ω_s t)/ω_s²} δB_gD); the series of the latter is
−Ω cos L g δB_gD t⁴/24 + O(t⁶), which the test below checks.
"""

import jax
import numpy as np
import pytest

from gyrojax import units
from gyrojax.seeds import system

LAT = np.deg2rad(45.0)


def test_schuler_frequency_and_period():
    assert float(system.schuler_frequency()) == pytest.approx(0.00124, abs=5e-6)  # Titterton 12.3
    assert float(system.schuler_period_min()) == pytest.approx(84.4, abs=0.1)  # Titterton 12.4


def _titterton(t, lat):
    """Table 12.3/12.4 medium-time entries, typed from the seed."""
    r0, g = system.R0, units.G0
    ws = np.sqrt(g / r0)
    a = units.OMEGA_IE * np.cos(lat)
    return {
        "gyro_h": r0 * (t - np.sin(ws * t) / ws),
        "gyro_d": -r0 * a * (t**2 / 2 - (1 - np.cos(ws * t)) / ws**2),
        "accel": (1 - np.cos(ws * t)) / ws**2,
        "tilt0": r0 * (1 - np.cos(ws * t)),
        "vel0": np.sin(ws * t) / ws,
    }


def test_closed_forms_are_titterton_tables():
    t = np.linspace(0, 6 * 3600, 50)
    s = np.asarray(system.position_sensitivities(t, lat=LAT))
    for i, name in enumerate(system.ERROR_SOURCES):
        np.testing.assert_allclose(s[:, i], _titterton(t, LAT)[name], rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("source", system.ERROR_SOURCES)
def test_loop_simulation_matches_titterton_closed_forms(source):
    dt, n = 10.0, 2160  # 6 h, several Schuler periods
    t = np.arange(n + 1) * dt
    size = {
        "gyro_h": 0.01 * units.DEG_PER_H,
        "gyro_d": 0.01 * units.DEG_PER_H,
        "accel": 1e-4 * units.G0,
        "tilt0": 1e-4,
        "vel0": 0.1,
    }[source]
    kw = {"gyro_h": np.zeros(n), "lat": LAT}
    if source == "gyro_h":
        kw["gyro_h"] = np.full(n, size)
    elif source == "gyro_d":
        kw["gyro_d"] = np.full(n, size)
    elif source == "accel":
        kw["accel"] = np.full(n, size)
    elif source == "tilt0":
        kw["x0"] = [0.0, size, 0.0, 0.0]
    else:
        kw["x0"] = [0.0, 0.0, size, 0.0]
    x = np.asarray(system.simulate_channel(dt, **kw))[:, 3]
    expected = _titterton(t, LAT)[source] * size
    # Tolerance from the numerics, not from one CPU: each step's Φ and Γ are exact to a few units of round-off u per
    # element (the exponential is taken in balanced units), and in a neutrally stable loop those errors add up at
    # most linearly over the n steps, so |x − x_exact| ≲ c·n·u·max|x| with c of order one (0.7 seen on one machine);
    # c = 32 leaves room for another expm/BLAS. An exponential accurate only in norm fails this by 10²–10⁴.
    tol = 32 * n * np.finfo(float).eps * np.abs(expected).max()
    np.testing.assert_allclose(x, expected, rtol=0, atol=tol)


def test_short_time_limits_table_12_4():
    t = np.array([30.0, 60.0, 120.0])
    med = np.asarray(system.position_sensitivities(t, lat=LAT))
    short = np.asarray(system.position_sensitivities(t, lat=LAT, schuler=False))
    ws2t2 = (np.sqrt(units.G0 / system.R0) * t) ** 2
    # leading corrections: gyro_h (1 − ω²t²/20), accel and tilt (1 − ω²t²/12), gyro_d (1 − ω²t²/30);
    # the next term is O((ω_s t)⁴)/840 or smaller: ≤ 6e-7 at 120 s
    np.testing.assert_allclose(med[:, 0] / short[:, 0], 1 - ws2t2 / 20, rtol=2e-6)
    np.testing.assert_allclose(med[:, 1] / short[:, 1], 1 - ws2t2 / 30, rtol=2e-6)
    np.testing.assert_allclose(med[:, 2] / short[:, 2], 1 - ws2t2 / 12, rtol=2e-6)
    np.testing.assert_allclose(med[:, 3] / short[:, 3], 1 - ws2t2 / 12, rtol=2e-6)
    # without Schuler feedback, the loop gives the 2-D inertial-frame growth g δω t³/6 (Titterton 12.1)
    x = np.asarray(system.simulate_channel(1.0, np.full(300, 1e-6), schuler=False))[:, 3]
    np.testing.assert_allclose(x[-1], units.G0 * 1e-6 * 300.0**3 / 6, rtol=1e-10)


def test_rule_of_thumb_one_km_per_hour():
    # Titterton §12.2.5: a 0.01 °/h gyro gives "about 1 km/h"; 0.6 n mile/h in §12.3.
    rate = float(system.drift_to_position_rate(0.01))
    assert rate == pytest.approx(1000, rel=0.15)
    assert rate / 1852.0 == pytest.approx(0.6, abs=0.01)
    # and the long-run slope of the loop's position error equals it (average over a Schuler period)
    ts = system.schuler_period_min() * 60
    s = system.position_sensitivities(np.array([2 * ts, 3 * ts]))[:, 0] * 0.01 * units.DEG_PER_H
    assert float((s[1] - s[0]) / ts * 3600) == pytest.approx(rate, rel=1e-9)


def test_coefficient_covariance_to_position_error_monte_carlo():
    # Residual uncertainty of (D_F, D_I, D_O) at an operating condition a = (0.3, 0.2, 0.93) g, mapped to position.
    rng = np.random.default_rng(5)
    jac = np.array([1.0, 0.3, 0.2])  # deg/h per (deg/h, deg/h/g, deg/h/g)
    cov = np.array([[4e-6, 1e-6, 0.0], [1e-6, 9e-6, -2e-6], [0.0, -2e-6, 1e-5]])
    t_end = 2 * 3600.0
    sigma = float(system.position_error_std(t_end, cov, jac, lat=LAT))
    expected = system.R0 * (t_end - np.sin(system.schuler_frequency() * t_end) / system.schuler_frequency())
    expected *= np.sqrt(jac @ cov @ jac) * units.DEG_PER_H
    assert sigma == pytest.approx(float(expected), rel=1e-12)
    coeffs = rng.multivariate_normal(np.zeros(3), cov, 4000)
    drift = coeffs @ jac * units.DEG_PER_H
    dt, n = 60.0, 120
    x_end = jax.vmap(lambda d: system.simulate_channel(dt, jnp_full(n, d), lat=LAT)[-1, 3])(drift)
    assert float(np.std(np.asarray(x_end))) == pytest.approx(sigma, rel=0.04)


def jnp_full(n, v):
    import jax.numpy as jnp

    return jnp.full(n, v)


@pytest.mark.parametrize("schuler, t_end", [(True, 4 * 3600.0), (False, 300.0)])
def test_arw_position_error_monte_carlo(schuler, t_end):
    # Angle random walk 0.05 °/√h: piecewise-constant white rate noise through the loop vs the closed form.
    rng = np.random.default_rng(7)
    n_steps, arw = 400, 0.05
    dt = t_end / n_steps
    sigma_rate = arw * units.DEG / 60.0 / np.sqrt(dt)  # rad/s per step
    noise = rng.normal(0, sigma_rate, (3000, n_steps))
    x_end = jax.vmap(lambda w: system.simulate_channel(dt, w, schuler=schuler)[-1, 3])(noise)
    sigma = float(system.position_error_std_arw(t_end, arw, schuler=schuler))
    assert float(np.std(np.asarray(x_end))) == pytest.approx(sigma, rel=0.05)  # 3000 draws: 1.3 % std error


def test_heading_errors():
    # Titterton 10.13 / L5090: "0.01 °/h of east-gyro bias gives 1 mrad of heading at 45° latitude".
    assert float(system.alignment_heading_error(0.01, np.deg2rad(45.0))) == pytest.approx(1e-3, rel=0.07)
    # free azimuth: γ = δω_D t, so 0.01 °/h for one hour is 0.01°
    assert float(system.heading_error(3600.0, 0.01)) == pytest.approx(np.deg2rad(0.01), rel=1e-12)
