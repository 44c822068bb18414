"""The servo table's angle readout noise: what a quantised angle record says about its own readout.

A servo record's measurement is the read angle's increment over each sample interval (Hu 3-59). The readout adds a
white angle error e_k to every read angle (Hu 5-51: the Inductosyn's quantisation and its within-pitch electrical
error), so the increments carry e_{k+1} − e_k beside the rate noise integrated over the interval: MA(1)-correlated
increments, lag-1 correlation −σ_e²/(σ_w²Δ² + 2σ_e²), which a white or Gauss–Markov rate model misreads (as colour,
and as standard errors 25 % too wide on a 0.18″ readout at 10 s).

A readout quantised at q leaves every angle a multiple of q: :func:`angle_quantum` finds q from the angles alone
(the second differences of a table turning smoothly are small multiples of it), and a uniform rounding error has
variance q²/12 (Widrow). In the measurement's unit the readout's error over the interval is ε = e/Δ, 1 arcsec/s =
1 deg/h, so σ_q² = q²/(12 Δ²) (deg/h)² with q in arcsec and Δ in s (:func:`readout_variance`). A record whose angles
are not on a grid gets none (its readout noise, if any, is then part of what the rate noise model sees).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from gyrojax.optimize import minimize_scalar

GRID_TOL = 0.02
"""Largest |angle/q − round(angle/q)| (in steps) for every increment of a record quantised at q."""
MIN_STEP_ARCSEC = 1e-4
"""Smallest quantum taken for a readout step (arcsec): below it, the record's own decimal digits are the grid."""


def angle_quantum(angles_deg: np.ndarray) -> float | None:
    """The step q (arcsec) of a quantised angle readout, or None when the angles (deg) are not on a grid.

    Candidate: the smallest non-zero |second difference| of the angles (a table turning smoothly changes its
    increment by a few steps from one sample to the next); accepted when every increment is a whole number of it
    within :data:`GRID_TOL` of a step (at least ten non-zero second differences needed).
    """
    a = np.asarray(angles_deg, dtype=float) * 3600.0
    if a.size < 4 or not np.all(np.isfinite(a)):
        return None
    inc = np.diff(a)
    d2 = np.abs(np.diff(inc))
    floor = max(MIN_STEP_ARCSEC, 1e-12 * float(np.max(np.abs(a))))
    live = d2[d2 > floor]
    if live.size < 10:
        return None
    q = float(np.min(live))
    # q may be a multiple of the step when the rate is very steady: the smallest second difference that is not a
    # whole number of the candidate refines it
    for _ in range(4):
        frac = np.abs(live / q - np.round(live / q))
        off = live[frac > GRID_TOL]
        if not off.size:
            break
        q = float(np.min(np.abs(off - q * np.floor(off / q + 0.5)))) or q
    if q < floor:
        return None
    k = inc / q
    if np.max(np.abs(k - np.round(k))) > GRID_TOL:
        return None
    return q


def readout_variance(angles_deg: np.ndarray, interval_s: float) -> float:
    """σ_q² (deg/h)² of the readout's error over a sample interval of ``interval_s`` (s), q²/(12 Δ²) for angles
    (deg) quantised at q arcsec (:func:`angle_quantum`); 0 when the angles are not on a grid."""
    q = angle_quantum(angles_deg)
    if q is None or not interval_s > 0:
        return 0.0
    return q * q / 12.0 / (interval_s * interval_s)


def record_readout_variance(record, interval_s: float) -> float:
    """σ_q² (deg/h)² of a servo record's readout (:func:`readout_variance` of its servo axis' angles); 0 for the other
    modes, whose measurement is not an angle increment."""
    if record.mode != "servo" or record.servo_axis_index is None:
        return 0.0
    return readout_variance(record.angles_deg[:, record.servo_axis_index], interval_s)


def white_beside_readout(r, design, labels, times, gm):
    """White rate noise (a Gauss–Markov term of σ 0) beside the readout noise of ``gm`` (a white + Gauss–Markov
    :class:`gyrojax.noise.spec.NoiseSpec` with ``readout_var``): σ_w² at its REML optimum (a bounded 1-D search in
    log σ_w²), the alternative against which a fitted drift is kept or dropped. ``r`` and the variances in one unit
    ((deg/h)²)."""
    from gyrojax.noise.whiten import gm_reml

    tau, g, w = gm.whitening_theta()
    total = max(g + w, 1e-300)

    def spec(u):
        return replace(
            gm, white=math.sqrt(total * np.exp(u) * gm.dt_s) / 60.0, gauss_markov=((0.0, tau),), cov=(), cov_names=()
        )

    sol = minimize_scalar(lambda u: gm_reml(r, design, labels, times, spec(u)), np.log(1e-3), np.log(1e2), xatol=1e-4)
    return spec(float(sol.x))
