"""The accelerometer of a triad, fitted beside the gyro from the same rests: imu_tk's model with σ.

imu_tk's (Tedaldi et al. 2014, eqs. 1–6) and Kalibr's accelerometer model: a_cal = T K (a − b), T upper triangular
with the three non-orthogonality angles (α_yz, α_zy, α_zx, rad), K = diag(s) the scale factors, b the bias (g),
fitted to |a_cal| = g_site at every static pose (:func:`gyrojax.data.segments.ellipsoid_accelerometer`, one
path with the importers' check :func:`gyrojax.data.accelcheck.accelerometer_in_g`). The noise of a pose's
|mean| is the sample variance of |a| over the pose / n; where the poses scatter more than that (χ² above its dof:
a hand's tremor, an effect the 9 parameters miss), the covariance is scaled by χ²/dof (Birge), so σ stay honest.

The gyro fit takes the records' specific force as calibrated when every rest's |a| is within
:data:`~gyrojax.data.accelcheck.ACC_CALIBRATED_TOL` of g (its g-terms then move by less than that fraction);
beyond it the specific force is calibrated here first (never taken on trust), and a session with fewer than 9
poses is refused.
"""

from __future__ import annotations

import numpy as np

from gyrojax import tails, units
from gyrojax.data.accelcheck import ACC_CALIBRATED_TOL, determinacy
from gyrojax.data.segments import ellipsoid_accelerometer, imutk_acc_jacobian, imutk_acc_model
from gyrojax.data.triad import acc_g
from gyrojax.data.triad_segments import label_rows
from gyrojax.errors import ModelError
from gyrojax.optimize import least_squares

PARAMS = ("alpha_yz", "alpha_zy", "alpha_zx", "s_x", "s_y", "s_z", "b_x", "b_y", "b_z")
PARAM_UNITS = ("rad",) * 3 + ("-",) * 3 + ("g",) * 3
MIN_POSES = 9  # nine parameters


