"""Numerical edge cases of the fit: rank-deficient and near-singular plans, very large rates with very small
drifts, noise-free data, a single sample, constant and unexcited regressors, NaN smuggled past the loader.

References are closed-form facts, not the code's own output: a_I² + a_O² + a_S² = 1 in any static test (so D_F,
D_II, D_OO, D_SS alias, as the identify module doc says); a fixed position with OA horizontal has a_O = 0 (D_O
unexcited); float64 resolves a value v to ulp(v) = 2^(⌊log2 v⌋ − 52).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyrojax.data import plans
from gyrojax.data.record import Record
from gyrojax.errors import GyrojaxError
from gyrojax.inference.identifiability import IdentifiabilityError
from gyrojax.inference.identify import fit
from gyrojax.simulation.simulator import simulate

LADDER_TRUTH = {"D_F": 1e-5, "E_SF": 150.0, "M_O": 120.0, "M_S": -80.0}


@pytest.fixture(scope="module")
def eight():
    """Hu's eight positions, 2 min each at 1 s, with known drift terms and white noise."""
    truth = {"coefficients": {"D_F": 0.5, "D_I": 0.3, "D_O": -0.2, "D_S": 0.1, "D_II": 0.05}, "noise": {"white": 0.002}}
    return simulate(plans.eight_position(minutes=2.0), truth, seed=11)


@pytest.fixture(scope="module")
def fixed_noisy():
    return simulate(plans.fixed_position(hours=0.01), {"coefficients": {"D_F": 0.1}, "noise": {"white": 0.01}}, seed=2)


@pytest.fixture(scope="module")
def fixed_clean():
    return simulate(plans.fixed_position(hours=0.01), {"coefficients": {"D_F": 0.1}})


# ---- rank-deficient and near-singular plans -----------------------------------------------------------------------


def test_static_plan_aliases_bias_with_squared_terms(eight):
    terms = ["D_F", "D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS"]
    with pytest.raises(IdentifiabilityError) as info:
        fit(eight, terms, noise="white")
    groups = info.value.report["aliases"]
    assert any({"D_F", "D_II", "D_OO", "D_SS"} <= set(g) for g in groups), groups
    msg = str(info.value)
    for name in ("D_F", "D_II", "D_OO", "D_SS"):
        assert name in msg


def test_allow_aliases_keeps_identifiable_coefficients_finite(eight):
    terms = ["D_F", "D_I", "D_O", "D_S", "D_II", "D_OO", "D_SS"]
    res = fit(eight, terms, noise="white", allow_aliases=True)
    v, s = res.values, res.stds
    assert all(math.isfinite(v[c]) for c in terms), v  # minimum-norm values, never NaN
    # Hu's positions put the SA up (a_S = 1) or level (a_S = 0), so a_S² = a_S and D_S joins the aliased group
    assert any({"D_F", "D_S", "D_II", "D_OO", "D_SS"} == set(g) for g in res.identifiability["aliases"])
    for c, true in (("D_I", 0.3), ("D_O", -0.2)):
        assert math.isfinite(s[c]) and s[c] > 0
        assert abs(v[c] - true) < 5 * s[c] + 1e-9, (c, v[c], s[c])
    # the aliased group has no finite standard error, and says so by NaN (not by a huge finite number)
    assert all(math.isnan(s[c]) for c in ("D_F", "D_S", "D_II", "D_OO", "D_SS"))
    j = res.to_json()
    assert j["coefficients"]["D_I"]["std"] is not None and j["coefficients"]["D_F"]["std"] is None


def test_near_singular_plan_is_refused():
    """Two positions 1e-7 deg apart: D_F and D_I differ by a regressor change of ~1e-9; that is no separation."""
    plan = plans.multiposition(positions=[(0.0, 0.0), (1e-7, 0.0)], minutes=1.0)
    recs = simulate(plan, {"coefficients": {"D_F": 0.2}, "noise": {"white": 0.001}})
    with pytest.raises(IdentifiabilityError) as info:
        fit(recs, ["D_F", "D_I"], noise="white")
    assert "D_F" in str(info.value) and "D_I" in str(info.value)


