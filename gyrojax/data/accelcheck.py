"""The accelerometer is never taken as calibrated on trust: its rest magnitudes are checked against g, and a sensor
off by more than :data:`ACC_CALIBRATED_TOL` is calibrated (imu_tk's 9-parameter ellipsoid, started from a sphere
fitted in closed form) with a note, or refused as a wrong unit beyond :data:`ACC_UNIT_TOL`."""

from __future__ import annotations

import numpy as np

from gyrojax import units
from gyrojax.errors import RecordError

ACC_CALIBRATED_TOL = 0.01
"""A calibrated accelerometer reads |a| = g at every rest within this fraction (consumer MEMS after calibration:
0.1–0.5 %; the poses' means have noise far below it). Beyond it the accelerometer is calibrated here."""
ACC_UNIT_TOL = 0.25
"""Beyond this fraction off g at rest the unit given is wrong, not the sensor's calibration (a 25 % gain error is
no accelerometer's); the import is refused."""


def sphere_fit(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of the sphere through ``points`` (k, 3) by linear least squares,
    |p − c|² = r² ⇔ 2 p·c + (r² − |c|²) = |p|² (closed form; starts the ellipsoid fit in any unit)."""
    a = np.column_stack([2.0 * points, np.ones(len(points))])
    sol, *_ = np.linalg.lstsq(a, (points**2).sum(axis=1), rcond=None)
    c = sol[:3]
    return c, float(np.sqrt(max(sol[3] + c @ c, 0.0)))


REST_ERROR_G = 1e-3
"""Error of one rest's |a| (in g) at which :func:`determinacy` states the calibration's standard errors: 0.1 %, a
tenth of :data:`ACC_CALIBRATED_TOL` (the pose-to-pose repeatability of a consumer MEMS accelerometer)."""
WEAK = {"scale": 0.01, "bias": 0.01, "misalignment": 0.01}
"""Standard errors (at :data:`REST_ERROR_G`) beyond which :func:`determinacy` says the rests determine the
calibration poorly: 1 % of scale factor, 10 mg of bias, 10 mrad of misalignment."""


def determinacy(params: np.ndarray, means: np.ndarray, g_units: float) -> tuple[dict, str | None]:
    """Standard errors of imu_tk's ellipsoid calibration ``params`` from the rest means ``means`` (k, 3, raw units)
    if each rest's |a| erred by :data:`REST_ERROR_G` (linearised least squares, the exact Jacobian
    :func:`gyrojax.data.segments.imutk_acc_jacobian`, columns normalised): ``scale`` relative, ``bias`` in g,
    ``misalignment`` in rad, per parameter (None where the rests do not determine it at all); and a note when any is
    beyond :data:`WEAK` (rests too few, or an axis never pointed up or down: its scale factor and bias then trade
    with |a| still g at every rest), else None."""
    from gyrojax.data.segments import imutk_acc_jacobian

    jac = imutk_acc_jacobian(params, means) / g_units
    norms = np.sqrt((jac * jac).sum(axis=0))
    z = jac / np.where(norms > 0, norms, 1.0)
    sv = np.linalg.svd(z, compute_uv=False)
    if sv[-1] <= 1e-12 * sv[0]:
        sd = np.full(len(params), np.inf)
    else:
        sd = np.sqrt(np.diag(np.linalg.inv(z.T @ z))) / np.where(norms > 0, norms, 1.0) * REST_ERROR_G
    scale = params[3:6]
    out = {"scale": sd[3:6] / np.abs(scale), "bias": sd[6:9] * np.abs(scale), "misalignment": sd[:3]}
    weak = {k: v for k, v in out.items() if np.any(~np.isfinite(v) | (v > WEAK[k]))}
    unit = {"scale": ("%", 100.0), "bias": ("mg", 1e3), "misalignment": ("mrad", 1e3)}
    axes = {"scale": "x/y/z", "bias": "x/y/z", "misalignment": "α_yz/α_zy/α_zx"}
    parts = [
        f"{k} ±" + "/".join(f"{unit[k][1] * x:.2g}" for x in out[k]) + f" {unit[k][0]} ({axes[k]})"
        for k in ("scale", "bias", "misalignment")
    ]
    out = {k: [float(x) if np.isfinite(x) else None for x in v] for k, v in out.items()}  # None: not determined
    if not weak:
        return out, None
    note = (
        f"the {len(means)} rests determine the accelerometer's calibration poorly: at {100 * REST_ERROR_G:g} % of g "
        f"per rest, {'; '.join(parts)}; the rests' gravity directions, which give the moves' rotations, inherit "
        "it: record more rests, each axis up and down (Tedaldi et al. 2014: 36-50 poses)"
    )
    return out, note


def accelerometer_in_g(
    acc: np.ndarray,
    intervals: list,
    acc_unit: str,
    g_units: float,
    *,
    acc_g_per_count: float | None = None,
    acc_bias0=None,
    where: str = "accelerometer",
) -> tuple[np.ndarray, dict | None, list[str], dict]:
    """The accelerometer in g, never taken as calibrated on trust: returns (specific force (n, 3) in g, its
    calibration or None, notes, the check: ``unit``, ``calibrated_here``, ``max_rest_magnitude_error`` of the
    result, relative to the local g).

    ``counts``: calibrated by imu_tk's 9-parameter model (:func:`gyrojax.data.segments.ellipsoid_accelerometer`)
    fitted to |a| = g over the rests, started from a sphere through the rest means (:func:`sphere_fit`, so any
    offset and unit works: signed or unsigned counts, even m/s²) or from ``acc_bias0``/``acc_g_per_count``.
    ``g`` and ``m/s^2``: the rests' |a| is checked against the local g; within :data:`ACC_CALIBRATED_TOL` the data
    are taken as calibrated, beyond it calibrated as counts are (with a note), beyond :data:`ACC_UNIT_TOL` refused
    (a unit mistake). Refused too when the calibration leaves |a| ≠ g by more than :data:`ACC_CALIBRATED_TOL` rms
    or the rests do not point in three dimensions."""
    from gyrojax.data.segments import ellipsoid_accelerometer, imutk_acc_model

    if acc_unit not in ("g", "m/s^2", "counts"):
        raise RecordError(f"accelerometer unit (--acc-unit) must be 'g', 'm/s^2' or 'counts', got {acc_unit!r}")
    means = np.array([acc[s:e].mean(axis=0) for s, e in intervals])
    notes = []
    if acc_unit != "counts":
        scale = 1.0 if acc_unit == "g" else 1.0 / units.G0
        mag = np.linalg.norm(means * scale, axis=1) / g_units - 1.0
        worst = float(mag[np.argmax(np.abs(mag))])
        if abs(worst) <= ACC_CALIBRATED_TOL:
            check = {"unit": acc_unit, "calibrated_here": False, "max_rest_magnitude_error": abs(worst)}
            return acc * scale, None, notes, check
        med = float(np.median(np.linalg.norm(means, axis=1)))
        if abs(float(np.median(mag))) > ACC_UNIT_TOL:
            raise RecordError(
                f"{where}: the accelerometer reads |a| = {med:.4g} {acc_unit} at rest (median of {len(means)} rests), "
                f"{100 * float(np.median(mag)):+.0f} % from the local g: is --acc-unit {acc_unit} right "
                "(g, m/s^2, or counts to calibrate)?"
            )
        notes.append(
            f"the accelerometer is not calibrated: |a| at rest is {100 * float(np.median(mag)):+.2f} % from the "
            f"local g (median; {100 * mag.min():+.2f} to {100 * mag.max():+.2f} % over {len(means)} rests); "
            "calibrated here by imu_tk's 9-parameter ellipsoid"
        )
    if len(means) >= 2:
        _, sv, _ = np.linalg.svd(means - means.mean(axis=0))
    if len(means) < 9 or sv[2] < 1e-3 * sv[0]:
        raise RecordError(
            f"{where}: the accelerometer needs calibrating (--acc-unit {acc_unit}) and {len(means)} rests that do not "
            "point in three dimensions cannot calibrate its 9 parameters; give calibrated g"
        )
    centre, radius = sphere_fit(means)
    bias0 = centre if acc_bias0 is None else np.asarray(acc_bias0, dtype=float)
    scale0 = acc_g_per_count or g_units / (radius or float(np.linalg.norm(means[0] - bias0)))
    params = ellipsoid_accelerometer(means, g_units, scale0, bias0)
    acc_cal = imutk_acc_model(params, acc)
    resid = np.linalg.norm(imutk_acc_model(params, means), axis=1) / g_units - 1.0
    rms = float(np.sqrt(np.mean(resid**2)))
    if rms > ACC_CALIBRATED_TOL:
        raise RecordError(
            f"{where}: imu_tk's ellipsoid calibration of the accelerometer leaves |a| off g by {100 * rms:.2g} % rms "
            f"over {len(means)} rests: not one accelerometer in --acc-unit {acc_unit}, or rests that are not at rest"
        )
    notes.append(
        f"accelerometer ({acc_unit}) calibrated by imu_tk's ellipsoid over {len(means)} rests: scale "
        + ", ".join(f"{v:.5g}" for v in params[3:6])
        + f" g per {acc_unit if acc_unit != 'counts' else 'count'}, bias "
        + ", ".join(f"{v:.4g}" for v in params[6:9])
        + f"; |a| = g to {100 * rms:.2g} % rms"
    )
    std, weak = determinacy(params, means, g_units)
    if weak:
        notes.append(weak)
    calib = {
        "model": "imu_tk: a = T K (raw - b) in g; params alpha_yz, alpha_zy, alpha_zx, s_x..s_z, b_x..b_z",
        "raw_unit": acc_unit,
        "params": params.tolist(),
        "rms_magnitude_error": rms,
        "std_at_rest_error": {"rest_error_g": REST_ERROR_G, **std},
    }
    check = {"unit": acc_unit, "calibrated_here": True, "max_rest_magnitude_error": float(np.abs(resid).max())}
    return acc_cal, calib, notes, check
