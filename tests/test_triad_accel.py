"""The triad's accelerometer fitted beside the gyro (issue 24): imu_tk's 9 parameters with σ, checked against a
planted truth (coverage over seeds), an accelerometer off g calibrated before the gyro fit or refused, and the
calibrated specific force in ``apply`` beside the calibrated rates."""

import copy

import numpy as np
import pytest
from scipy import stats

from gyrojax.cli.app import main
from gyrojax.data.record import Record
from gyrojax.data.records import save_record
from gyrojax.errors import ModelError
from gyrojax.inference.triad import fit_triad
from gyrojax.inference.triad_accel import PARAMS, fit_accelerometer
from gyrojax.inference.triad_result import load_triad_fit
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.simulation.triad import simulate_multiposition

TRUTH = mems_truth(7)
# a consumer MEMS accelerometer before calibration: 2–4 % scale, 0.3–0.8° non-orthogonality, 30–60 mg bias
ACC_TRUE = np.array([0.006, -0.009, 0.012, 1.03, 0.97, 1.04, 0.03, -0.06, 0.045])


def uncalibrated(rec: Record, p=ACC_TRUE) -> Record:
    """``rec`` with its accelerometer read through imu_tk's model inverted (Tedaldi et al. eqs. 1–6, written out
    here): raw = K⁻¹ T⁻¹ a + b, so that T K (raw − b) = a."""
    t = np.array([[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]])
    a = np.column_stack([rec.columns[f"acc_{c}_g"] for c in "xyz"])
    raw = np.linalg.solve(t @ np.diag(p[3:6]), a.T).T + p[6:9]
    cols = dict(rec.columns)
    for j, c in enumerate("xyz"):
        cols[f"acc_{c}_g"] = raw[:, j]
    return Record(copy.deepcopy(rec.meta), cols)


def test_accelerometer_parameters_cover_the_planted_truth():
    """30 simulated 16-pose sessions: the 9 parameters inside ±2σ at the rate of an honest σ (99.9 % binomial
    interval of p = 0.9545)."""
    hits = []
    for seed in range(30):
        rec = uncalibrated(simulate_multiposition(TRUTH, poses=16, seed=500 + seed, acc_noise_g=0.003))
        f = fit_accelerometer([rec])
        sd = np.sqrt(np.diag(f["cov"]))
        hits.extend(np.abs(f["params"] - ACC_TRUE) <= 2 * sd)
    lo, hi = stats.binom.ppf([0.0005, 0.9995], len(hits), 0.9545) / len(hits)
    assert lo <= np.mean(hits) <= hi, (np.mean(hits), lo, hi)


def test_accelerometer_off_g_is_calibrated_before_the_gyro_fit(tmp_path):
    """|a| 3–4 % off g at rest: the fit calibrates the accelerometer (never takes it as calibrated), the gyro's
    coefficients still land on the truth, the JSON carries the accelerometer with σ, and ``apply`` writes the
    calibrated specific force (|a| = g at the rests) beside the calibrated rates."""
    rec = simulate_multiposition(TRUTH, poses=14, seed=8, earth_rate=False)
    bad = uncalibrated(rec)
    res = fit_triad(bad)
    acc = res.accelerometer
    assert acc["calibrated_before_gyro_fit"] and acc["max_rest_magnitude_error_as_given"] > 0.02
    for n, v in zip(PARAMS, ACC_TRUE):
        c = acc["coefficients"][n]
        assert abs(c["value"] - v) < 4.5 * c["std"], n
    z = np.array([(res.values[k] - v) / res.stds[k] for k, v in TRUTH.items()])
    assert np.max(np.abs(z)) < 4.5, z
    path = res.save(tmp_path / "fit.json")
    assert load_triad_fit(path).accelerometer["params"] == pytest.approx(acc["params"])
    save_record(bad, tmp_path / "rec")
    assert main(["apply", str(path), str(tmp_path / "rec"), "--out", str(tmp_path / "cal")]) == 0
    out = np.genfromtxt(next((tmp_path / "cal").glob("*.csv")), delimiter=",", names=True)
    seg = np.asarray(bad.columns["segment"]).astype(int)
    rest = seg == 0
    mag = np.linalg.norm(np.column_stack([out[f"acc_{c}_g"][rest] for c in "xyz"]).mean(axis=0))
    assert mag == pytest.approx(9.81 / 9.80665, rel=2e-3)
    assert {"gyro_x_dps", "acc_z_g"} <= set(out.dtype.names)


def test_accelerometer_off_g_that_cannot_be_calibrated_is_refused():
    rec = uncalibrated(simulate_multiposition(TRUTH, poses=6, seed=9))
    with pytest.raises(ModelError, match="cannot calibrate its 9 parameters"):
        fit_triad(rec, allow_aliases=True)
