"""Static-interval detection for hand-moved IMUs, and the accelerometer calibration of the poses it finds.

:func:`static_intervals` is a variance detector in the spirit of imu_tk's (Tedaldi, Pretto & Menegatti, ICRA 2014,
§IV-A): a sample is static when the variance of the accelerometer over a window around it is below k times the
variance seen during the initial rest, and — better for hand-held moves, which can be slow and smooth — the gyro's
variance too. Runs shorter than a minimum duration are dropped and every run is trimmed by half a window at each
end, so no sample of a move is taken for rest.

:func:`ellipsoid_accelerometer` fits the 9-parameter accelerometer model of imu_tk (bias, scale, three
non-orthogonality angles) by requiring every static pose's calibrated specific force to have the magnitude of
gravity (Tedaldi et al. eq. 10), by scipy's least squares.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize

from gyrojax.errors import RecordError


def rolling_variance(x: np.ndarray, window: int) -> np.ndarray:
    """Variance of each column of ``x`` (n, k) over a centred window of ``window`` samples (edges: shorter windows)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    c1 = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    c2 = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x * x, axis=0)])
    half = window // 2
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    return np.maximum((c2[hi] - c2[lo]) / cnt - mean * mean, 0.0)


def static_intervals(
    acc: np.ndarray,
    rate_hz: float,
    *,
    gyro: np.ndarray | None = None,
    init_s: float = 50.0,
    window_s: float = 1.0,
    k: float = 6.0,
    min_s: float = 2.0,
) -> list[tuple[int, int]]:
    """(start, end) sample ranges (end exclusive) of the static intervals of an IMU recording (module doc).

    Args:
      acc: (n, 3) accelerometer samples (any unit); gyro: (n, 3) gyro samples (any unit), optional.
      rate_hz: sample rate, Hz. init_s: length of the initial rest that sets the noise level, s.
      window_s: variance window, s. k: threshold factor on the initial rest's variance. min_s: shortest interval, s.
    """
    acc = np.asarray(acc, dtype=float)
    n = len(acc)
    w = max(3, int(round(window_s * rate_hz)))
    n_init = int(round(init_s * rate_hz))
    if n_init < 2 * w or n_init > n:
        raise RecordError(
            f"the static detector needs an initial rest of {init_s:g} s ({n_init} samples) longer than two "
            f"windows ({2 * w} samples) and within the {n} samples"
        )
    static = np.ones(n, dtype=bool)
    for x in (acc, gyro):
        if x is None:
            continue
        v = rolling_variance(np.asarray(x, dtype=float), w).sum(axis=1)
        level = float(np.median(v[w : n_init - w]))
        if level <= 0:
            level = float(np.max(v[:n_init])) or 1e-30
        static &= v <= k * level
    edges = np.flatnonzero(np.diff(np.concatenate([[0], static.astype(int), [0]])))
    out = []
    trim = w // 2
    for s, e in zip(edges[::2], edges[1::2]):
        s2, e2 = s + trim if s > 0 else s, e - trim if e < n else e
        if e2 - s2 >= min_s * rate_hz:
            out.append((int(s2), int(e2)))
    return out


def imutk_acc_model(params: np.ndarray, raw: np.ndarray) -> np.ndarray:
    """imu_tk's accelerometer model: a = T K (raw − b), T = [[1, −α_yz, α_zy], [0, 1, −α_zx], [0, 0, 1]],
    K = diag(s); ``params`` = (α_yz, α_zy, α_zx, s_x, s_y, s_z, b_x, b_y, b_z) (Tedaldi et al. eqs. 1–6)."""
    ayz, azy, azx = params[:3]
    t = np.array([[1.0, -ayz, azy], [0.0, 1.0, -azx], [0.0, 0.0, 1.0]])
    return (t @ np.diag(params[3:6]) @ (np.asarray(raw) - params[6:9]).T).T


def ellipsoid_accelerometer(pose_means: np.ndarray, g: float, scale0: float, bias0) -> np.ndarray:
    """Parameters of :func:`imutk_acc_model` such that every pose mean (rows, raw units) has magnitude ``g``.

    ``scale0`` (g per raw unit) and ``bias0`` (raw) start the least squares; at least 9 poses are needed."""
    pose_means = np.asarray(pose_means, dtype=float)
    if len(pose_means) < 9:
        raise RecordError(
            f"the accelerometer needs at least 9 static poses for its 9 parameters; found {len(pose_means)}"
        )
    x0 = np.concatenate([np.zeros(3), np.full(3, scale0), np.asarray(bias0, dtype=float)])

    def resid(p):
        return np.linalg.norm(imutk_acc_model(p, pose_means), axis=1) - g

    sol = optimize.least_squares(resid, x0, method="lm", x_scale="jac")
    return sol.x
