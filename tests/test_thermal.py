"""Seed 001 (Peng & Zhu 2009): two-slope temperature model hinged at 20 °C, built from room-before, hot, cold and
room-after runs (001 l.75-132), compensation, and navigation error with and without it (001 l.136).

Misprints in the seed met here: l.122 prints k_ax,b as the leading term of R_x04 (the after-run: read k_ax,a);
K_tex1 prints k_ax,b (read k_ax,h); the minus signs of S_x01/S_x04 are lost at l.94-99 (restored from l.75-81).
"""

import numpy as np
import pytest

from gyrojax import simulate, units
from gyrojax.data import plans
from gyrojax.seeds import system, thermal


def _paper_s0(k_room, t_room, k_h, t_h, k_d, t_d):
    """001 l.75-81 typed from the seed (t = sensor temperature − 20 °C)."""
    if t_room >= 0:
        return k_room - (k_h - k_room) * t_room / (t_h - t_room)
    return k_room - (k_d - k_room) * t_room / (t_d - t_room)


TRUTH = thermal.TwoSlope(e=0.50, k_hot=0.012, k_cold=-0.021)  # deg/h and deg/h/°C
TAUS = {"b": 3.0, "h": 40.0, "d": -65.0, "a": -2.0}


def _runs(offsets=None):
    offsets = offsets or {}
    return {s: float(TRUTH(20.0 + t)) + offsets.get(s, 0.0) for s, t in TAUS.items()}


def test_two_slope_model_shape():
    temps = np.array([-45.0, 0.0, 20.0, 35.0, 60.0])
    got = np.asarray(TRUTH(temps))
    np.testing.assert_allclose(got, [0.5 - 0.021 * -65, 0.5 - 0.021 * -20, 0.5, 0.5 + 0.012 * 15, 0.5 + 0.012 * 40])


def test_noise_free_runs_recover_the_model_exactly():
    k = _runs()
    e, k1, k2, hyst = thermal.two_slope_from_runs(
        k["b"], TAUS["b"], k["h"], TAUS["h"], k["d"], TAUS["d"], k["a"], TAUS["a"]
    )
    assert float(e) == pytest.approx(TRUTH.e, rel=1e-13)
    assert float(k1) == pytest.approx(TRUTH.k_hot, rel=1e-12)
    assert float(k2) == pytest.approx(TRUTH.k_cold, rel=1e-12)
    assert abs(float(hyst)) < 1e-14


@pytest.mark.parametrize("t_room", [4.0, -3.0, 0.0])
def test_extrapolation_matches_paper_formula(t_room):
    k_room, k_h, k_d = 0.61, 0.93, 1.85
    got = float(thermal.extrapolate_to_reference(k_room, t_room, k_h, 40.0, k_d, -65.0))
    assert got == pytest.approx(_paper_s0(k_room, t_room, k_h, 40.0, k_d, -65.0), rel=1e-14)


def test_turn_on_offset_of_after_run_shows_as_hysteresis():
    # An offset δ on the after-run (τ_a < 0, cold branch) moves S_04 by δ·τ_d/(τ_d − τ_a) (derived by hand from
    # l.75-81), so e moves by half of it and S_01 − S_04 = −δ·τ_d/(τ_d − τ_a).
    delta = 0.03
    k = _runs({"a": delta})
    e, _, _, hyst = thermal.two_slope_from_runs(
        k["b"], TAUS["b"], k["h"], TAUS["h"], k["d"], TAUS["d"], k["a"], TAUS["a"]
    )
    shift = delta * TAUS["d"] / (TAUS["d"] - TAUS["a"])
    assert float(hyst) == pytest.approx(-shift, rel=1e-12)
    assert float(e) == pytest.approx(TRUTH.e + shift / 2, rel=1e-12)


def test_compensation_recovers_true_rate():
    rng = np.random.default_rng(0)
    temp = np.linspace(-40.0, 55.0, 500)
    w = rng.uniform(-300, 300, 500) * 3600  # deg/h
    sf = thermal.TwoSlope(e=120e-6, k_hot=2e-6, k_cold=-3e-6)
    indicated = (1 + np.asarray(sf(temp))) * w + np.asarray(TRUTH(temp))
    np.testing.assert_allclose(thermal.compensate_rate(indicated, temp, TRUTH, sf), w, rtol=1e-13, atol=1e-9)
    # bias-only compensation leaves exactly the scale-factor error
    resid = np.asarray(thermal.compensate_rate(indicated, temp, TRUTH)) - w
    np.testing.assert_allclose(resid, np.asarray(sf(temp)) * w, rtol=1e-9)


def test_binned_values_jump_where_continuous_model_does_not():
    # 001 l.134: per-temperature-point coefficients make the compensated output jump at bin boundaries.
    cal_t = [20.0 + t for t in TAUS.values()]
    binned = thermal.binned_model(cal_t, [float(TRUTH(t)) for t in cal_t])
    temp = np.linspace(-45.0, 60.0, 2101)  # a slow chamber sweep, 0.05 °C per sample
    w = 36000.0
    ind = w + np.asarray(TRUTH(temp))
    resid_binned = np.asarray(thermal.compensate_rate(ind, temp, binned)) - w
    resid_model = np.asarray(thermal.compensate_rate(ind, temp, TRUTH)) - w
    assert np.abs(resid_model).max() < 1e-9
    steps = np.abs(np.diff(resid_binned))
    # three boundaries between the four calibration points (−45, 18, 23, 60 °C); each jump is the model's change
    # between neighbouring points (± one sample's drift of the truth, ≤ 0.021 × 0.05):
    # |k(23) − k(18)| = |0.012·3 − 0.021·2|, |k(60) − k(23)| = 0.012·37, |k(18) − k(−45)| = 0.021·63
    big = np.sort(steps[steps > 0.003])
    np.testing.assert_allclose(big, [0.042 - 0.036, 0.012 * 37, 0.021 * 63], atol=1.1e-3)


