"""Every built-in plan simulates (noise-free) to records that load back, whose indicated output equals the model
evaluated independently: scipy rotations and the conventions §4/§6 formulas written out in numpy here."""

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax import load_record, save_record, simulate, units
from gyrojax.data import plans
from gyrojax.data.planfile import load_plan, plan_to_json
from gyrojax.errors import PlanError

TRUTH = {
    "D_F": 0.42,
    "D_I": 0.61,
    "D_O": -0.17,
    "D_S": 0.3,
    "D_II": 0.02,
    "D_SS": -0.015,
    "D_IS": 0.052,
    "D_IO": -0.01,
    "D_OS": 0.007,
    "E_SF": 150.0,
    "M_O": 120.0,
    "M_S": -60.0,
}
TDF_TRUTH = {"DX_F": 0.3, "DX_X": 0.2, "DX_Z": -0.1, "DX_XZ": 0.02, "DY_F": -0.2, "DY_Y": 0.15, "DY_YZ": 0.01}
ACC_TRUTH = {"K_0": 1e-4, "K_1": 1.0002, "K_2": 2e-5, "K_3": -1e-5, "K_IP": 3e-5, "K_IO": -2e-5}


def _inputs(rec):
    lat = np.deg2rad(rec.latitude_deg)
    omega = units.OMEGA_IE * np.array([0, np.cos(lat), np.sin(lat)])
    f = np.array([0, 0, rec.gravity_mps2])
    ang, rat = np.deg2rad(rec.angles_deg), np.deg2rad(rec.rates_dps)
    w_out, a_out = [], []
    for th, rt in zip(ang, rat):
        c, w = np.eye(3), np.zeros(3)
        for u, t, r in zip(rec.axes_enu, th, rt):
            w = w + r * (c @ u)
            c = c @ Rotation.from_rotvec(u * t).as_matrix()
        w_out.append(rec.triad @ (c.T @ (omega + w)) / units.DEG_PER_H)
        a_out.append(rec.triad @ (c.T @ f) / units.G0)
    return np.array(w_out), np.array(a_out)


def _sdf_expected(rec):
    w, a = _inputs(rec)
    wi, wo, ws = w.T
    ai, ao, as_ = a.T
    t = TRUTH
    return (
        wi
        + t["D_F"]
        + t["D_I"] * ai
        + t["D_O"] * ao
        + t["D_S"] * as_
        + t["D_II"] * ai**2
        + t["D_SS"] * as_**2
        + t["D_IS"] * ai * as_
        + t["D_IO"] * ai * ao
        + t["D_OS"] * ao * as_
        + t["E_SF"] * 1e-6 * wi
        + (t["M_O"] * wo + t["M_S"] * ws) * units.ARCSEC
    )


SMALL = {
    "fixed": dict(hours=0.01, dt_s=2.0),
    "eight-position": dict(minutes=0.2, dt_s=2.0),
    "multiposition": dict(n=30, minutes=0.1, dt_s=2.0),
    "tumble": dict(revolutions=0.05, dt_s=20.0),
    "two-axis-tumble": dict(revolutions=0.05, dt_s=20.0),
    "rate-ladder": dict(seconds=1.0, dt_s=0.2),
}


@pytest.mark.parametrize("name", list(SMALL))
def test_sdf_plans_round_trip_and_match_independent_model(name, tmp_path):
    recs = simulate(plans.build(name, **SMALL[name]), {"coefficients": TRUTH})
    for r in recs:
        save_record(r, tmp_path)
        back = load_record(tmp_path / f"{r.name}.json")
        np.testing.assert_allclose(back.indicated, _sdf_expected(back), rtol=0, atol=1e-9)


def test_servo_plans_follow_hu_3_59(tmp_path):
    """IA along the servo axis: θ̇_s = −Ω·IA_L − drift (Hu 3-59); the recorded angle's increments over each
    interval equal the trapezoid of that rate at the recorded angles to 1e-9 deg/h."""
    truth = {k: TRUTH[k] for k in ("D_F", "D_I", "D_S", "D_IS")}
    for orientation in ("polar", "vertical", "horizontal"):
        rec = simulate(plans.servo(orientation, hours=0.25, dt_s=10.0), {"coefficients": truth})[0]
        save_record(rec, tmp_path)
        back = load_record(tmp_path / f"{rec.name}.json")
        w, a = _inputs(back.with_columns(**{f"rate_{back.axis_names[0]}_dps": np.zeros(back.n)}))
        ai, _, as_ = a.T
        drift = truth["D_F"] + truth["D_I"] * ai + truth["D_S"] * as_ + truth["D_IS"] * ai * as_
        rate = -(w[:, 0] + drift)  # deg/h: Earth rate on IA with the table still, plus drift
        meas = np.diff(back.angles_deg[:, 0]) * 3600.0 / np.diff(back.time_s)
        np.testing.assert_allclose(meas, 0.5 * (rate[1:] + rate[:-1]), rtol=0, atol=1e-9 * 3600)