def rest_means(records) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pose means (k, 3) g, variance of each pose's |mean| (k,) g², local g of each pose (k,) in g) of the
    static segments of triad ``records`` that have an accelerometer."""
    means, var, g_loc = [], [], []
    for r in records:
        a = acc_g(r)
        if a is None:
            continue
        rows = label_rows(r.columns["segment"])
        g_site = float(r.meta["site"]["gravity_mps2"]) / units.G0
        for spec in r.meta["segments"]:
            if spec["type"] != "static":
                continue
            sel = a[rows(spec["label"])]
            if len(sel) < 2:
                continue
            means.append(sel.mean(axis=0))
            var.append(float(np.linalg.norm(sel, axis=1).var(ddof=1)) / len(sel))
            g_loc.append(g_site)
    return np.array(means).reshape(-1, 3), np.array(var), np.array(g_loc)


def _residual(p, means, g_loc):
    return np.linalg.norm(imutk_acc_model(p, means), axis=1) - g_loc


def residual_jacobian(params, means) -> np.ndarray:
    """Exact ∂|T K (a − b)|/∂p (k, 9) at the pose means ``means`` (k, 3) g, in g per parameter unit (rad, -, g)
    (:func:`gyrojax.data.segments.imutk_acc_jacobian`, Tedaldi et al. eq. 6)."""
    return imutk_acc_jacobian(params, means)


def fit_accelerometer(records) -> dict | None:
    """imu_tk's 9 accelerometer parameters with their covariance from the rests of ``records`` (module doc), or
    None when they have no accelerometer or fewer than :data:`MIN_POSES` poses. Returns ``params`` (9,), ``cov``
    (9, 9), ``chi2``, ``dof``, ``birge`` (the factor applied to the covariance, ≥ 1),
    ``max_rest_magnitude_error`` of the records' specific force as given (fraction of g), and the standard errors the
    rests allow at 0.1 % of g per rest with a note when they are poor (``std_at_rest_error``, ``poorly_determined``:
    :func:`gyrojax.data.accelcheck.determinacy`; the pose-noise covariance above understates them when the poses
    scatter by more than their noise, which Birge's factor sees only beyond 9 poses)."""
    means, var, g_loc = rest_means(records)
    if len(means) < MIN_POSES:
        return None
    before = float(np.max(np.abs(np.linalg.norm(means, axis=1) / g_loc - 1.0)))
    g_mean = float(np.mean(g_loc))
    params = ellipsoid_accelerometer(means, g_mean, 1.0, np.zeros(3))
    if not np.allclose(g_loc, g_mean):  # records of different sites: refine at each pose's own g
        system = lambda p: (-_residual(p, means, g_loc), residual_jacobian(p, means))  # noqa: E731
        params = least_squares(system, params, 100 * (len(params) + 1)).x
    sd = np.sqrt(np.maximum(var, 1e-30))
    r = _residual(params, means, g_loc) / sd
    jac = residual_jacobian(params, means) / sd[:, None]
    dof = len(means) - 9
    chi2 = float(r @ r)
    cov = np.linalg.pinv(jac.T @ jac)
    birge = max(chi2 / dof, 1.0) if dof > 0 else 1.0
    # what the rests leave undetermined, whatever wrote the record (the importers say it too, on the raw counts)
    std_at_rest_error, poorly = determinacy(params, means, g_mean)
    return {
        "params": params,
        "cov": cov * birge,
        "chi2": chi2,
        "dof": dof,
        "p_value": float(tails.chi2_sf(chi2, dof)) if dof > 0 else float("nan"),
        "birge": birge,
        "max_rest_magnitude_error": before,
        "n_poses": len(means),
        "std_at_rest_error": std_at_rest_error,
        "poorly_determined": poorly,
    }


def needs_calibration(acc_fit: dict | None, records) -> bool:
    """True when the records' rests are off g by more than the tolerance (module doc); refuses a session that
    cannot calibrate its accelerometer then."""
    if acc_fit is not None:  # the same worst |a| error, measured by the fit on the same rests
        worst = float(acc_fit["max_rest_magnitude_error"])
    else:
        means, _, g_loc = rest_means(records)
        if not len(means):
            return False
        worst = float(np.max(np.abs(np.linalg.norm(means, axis=1) / g_loc - 1.0)))
    if worst <= ACC_CALIBRATED_TOL:
        return False
    if acc_fit is None:
        raise ModelError(
            f"the accelerometer of {', '.join(r.name for r in records)} reads |a| off g by up to {100 * worst:.3g} % "
            f"at rest and {len(means)} poses cannot calibrate its 9 parameters (at least {MIN_POSES}); give "
            "calibrated g (import with --acc-unit counts to calibrate it there)"
        )
    return True


def calibrate(acc_fit: dict, acc: np.ndarray) -> np.ndarray:
    """Calibrated specific force (n, 3) g of the records' ``acc`` (n, 3) g by the fitted model."""
    return imutk_acc_model(np.asarray(acc_fit["params"], dtype=float), acc)


def kalibr_accelerometer(params) -> dict:
    """Kalibr's ``scale-misalignment`` accelerometer intrinsics of imu_tk's parameters, a_m = M⁻¹ a + b (M = T K
    upper triangular, a in m/s²): M and b in m/s²."""
    p = np.asarray(params, dtype=float)
    t = np.array([[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]])
    return {"M": (t @ np.diag(p[3:6])).tolist(), "b_mps2": (p[6:9] * units.G0).tolist()}


def accelerometer_json(acc_fit: dict | None) -> dict | None:
    """The fit JSON's ``accelerometer`` entry: values and σ of the 9 parameters, χ², Kalibr's form."""
    if acc_fit is None:
        return None
    p, cov = np.asarray(acc_fit["params"]), np.asarray(acc_fit["cov"])
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return {
        "model": "imu_tk: a_cal = T K (a - b), a in g; T = [[1, -alpha_yz, alpha_zy], [0, 1, -alpha_zx], [0, 0, 1]]",
        "coefficients": {
            n: {"value": float(v), "std": float(s), "unit": u} for n, v, s, u in zip(PARAMS, p, sd, PARAM_UNITS)
        },
        "params": p.tolist(),
        "cov": cov.tolist(),
        "chi2": float(acc_fit["chi2"]),
        "dof": int(acc_fit["dof"]),
        "birge": float(acc_fit["birge"]),
        "n_poses": int(acc_fit["n_poses"]),
        "max_rest_magnitude_error_as_given": float(acc_fit["max_rest_magnitude_error"]),
        "calibrated_before_gyro_fit": bool(acc_fit.get("applied", False)),
        "std_at_rest_error": acc_fit["std_at_rest_error"],
        "kalibr": kalibr_accelerometer(p),
    }