def test_constant_regressor_aliases_bias(fixed_noisy):
    """At one position a_S = 1 (SA up) is a constant regressor: D_S is D_F, and the fit must say so."""
    with pytest.raises(IdentifiabilityError, match=r"\[D_F \+ D_S\]"):
        fit(fixed_noisy, ["D_F", "D_S"], noise="white")


def test_unexcited_regressor(fixed_noisy):
    """OA North, table level: a_O = 0 at every sample, so D_O is not excited."""
    with pytest.raises(IdentifiabilityError, match="not excited.*D_O"):
        fit(fixed_noisy, ["D_F", "D_O"], noise="white")
    res = fit(fixed_noisy, ["D_F", "D_O"], noise="white", allow_aliases=True)
    assert math.isfinite(res.values["D_F"]) and math.isfinite(res.stds["D_F"])
    assert abs(res.values["D_F"] - 0.1) < 5 * res.stds["D_F"]
    assert res.values["D_O"] == 0.0


# ---- large rates, small drifts ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ladder():
    return simulate(plans.rate_ladder(rates_dps=(1, 10, 100, 1000)), {"coefficients": LADDER_TRUTH})


def test_rate_ladder_to_1000_dps_noise_free_round_trip(ladder):
    """Rates to 1000 deg/s (3.6e6 deg/h) with D_F = 1e-5 deg/h, noise-free.

    E_SF, M_O and M_S come back to 1e-6 relative (measured: ~1e-14). D_F cannot: each sample's indicated rate is
    one float64 near 3.6e6 deg/h, whose resolution ulp = 4.7e-10 deg/h is 4.7e-5 of D_F, and the rounding is the
    same for every sample of a constant-rate step, so it averages only over the ~72 steps (measured error
    1.2e-11 deg/h = 1.2e-6 relative). The bound asserted for D_F is a quarter ulp of the largest indicated rate.
    """
    res = fit(ladder, ["D_F", "sf_error", "ia_misalignment"], noise="white")
    v = res.values
    for c in ("E_SF", "M_O", "M_S"):
        assert abs(v[c] / LADDER_TRUTH[c] - 1) < 1e-6, (c, v[c])
    y_max = max(float(np.max(np.abs(r.indicated))) for r in ladder)
    assert y_max > 3.5e6
    ulp = math.ulp(y_max)
    assert abs(v["D_F"] - LADDER_TRUTH["D_F"]) < ulp / 4, (v["D_F"], ulp)
    assert all(np.isfinite(res.std)) and np.all(res.std < 1e-6)


# ---- noise-free data, tiny records ---------------------------------------------------------------------------------


def test_noise_free_static_record_fits(fixed_clean):
    """Noise-free static data: the per-record noise scale is 0. (Before main's 103c5fc the 1e-300 floor made J/σ
    overflow and D_F was reported 'not excited'; this is the regression test.)"""
    res = fit(fixed_clean, ["D_F"], noise="white")
    assert abs(res.values["D_F"] - 0.1) < 1e-12
    assert np.all(np.isfinite(res.std))


def test_noise_free_static_record_fits_ar(fixed_clean):
    res = fit(fixed_clean, ["D_F"])
    assert abs(res.values["D_F"] - 0.1) < 1e-12 and np.all(np.isfinite(res.std))


def test_noise_free_fit_never_returns_nan(fixed_clean):
    """Whatever it decides, a noise-free fit must not hand back NaN estimates: a result or a gyrojax error."""
    try:
        res = fit(fixed_clean, ["D_F"], noise="white")
    except GyrojaxError:
        return
    assert np.all(np.isfinite(res.theta))


def _first(rec: Record, n: int) -> Record:
    return Record(rec.meta, {k: v[:n] for k, v in rec.columns.items()}, rec.path)