def test_navigation_error_with_and_without_compensation():
    # Spec-sheet scale (001 Tables 1-2): accelerometer K_0 temperature coefficient ≤ 1e-5 g/°C; FOG bias 0.1 °/h
    # class. Run at −45 °C (low end of the −45…60 °C range) for 90 s at 100 Hz, as in 001 l.136.
    accel = thermal.TwoSlope(e=2e-4, k_hot=0.8e-5, k_cold=1e-5)  # g
    gyro = thermal.TwoSlope(e=0.3, k_hot=0.004, k_cold=-0.006)  # deg/h
    dt, n = 0.01, 9000
    temp = np.full(n, -45.0)
    unc = np.asarray(thermal.navigation_position_error(dt, temp, gyro, accel))
    # uncompensated: residuals −65e-5 g and +0.39 °/h (the 20 °C values removed) through the Schuler loop
    # (Titterton Table 12.3)
    # (Titterton Table 12.3: accelerometer bias B → B (1 − cos ω_s t)/ω_s², horizontal gyro drift δω →
    # R_0 δω (t − sin ω_s t / ω_s); ω_s = √(g0/R_0), R_0 the WGS-84 equatorial radius)
    t = np.arange(n + 1) * dt
    r0, g0 = 6378137.0, 9.80665
    ws = np.sqrt(g0 / r0)
    accel_part = -65e-5 * g0 * (1 - np.cos(ws * t)) / ws**2
    gyro_part = r0 * 0.39 * np.pi / 180 / 3600 * (t - np.sin(ws * t) / ws)
    expected = accel_part + gyro_part
    np.testing.assert_allclose(unc, expected, rtol=1e-8, atol=1e-9)  # closed form t − sin(ω_s t)/ω_s cancels at t→0
    # compensated with a model fitted from runs that carry 2e-5 g / 0.02 °/h turn-on offsets
    fits = []
    for model, off in ((accel, 2e-5), (gyro, 0.02)):
        k = {s: float(model(20.0 + t)) for s, t in TAUS.items()}
        k["a"] += off
        e, k1, k2, _ = thermal.two_slope_from_runs(
            k["b"], TAUS["b"], k["h"], TAUS["h"], k["d"], TAUS["d"], k["a"], TAUS["a"]
        )
        fits.append(thermal.TwoSlope(float(e), float(k1), float(k2)))
    comp = np.asarray(thermal.navigation_position_error(dt, temp, gyro, accel, gyro_model=fits[1], accel_model=fits[0]))
    i70 = 7000
    # short-time forms (Titterton Table 12.4): −½·65e-5 g·t² + g·0.39 °/h·t³/6 = −15.6 m + 1.1 m at 70 s
    short = -0.5 * 65e-5 * units.G0 * 70.0**2 + units.G0 * 0.39 * units.DEG_PER_H * 70.0**3 / 6
    assert unc[i70] == pytest.approx(short, rel=1e-3)
    assert abs(comp[i70]) < 0.2 * abs(unc[i70])
    assert np.abs(comp).max() < np.abs(unc).max()


def test_paper_growth_ratio_lies_between_accel_and_gyro_laws():
    # 001 l.136: max(90 s)/value(70 s) = 181/98 uncompensated, 29.5/15.8 compensated. Bias-driven errors grow as
    # t² (accelerometer) to t³ (gyro) over 90 s (Titterton Table 12.4), bounding that ratio by (9/7)² … (9/7)³.
    s = system.position_sensitivities(np.array([70.0, 90.0]))
    lo = float(s[1, 2] / s[0, 2])
    hi = float(s[1, 0] / s[0, 0])
    for r in (181 / 98, 29.5 / 15.8):
        assert lo < r < hi


def test_full_temperature_plan_sequence_and_simulation():
    base = plans.fixed_position(hours=60 / 3600, dt_s=5.0)
    plan = thermal.full_temperature_plan(base, hot_c=60.0, cold_c=-45.0, room_c=(23.0, 18.0))
    assert [r.name for r in plan.runs] == ["fixed_b", "fixed_h", "fixed_d", "fixed_a"]
    assert [r.temperature_C for r in plan.runs] == [23.0, 60.0, -45.0, 18.0]
    recs = simulate(plan, {"coefficients": {"D_F": 0.5, "D_TEMP": 0.01}})
    means = [float(np.mean(r.indicated)) for r in recs]
    temps = [float(np.mean(r.temperature_C)) for r in recs]
    assert temps == pytest.approx([23.0, 60.0, -45.0, 18.0])
    # hot − cold difference of the indicated rate is D_TEMP·105 °C (conventions §6 bias_temperature)
    assert means[1] - means[2] == pytest.approx(0.01 * 105, rel=1e-9)
    ramp = thermal.full_temperature_plan(base, soak_ramp_c=5.0)
    assert ramp.runs[1].temperature_C == (60.0, 55.0) and ramp.runs[2].temperature_C == (-45.0, -40.0)
