"""simulate(dynamics="loop") for TDF (DTG) plans, the accelerometer and the loop-parameter checks.

References: the quasi-static balance of each channel rebuilt here by hand from the plan geometry (Earth rate and
specific force projected on the instrument's X, Y, Z with scipy's rotations; Hu 2-45/2-46 per channel, 3-1 to 3-11,
3-22 to 3-37), and the DTG loops' static matrix S built by hand from the rotor balance (Hu 3-94, 5-64 to 5-68):
S·u = ω + d with S = T + [[ℓ/k_X, −κ/k_Y], [κ/k_X, ℓ/k_Y]]."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax import simulate, units
from gyrojax.data import plans
from gyrojax.dynamics import loops, tdfloop
from gyrojax.errors import PlanError
from gyrojax.inference.identify import fit

DPH = units.DEG_PER_H
EIGHT_TERMS = {
    "DX_F": 0.3,
    "DY_F": -0.2,
    "DX_X": 0.5,
    "DY_Y": -0.4,
    "DX_Y": 0.1,
    "DY_X": 0.15,
    "DX_Z": 0.25,
    "DY_Z": -0.3,
}
TUMBLE_TERMS = {"DX_F": 0.3, "DY_F": -0.2, "DX_X": 0.5, "DY_Y": -0.4, "DX_Z": 0.25, "DY_Z": -0.3, "DX_XZ": 0.05}
TUMBLE_DT = 360.0 / (10.0 * units.OMEGA_IE_DEG_PER_H / 3600.0) / 60.0  # 60 samples a turn, as eight-position's runs
# a deliberately poor loop: 20 % mistuning, torquer SF errors and cross-coupling, so S − I ≈ 1e-3 is visible
POOR = dict(dK=0.2 * 0.02, E_SF_X=300.0, E_SF_Y=-200.0, mu_XY=1e-3, mu_YX=-2e-3)


def _static_matrix(p):
    """S by hand from the parameters (the steady offsets θ_c = −u_c/k_c times the springs, Hu 5-67/5-68)."""
    kx, ky = p.S_nom * p.K_amp_X * p.K_pickoff, p.S_nom * p.K_amp_Y * p.K_pickoff
    kap, ell = p.dK / (p.H * DPH), p.lam / (p.H * DPH)
    t = np.array([[1 + 1e-6 * p.E_SF_X, p.mu_XY], [p.mu_YX, 1 + 1e-6 * p.E_SF_Y]])
    return t + np.array([[ell / kx, -kap / ky], [kap / kx, ell / ky]])


def _hand_quasi_static(rec, coeffs):
    """Channels' sensed rates (n, 2), deg/h: ω_c + D(c)_F + D(c)_X a_X + … from the record's geometry by hand."""
    phi = np.deg2rad(rec.meta["site"]["latitude_deg"])
    earth = units.OMEGA_IE_DEG_PER_H * np.array([0.0, np.cos(phi), np.sin(phi)])
    f = np.array([0.0, 0.0, rec.gravity_mps2 / units.G0])
    (ax,) = [np.asarray(a["axis_enu"], float) for a in rec.meta["table"]["axes"]]  # one-axis tables here
    name = rec.meta["table"]["axes"][0]["name"]
    ang = np.deg2rad(rec.columns[f"angle_{name}_deg"])
    rate = rec.columns[f"rate_{name}_dps"] * 3600.0  # deg/h
    tri = np.array([rec.meta["instrument"][k] for k in ("x", "y", "z")], float)
    rot = Rotation.from_rotvec(ang[:, None] * ax).as_matrix()  # C(θ), platform → L
    w_l = earth + rate[:, None] * ax
    w = np.einsum("ij,njk,nk->ni", tri, rot.transpose(0, 2, 1), w_l)
    a = np.einsum("ij,njk,k->ni", tri, rot.transpose(0, 2, 1), f)
    inp = {"X": a[:, 0], "Y": a[:, 1], "Z": a[:, 2]}
    out = w[:, :2].copy()
    for c, v in coeffs.items():
        ch, term = c[1], c.split("_")[1]
        col = 0 if ch == "X" else 1
        out[:, col] += v * (1.0 if term == "F" else np.prod([inp[s] for s in term], axis=0))
    return out


@pytest.fixture(scope="module")
def cases():
    """(plan, truth coefficients, quasi-static records, poor-loop records, default-loop records) per plan."""
    out = {}
    for name, opts, coeffs in (
        ("eight-position", dict(kind="tdf-gyro", minutes=1.0), EIGHT_TERMS),
        ("tdf-tumble", dict(revolutions=1.0, dt_s=TUMBLE_DT), TUMBLE_TERMS),
    ):
        plan = plans.build(name, **opts)
        truth = {"coefficients": coeffs}
        qs = simulate(plan, truth)
        poor = simulate(plan, truth, dynamics="loop", loop=tdfloop.default_tdf(**POOR))
        dflt = simulate(plan, truth, dynamics="loop")
        out[name] = (plan, coeffs, qs, poor, dflt)
    return out


@pytest.mark.parametrize("name", ["eight-position", "tdf-tumble"])
def test_loop_records_are_the_static_balance_of_the_quasi_static_rates(cases, name):
    """Noise-free: each loop reading is S⁻¹ times the hand-made quasi-static pair (every hold is far longer than the
    loop's slowest mode, ~28 /s), so the records differ from the quasi-static ones by exactly the static error."""
    _, coeffs, qs, poor, dflt = cases[name]
    for params, recs in ((tdfloop.default_tdf(**POOR), poor), (tdfloop.default_tdf(), dflt)):
        s_inv = np.linalg.inv(_static_matrix(params))
        for q, r in zip(qs, recs):
            hand = _hand_quasi_static(q, coeffs)
            scale = np.abs(hand).max()
            np.testing.assert_allclose(q.indicated, hand, rtol=0, atol=1e-9 * scale)  # the reference is right
            np.testing.assert_allclose(r.indicated, hand @ s_inv.T, rtol=0, atol=1e-9 * scale)
            # |loop − quasi-static| within ‖S⁻¹ − I‖∞·|sensed|, and the error is not zero
            err = np.abs(r.indicated - q.indicated).max()
            assert err <= np.abs(s_inv - np.eye(2)).sum(axis=1).max() * scale * (1 + 1e-9)
            assert err > 1e-7 * scale


@pytest.mark.parametrize("name", ["eight-position", "tdf-tumble"])
def test_fit_of_loop_records_recovers_truth_within_the_static_error(cases, name):
    """identify.fit on the loop records recovers the truth's DX_*/DY_* within the static error they carry: a channel
    error e = (S⁻¹ − I)(ω + d) moves a coefficient by at most a few |e|, the plan's combination of positions
    (Hu 3-1 to 3-11: D_F, D_X, D_Y as ±(1/2, 1/4) combinations, D_Z as a difference of means; 3-22 to 3-37: Fourier
    coefficients, amplitude ≤ 4/π, divided by sin φ for the spin-axis terms). Quasi-static records fit exactly."""
    _, coeffs, qs, poor, dflt = cases[name]
    terms = list(coeffs)
    f0 = fit(qs, terms, noise="white")
    np.testing.assert_allclose([f0.values[c] for c in terms], [coeffs[c] for c in terms], rtol=0, atol=1e-9)
    lat = np.deg2rad(plans.DEFAULT_LATITUDE)
    for recs in (poor, dflt):  # e is ≤ ‖S⁻¹ − I‖∞·|sensed| (previous test)
        e = max(np.abs(r.indicated - q.indicated).max() for q, r in zip(qs, recs))
        tol = 2.0 * e / np.sin(lat)
        f = fit(recs, terms, noise="white")
        dev = np.array([f.values[c] - coeffs[c] for c in terms])
        assert np.abs(dev).max() <= tol, (dict(zip(terms, dev)), tol)
    assert np.abs(dev).max() > 0  # the default loop's static error is real (≈ 2e-4 relative), just small


def test_wrong_loop_parameters_for_the_kind_raise_naming_it():
    tdf = plans.build("eight-position", kind="tdf-gyro", minutes=0.05)
    sdf = plans.build("eight-position", minutes=0.05)
    truth = {"coefficients": {}}
    with pytest.raises(PlanError, match="tdf-gyro run needs loop=TDFParams"):
        simulate(tdf, truth, dynamics="loop", loop=loops.default_rebalance())
    with pytest.raises(PlanError, match="sdf-gyro run needs loop=RebalanceParams"):
        simulate(sdf, truth, dynamics="loop", loop=tdfloop.default_tdf())
    with pytest.raises(PlanError, match="unknown instrument kind"):
        simulate(sdf, truth, dynamics="loop", loop={"sdf": loops.default_rebalance()})


def test_mixed_plan_takes_a_dict_of_loops():
    """One SDF and one TDF run in a plan: a dict {kind: params} gives each its loop, the default for kinds left out
    (S⁻¹ visible on the TDF run, the SDF at its quasi-static value within the default loop's 1e-6)."""
    tdf = plans.build("eight-position", kind="tdf-gyro", minutes=1.0)
    sdf = plans.build("eight-position", minutes=1.0)
    mixed = dataclasses.replace(tdf, runs=(sdf.runs[0], tdf.runs[0]))
    truth = {"coefficients": {"D_F": 0.5, "DX_F": 0.3, "DY_F": -0.2}}
    p = tdfloop.default_tdf(**POOR)
    qs = simulate(mixed, truth, loop=p)  # quasi-static ignores ``loop``
    lp = simulate(mixed, truth, dynamics="loop", loop={"tdf-gyro": p})
    assert lp[0].kind == "sdf-gyro" and lp[1].kind == "tdf-gyro"
    np.testing.assert_allclose(lp[0].indicated, qs[0].indicated, rtol=1e-6)
    np.testing.assert_allclose(lp[1].indicated, qs[1].indicated @ np.linalg.inv(_static_matrix(p)).T, rtol=1e-9)


def test_accelerometer_runs_through_the_float_loop_with_unit_dc_gain():
    """The pendulum's float obeys the SDF float equation with pendulosity·a for H·ω (Hu 3-38): at the dwell the
    loop reads the quasi-static output K_0 + K_1 a_I + …, in g (unit DC gain; the loop's lag on moving inputs is the
    SDF loop's, tested in test_loops/test_loopfit)."""
    truth = {"coefficients": {"K_0": 1e-4, "K_1": 1.0, "K_2": 2e-5}}
    plan = plans.build("accel-tumble", positions=4, dwell_s=5.0)
    qs, lp = simulate(plan, truth), simulate(plan, truth, dynamics="loop")
    np.testing.assert_allclose(lp[0].indicated, qs[0].indicated, rtol=0, atol=1e-9)
    with pytest.raises(PlanError, match="pendulous-accel run needs loop=RebalanceParams"):
        simulate(plan, truth, dynamics="loop", loop=tdfloop.default_tdf())


def test_random_drift_goes_through_the_loop_as_a_drift_torque():
    """With noise, the loop sees the same sensed rates (same key) and reads them through S⁻¹ sample by sample: the
    random drift is a torque on the rotor like the drift coefficients (Hu 5-64)."""
    plan = plans.build("eight-position", kind="tdf-gyro", minutes=1.0)
    truth = {"coefficients": {"DX_F": 0.3}, "noise": {"white": 0.01, "gauss_markov": [0.02, 300.0]}}
    p = tdfloop.default_tdf(**POOR)
    qs = simulate(plan, truth, seed=3)
    lp = simulate(plan, truth, seed=3, dynamics="loop", loop=p)
    s_inv = np.linalg.inv(_static_matrix(p))
    for q, r in zip(qs, lp):
        assert np.std(np.diff(q.indicated[:, 0])) > 0.1  # noisy
        np.testing.assert_allclose(r.indicated, q.indicated @ s_inv.T, rtol=0, atol=1e-9 * np.abs(q.indicated).max())