def test_single_sample_record_is_a_gyrojax_error_or_finite(fixed_noisy):
    one = _first(fixed_noisy[0], 1)
    try:
        res = fit([one], ["D_F"], noise="white")
    except GyrojaxError as e:
        assert "D_F" in str(e) or "sample" in str(e)
        return
    assert np.all(np.isfinite(res.theta))


def test_zero_degrees_of_freedom_is_not_certainty(fixed_noisy):
    try:
        res = fit([_first(fixed_noisy[0], 1)], ["D_F"], noise="white")
    except GyrojaxError:
        return
    assert not res.stds["D_F"] == 0.0, res.stds


def test_nan_in_memory_record_is_announced(fixed_noisy):
    rec = fixed_noisy[0]
    cur = rec.columns["current_mA"].copy()
    cur[5] = np.nan
    with pytest.raises(GyrojaxError, match="current_mA"):
        fit([rec.with_columns(current_mA=cur)], ["D_F"], noise="white")


def test_scaled_data_gives_scaled_estimates(fixed_noisy):
    """Linear WLS is equivariant: multiplying the current by 1e6 multiplies D_F and its std by 1e6 (no underflow
    or overflow in the column scaling either way)."""
    rec = fixed_noisy[0]
    base = fit([rec], ["D_F"], noise="white")
    for k in (1e-6, 1e6):
        big = rec.with_columns(current_mA=rec.columns["current_mA"] * k)
        # ω_I (Earth rate on the IA) is in the data and in the model; scale the drift part only
        ref = fit([big], ["D_F"], noise="white")
        assert np.isfinite(ref.values["D_F"]) and np.isfinite(ref.stds["D_F"]) and ref.stds["D_F"] > 0
        w_i = float(np.mean(rec.indicated)) - base.values["D_F"]  # the Earth-rate part of the output
        expected = (w_i + base.values["D_F"]) * k - w_i
        assert abs(ref.values["D_F"] - expected) <= 1e-9 * abs(expected) + 1e-12


# ---- no NaN out of the jitted model ---------------------------------------------------------------------------------


def test_every_sdf_effect_has_finite_regressors_from_rest_to_1000_dps():
    """Zero rate (|ω| and ω·|ω| terms have kinks there) and 1000 deg/s, all three ladder mountings, every SDF effect
    (including the nonlinear set-up ones): the Jacobian is finite."""
    import jax.numpy as jnp

    from gyrojax.data.arrays import record_data
    from gyrojax.physics import effects as fx
    from gyrojax.physics.model import Model, jacobian_jit, predict_jit

    recs = simulate(plans.rate_ladder(rates_dps=(0, 1000), seconds=2, dt_s=0.5), {"coefficients": {"D_F": 1e-5}})
    terms = tuple(n for n in fx.names() if fx.SDF in fx.get(n).kinds)
    assert {"sf_asymmetry", "sf_quadratic", "table_tilt", "encoder_harmonic"} <= set(terms)
    m = Model(terms)
    theta = jnp.zeros(m.size)
    for r in recs:
        d = record_data(r)
        assert np.all(np.isfinite(np.asarray(predict_jit(m, theta, d))))
        assert np.all(np.isfinite(np.asarray(jacobian_jit(m, theta, d)))), r.name


def test_servo_with_ia_perpendicular_to_the_servo_axis_is_announced():
    up, east, north = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    seg = plans.Segment((0.0,), 10.0, 1.0)
    run = plans.Run(
        "servo-ia-level", (("servo", up),), plans.sdf_mount(east, north), (seg,), mode="servo", servo_axis="servo"
    )
    try:
        (rec,) = simulate(plans.Plan("servo-bad", (run,)), {"coefficients": {"D_F": 0.1}})
    except GyrojaxError:
        return
    assert np.all(np.isfinite(rec.columns["angle_servo_deg"]))