def test_tdf_and_accelerometer_plans():
    rec = simulate(plans.tdf_tumble(revolutions=0.05, dt_s=20.0), {"coefficients": TDF_TRUTH})[0]
    w, a = _inputs(rec)
    ax, ay, az = a.T
    t = TDF_TRUTH
    x = w[:, 0] + t["DX_F"] + t["DX_X"] * ax + t["DX_Z"] * az + t["DX_XZ"] * ax * az
    y = w[:, 1] + t["DY_F"] + t["DY_Y"] * ay + t["DY_YZ"] * ay * az
    np.testing.assert_allclose(rec.indicated[:, 0], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.indicated[:, 1], y, rtol=0, atol=1e-9)
    rec = simulate(plans.accel_tumble(positions=12, dwell_s=2.0), {"coefficients": ACC_TRUTH})[0]
    _, a = _inputs(rec)
    ai, ap, ao = a.T
    t = ACC_TRUTH
    expect = t["K_0"] + t["K_1"] * ai + t["K_2"] * ai**2 + t["K_3"] * ai**3 + t["K_IP"] * ai * ap + t["K_IO"] * ai * ao
    np.testing.assert_allclose(rec.indicated, expect, rtol=0, atol=1e-12)


def test_accelerometer_tumble_states_and_noise():
    """Hu's two dividing-head states (Hu 3-42, 3-43): with the output axis along the head axis a_O = 0 and a_I·a_P
    turns through g at 2θ; with the pendulous axis along it a_P = 0 and a_I·a_O does. The truth's noise reaches the
    accelerometer in its output unit: the scatter about each position's mean is 60·N/√Δt g (conventions §9.6),
    read from the samples alone."""
    for along, zero, seen in (("oa", 2, 1), ("pa", 1, 2)):
        rec = simulate(plans.accel_tumble(positions=8, dwell_s=2.0, head_along=along), {"coefficients": ACC_TRUTH})[0]
        _, a = _inputs(rec)
        assert np.abs(a[:, zero]).max() < 1e-12 and np.abs(a[:, 0] * a[:, seen]).max() > 0.49
    with pytest.raises(PlanError, match="head_along"):
        plans.accel_tumble(head_along="ia")
    white, dt = 3e-7, 10.0
    plan = plans.accel_tumble(positions=12, dwell_s=400.0, dt_s=dt)
    rec = simulate(plan, {"coefficients": ACC_TRUTH, "noise": {"white": white}}, seed=3)[0]
    y, seg = np.asarray(rec.indicated), np.asarray(rec.segment_id)
    dev = np.concatenate([y[seg == s] - y[seg == s].mean() for s in np.unique(seg)])
    dof = dev.size - len(np.unique(seg))
    sd = math.sqrt(float(dev @ dev) / dof)
    assert sd == pytest.approx(60.0 * white / math.sqrt(dt), rel=4.0 / math.sqrt(2.0 * dof))


def test_plan_json_round_trip_and_errors(tmp_path):
    plan = plans.tumble(revolutions=0.05, dt_s=20.0)
    p = tmp_path / "plan.json"
    p.write_text(plan_to_json(plan))
    again = load_plan(p)
    assert again == plan
    bad = json.loads(plan_to_json(plan))
    del bad["runs"][0]["segments"][0]["duration_s"]
    p.write_text(json.dumps(bad))
    with pytest.raises(PlanError, match="duration_s"):
        load_plan(p)
    with pytest.raises(PlanError, match="unknown plan"):
        plans.build("nonsense")


def test_simulation_is_deterministic_per_key():
    plan = plans.multiposition(6, minutes=0.2, dt_s=2.0)
    truth = {"coefficients": {"D_F": 0.1}, "noise": {"white": 0.001, "gauss_markov": [0.01, 100.0]}}
    a, b, c = simulate(plan, truth, seed=3), simulate(plan, truth, seed=3), simulate(plan, truth, seed=4)
    np.testing.assert_array_equal(a[0].columns["current_mA"], b[0].columns["current_mA"])
    assert not np.array_equal(a[0].columns["current_mA"], c[0].columns["current_mA"])
