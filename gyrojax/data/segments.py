"""Static-interval detection for hand-moved IMUs, and the accelerometer calibration of the poses it finds.

:func:`detect_rests` is a variance detector in the spirit of imu_tk's (Tedaldi, Pretto & Menegatti, ICRA 2014,
§IV-A): a sample is at rest when the variance of the accelerometer over a short window around it, and that of the
gyro (better for hand-held moves, which can be slow and smooth), are below ``threshold`` times the variance of the
rests' own noise. That noise is estimated from the record itself, channel by channel and robustly (from its quietest
windows, then from the median window of the rests found), so the threshold is a multiple of the sensor's own noise,
not an absolute number tuned to one sensor; by default the multiple that one window of that noise exceeds with
probability 10⁻⁶, from the spread of the rests' own windows (:func:`window_dof`). Runs shorter than a minimum are
dropped and every run is trimmed by half a window at each end next to a move, so no sample of a move is taken for
rest. What it drops, it reports.

:func:`ellipsoid_accelerometer` fits the 9-parameter accelerometer model of imu_tk (bias, scale, three
non-orthogonality angles) by requiring every static pose's calibrated specific force to have the magnitude of
gravity (Tedaldi et al. eq. 10), by scipy's Levenberg–Marquardt on the exact Jacobian (:func:`imutk_acc_jacobian`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from gyrojax import tails
from gyrojax.data.timebase import true_runs
from gyrojax.errors import RecordError

WINDOW_S = 0.2
"""Default variance window, s: short enough that a 1 s rest keeps most of its samples after trimming."""
MIN_REST_S = 0.5
"""Default shortest rest kept (after trimming), s: a 1.3 s rest at 100 Hz keeps about 0.9 s."""
FALSE_ALARM = 1e-6
"""Probability that one window of rest noise exceeds the default threshold (module doc of :func:`default_threshold`)."""
CANDIDATE_FACTOR = 10.0
"""A candidate rest is a run whose variance stays below this many thresholds: within an order of magnitude of the
noise (a hand move is 10³–10⁶ above it); candidates that yield no rest are reported as dropped."""


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


def window_samples(window_s: float, rate_hz: float) -> int:
    """Samples in the centred variance window of ``window_s`` s at ``rate_hz`` Hz: 2·round(window_s·rate_hz/2) + 1,
    at least 5."""
    return max(5, 2 * int(round(window_s * rate_hz / 2)) + 1)


def default_threshold(dof: float) -> float:
    """The default rest threshold, in multiples of the rest noise variance, for windows whose variance has ``dof``
    degrees of freedom: the ratio that one window of rest noise, χ²_dof/dof, exceeds with probability
    :data:`FALSE_ALARM` (3.27 for the 20 of a 0.2 s window of white noise at 100 Hz)."""
    return float(tails.chi2_isf(FALSE_ALARM, dof) / dof)


def window_dof(ratio: np.ndarray, m: int) -> float:
    """Degrees of freedom of the rest windows' variance ratio ``ratio`` (samples at rest), from its spread:
    χ²_ν/ν has variance 2/ν, the spread taken robustly (interquartile range / 1.349). At most m − 1, the value of
    white noise with the three channels fully correlated; fewer when the noise is coloured (a sensor's low-pass
    filter: at 1 kHz behind a 40 Hz filter a 0.2 s window holds about 16 independent samples, not 200)."""
    if len(ratio) < 4 * m:
        return float(m - 1)
    q1, q3 = np.quantile(ratio, [0.25, 0.75])
    sd = (q3 - q1) / 1.349
    return float(np.clip(2.0 / sd**2, 1.0, m - 1)) if sd > 0 else float(m - 1)


@dataclass(frozen=True)
class RestDetection:
    """What :func:`detect_rests` found: ``intervals`` (start, end) sample ranges (end exclusive) of the rests kept;
    ``dropped`` the candidate rests it did not keep (``start_s``, ``end_s``: the quiet run widened by half a window
    at each end; ``reason``: ``"too short"`` or ``"too noisy"``; ``detail``); ``joined`` the gaps (``start_s``,
    ``end_s``) across which two rests were joined into one (the gyro quiet throughout: the accelerometer was
    disturbed — a tap — but nothing turned); the settings it used (``threshold`` per sensor) and the rest noise σ
    per channel (input units)."""

    intervals: list
    dropped: list
    joined: list
    rate_hz: float
    window_s: float
    threshold: dict
    min_rest_s: float
    noise: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """A JSON-ready summary (times in s)."""
        return {
            "rests_found": len(self.intervals),
            "rests": [[round(s / self.rate_hz, 4), round(e / self.rate_hz, 4)] for s, e in self.intervals],
            "dropped": [dict(d) for d in self.dropped],
            "joined": [dict(d) for d in self.joined],
            "window_s": round(self.window_s, 6),
            "static_threshold": self.threshold,
            "min_rest_s": self.min_rest_s,
            "noise_sigma": {k: [float(v) for v in s] for k, s in self.noise.items()},
        }

    def summary(self) -> str:
        """One line: how many rests, how many candidates dropped and why, with their times (:func:`rest_summary`)."""
        return rest_summary(self.to_json())


def rest_summary(report: dict, details: bool = True) -> str:
    """One line from :meth:`RestDetection.to_json`: rests found, candidates dropped (and, with ``details``, each
    one's start and end in s and its reason), rests joined."""
    s = (
        f"{report['rests_found']} rests found (window {report['window_s']:.3g} s, threshold "
        + ", ".join(f"{k} {v:.3g}" for k, v in report["static_threshold"].items())
        + f"× the rest noise variance, shortest {report['min_rest_s']:g} s); "
        f"{len(report['dropped'])} candidate rests dropped"
    )
    if report["dropped"] and details:
        s += ": " + "; ".join(
            f"{d['start_s']:.2f}–{d['end_s']:.2f} s {d['reason']} ({d['detail']})" for d in report["dropped"]
        )
    if report["joined"]:
        gaps = ", ".join(f"{d['start_s']:.2f}–{d['end_s']:.2f} s" for d in report["joined"])
        s += f"; {len(report['joined'])} rests joined across an accelerometer disturbance with the gyro quiet ({gaps})"
    return s


def quantum(x: np.ndarray) -> np.ndarray:
    """Per column of ``x`` (n, k), the smallest non-zero step between samples (the LSB of quantised data)."""
    d = np.abs(np.diff(np.asarray(x, dtype=float), axis=0))
    d = np.where(d > 0, d, np.inf)
    q = d.min(axis=0) if len(d) else np.full(x.shape[1], np.inf)
    return np.where(np.isfinite(q), q, 0.0)


def _noise_variance(v: np.ndarray, m: int, rest: np.ndarray | None, floor: np.ndarray) -> np.ndarray:
    """Per-channel variance of the rest noise from rolling variances ``v`` (n, 3) of ``m``-sample windows (scaled to
    be unbiased): the median window of the rest samples ``rest`` (or, on the first pass, the 10 % quantile of all
    windows, which lies among the rests when at least a tenth of the record rests), divided by the same quantile
    of χ²_{m−1}/(m−1); at least ``floor`` (the quantisation noise, LSB²/12: a sensor quieter than its LSB)."""
    q = 0.5 if rest is not None and rest.sum() >= m else 0.1
    sel = v[rest] if q == 0.5 else v
    level = np.quantile(sel, q, axis=0) * (m - 1) / tails.chi2_ppf(q, m - 1)
    return np.maximum(level, np.maximum(floor, 1e-300))


def _join_gyro_quiet(keep, ratio_gyro, rate_hz):
    """Join consecutive rests whose gap never lifts the gyro's windowed variance above the threshold: nothing
    turned between them (a tap disturbed the accelerometer), so they are one pose. Returns (rests, joined gaps)."""
    if ratio_gyro is None or not keep:
        return keep, []
    out, joined = [keep[0]], []
    for s, e in keep[1:]:
        ps, pe = out[-1]
        if np.all(ratio_gyro[pe:s] <= 1.0):
            out[-1] = (ps, e)
            joined.append({"start_s": pe / rate_hz, "end_s": s / rate_hz})
        else:
            out.append((s, e))
    return out, joined


def detect_rests(
    acc: np.ndarray,
    rate_hz: float,
    *,
    gyro: np.ndarray | None = None,
    window_s: float = WINDOW_S,
    threshold: float | None = None,
    min_rest_s: float = MIN_REST_S,
) -> RestDetection:
    """The rests of an IMU recording (module doc), with a report of the candidate rests it dropped.

    Args:
      acc: (n, 3) accelerometer samples (any unit), or None for a gyro alone; gyro: (n, 3) gyro samples (any unit),
        optional with an accelerometer.
      rate_hz: sample rate, Hz. window_s: variance window, s (at least 5 samples).
      threshold: a sample rests when the windowed variance of each sensor, averaged over its channels in units of
        each channel's rest noise variance, is at most this (default: :func:`default_threshold` of the rest windows'
        degrees of freedom, :func:`window_dof`, per sensor).
      min_rest_s: shortest rest kept, s, after trimming half a window at each end next to a move.
    """
    if acc is None and gyro is None:
        raise RecordError("the static detector needs the accelerometer or the gyro")
    n = len(acc if acc is not None else gyro)
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise RecordError(f"the static detector needs a positive sample rate, got {rate_hz!r} Hz")
    if not (np.isfinite(window_s) and window_s > 0):
        raise RecordError(f"the static detector's window must be a positive duration (s), got {window_s!r}")
    if not (np.isfinite(min_rest_s) and min_rest_s >= 0):
        raise RecordError(f"the shortest rest (--min-rest) must be a duration >= 0 s, got {min_rest_s!r}")
    if threshold is not None and not (np.isfinite(threshold) and threshold > 1):
        raise RecordError(
            f"the static threshold (--static-threshold) is a multiple of the rest noise variance and must exceed 1 "
            f"(the noise itself), got {threshold!r}"
        )
    m = window_samples(window_s, rate_hz)
    if n < 2 * m:
        raise RecordError(f"the static detector needs at least two windows ({2 * m} samples); the record has {n}")
    sensors = [(k, np.asarray(x, dtype=float)) for k, x in (("acc", acc), ("gyro", gyro)) if x is not None]
    var = {k: rolling_variance(x, m) * m / (m - 1) for k, x in sensors}
    floor = {k: quantum(x) ** 2 / 12.0 for k, x in sensors}
    rest, noise, thr, r = None, {}, {}, {}
    for _ in range(3):  # quietest windows first, then the median window of the rests found; converges in two
        for k, v in var.items():
            noise[k] = _noise_variance(v, m, rest, floor[k])
            r[k] = (v / noise[k]).mean(axis=1)
            dof = window_dof(r[k][rest], m) if rest is not None else m - 1.0
            thr[k] = default_threshold(dof) if threshold is None else float(threshold)
        ratio = np.max([r[k] / thr[k] for k in var], axis=0)  # in thresholds: at rest when ≤ 1
        rest = ratio <= 1.0
    ratio_gyro = r["gyro"] / thr["gyro"] if "gyro" in var else None
    trim = m // 2
    keep, dropped = [], []
    min_n = min_rest_s * rate_hz

    def trimmed(s, e):
        return (s + trim if s > 0 else s), (e - trim if e < n else e)

    for cs, ce in true_runs(ratio <= CANDIDATE_FACTOR):
        found, short = [], []
        for s, e in true_runs(rest[cs:ce]):
            s2, e2 = trimmed(cs + s, cs + e)
            if e2 - s2 >= min_n and e2 > s2:
                found.append((s2, e2))
            elif e2 > s2:
                short.append((s2, e2))
        keep += found
        if found or ce - cs < m // 2:  # quiet for less than half a window: a flicker at a move's edge, not a rest
            continue
        c2s, c2e = trimmed(cs, ce)
        if c2e - c2s < min_n:
            reason, detail = "too short", f"{max(c2e - c2s, 0) / rate_hz:.2f} s after trimming < {min_rest_s:g} s"
        elif short:
            longest = max(e - s for s, e in short)
            reason, detail = "too short", f"its quiet part lasts {longest / rate_hz:.2f} s < {min_rest_s:g} s"
        else:
            k = max(var, key=lambda k: float(np.median(r[k][cs:ce] / thr[k])))
            med = float(np.median(r[k][cs:ce]))
            reason, detail = "too noisy", f"{k} variance {med:.3g}× its rest noise > threshold {thr[k]:.3g}"
        span = max(cs - trim, 0) / rate_hz, min(ce + trim, n) / rate_hz  # the pause as the sensor saw it
        dropped.append({"start_s": span[0], "end_s": span[1], "reason": reason, "detail": detail})
    keep, joined = _join_gyro_quiet(sorted(keep), ratio_gyro, rate_hz)
    return RestDetection(
        intervals=[(int(s), int(e)) for s, e in keep],
        dropped=dropped,
        joined=joined,
        rate_hz=float(rate_hz),
        window_s=m / float(rate_hz),
        threshold={k: float(v) for k, v in thr.items()},
        min_rest_s=float(min_rest_s),
        noise={k: np.sqrt(v) for k, v in noise.items()},
    )


def static_intervals(acc: np.ndarray, rate_hz: float, **kw) -> list[tuple[int, int]]:
    """(start, end) sample ranges (end exclusive) of the rests of an IMU recording: :func:`detect_rests`'s
    intervals (keywords as there)."""
    return detect_rests(acc, rate_hz, **kw).intervals


def imutk_acc_model(params: np.ndarray, raw: np.ndarray) -> np.ndarray:
    """imu_tk's accelerometer model: a = T K (raw − b), T = [[1, −α_yz, α_zy], [0, 1, −α_zx], [0, 0, 1]],
    K = diag(s); ``params`` = (α_yz, α_zy, α_zx, s_x, s_y, s_z, b_x, b_y, b_z) (Tedaldi et al. eqs. 1–6)."""
    ayz, azy, azx = params[:3]
    t = np.array([[1.0, -ayz, azy], [0.0, 1.0, -azx], [0.0, 0.0, 1.0]])
    return (t @ np.diag(params[3:6]) @ (np.asarray(raw) - params[6:9]).T).T


def imutk_acc_jacobian(params: np.ndarray, raw: np.ndarray) -> np.ndarray:
    """Exact ∂|T K (raw − b)|/∂p (k, 9) of :func:`imutk_acc_model`'s magnitude at the rows ``raw`` (k, 3), per
    parameter unit (rad, -, raw): with z = raw − b, k = K z, c = T k and u = c/|c|, ∂|c|/∂p = uᵀ ∂c/∂p, where
    ∂c/∂α_yz = −k_y e_x, ∂c/∂α_zy = k_z e_x, ∂c/∂α_zx = −k_z e_y, ∂c/∂s_j = T e_j z_j and ∂c/∂b_j = −T e_j s_j
    (Tedaldi et al. eq. 6)."""
    p = np.asarray(params, dtype=float)
    t = np.array([[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]])
    z = np.asarray(raw, dtype=float) - p[6:9]
    k = z * p[3:6]
    c = k @ t.T
    u = c / np.linalg.norm(c, axis=1, keepdims=True)
    ut = u @ t  # uᵀ T e_j for each row
    return np.column_stack([-u[:, 0] * k[:, 1], u[:, 0] * k[:, 2], -u[:, 1] * k[:, 2], ut * z, -ut * p[3:6]])


def ellipsoid_accelerometer(pose_means: np.ndarray, g: float, scale0: float, bias0) -> np.ndarray:
    """Parameters of :func:`imutk_acc_model` such that every pose mean (rows, raw units) has magnitude ``g``.

    ``scale0`` (g per raw unit) and ``bias0`` (raw) start the least squares (scipy's Levenberg–Marquardt); at least
    9 poses are needed. A search that does not converge raises :class:`RecordError` with scipy's reason."""
    pose_means = np.asarray(pose_means, dtype=float)
    if len(pose_means) < 9:
        raise RecordError(
            f"the accelerometer needs at least 9 static poses for its 9 parameters; found {len(pose_means)}"
        )
    x0 = np.concatenate([np.zeros(3), np.full(3, scale0), np.asarray(bias0, dtype=float)])

    def resid(p):
        return np.linalg.norm(imutk_acc_model(p, pose_means), axis=1) - g

    sol = optimize.least_squares(
        resid, x0, jac=lambda p: imutk_acc_jacobian(p, pose_means), method="lm", x_scale="jac"
    )  # the exact Jacobian: one residual evaluation per step instead of ten
    if not sol.success:  # never a calibration from a search that stopped short
        raise RecordError(f"the accelerometer's ellipsoid fit did not converge ({sol.message}); check --acc-unit")
    return sol.x
