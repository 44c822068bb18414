"""Monte Carlo coverage of the triad fit itself (:func:`gyrojax.inference.triad.fit_triad`, its noise estimated):
simulated sessions, each fitted, the fraction of coefficients inside θ̂ ± 2σ̂ (0.9545 for an honest σ̂). A loop over
sessions, since the fit under test is numpy; the vmapped study of a triad design is
:mod:`gyrojax.montecarlo.triad`. Used by the tests and ``benchmarks/bench_triad.py`` (400 draws in three settings).
"""

from __future__ import annotations

import numpy as np

from gyrojax.inference.triad import fit_triad
from gyrojax.montecarlo.triad import LATITUDE, mems_truth, with_vertical_earth_rate
from gyrojax.simulation.triad import simulate_ferraris, simulate_multiposition

EARTH_MODES = ("latitude unknown", "latitude known", "off")
"""How a simulated session with moves holds the Earth rate: in the motion with the latitude unknown to the fit
(``null``) or given to it, or out of the motion and the record."""


def ferraris_coverage(draws: int, latitude_known: bool = True, angle_std_deg: float = 0.0, truth=None) -> np.ndarray:
    """Inside-±2σ indicator, shape (draws, 21), of simulated Ferraris sessions fitted by the triad fit.

    ``latitude_known``: the fit is told the site latitude (:data:`~gyrojax.montecarlo.triad.LATITUDE`, deg), else
    not (D_I then holds the vertical Earth rate, deg/h/g); ``angle_std_deg``: the hand's angle error, deg, simulated
    and declared."""
    truth = truth or mems_truth()
    want = dict(truth) if latitude_known else with_vertical_earth_rate(truth)
    hits = []
    for seed in range(draws):
        rec = simulate_ferraris(
            truth, seed=seed, angle_std_deg=angle_std_deg, latitude_deg=LATITUDE, fit_latitude=latitude_known
        )
        res = fit_triad(rec)
        v, s = res.values, res.stds
        hits.append([abs(v[k] - want[k]) <= 2 * s[k] for k in truth])
    return np.array(hits)


def multiposition_coverage(
    draws: int,
    poses: int = 12,
    truth=None,
    earth: str = "latitude unknown",
    first_seed: int = 0,
    move_error_deg: float = 0.0,
    bias_step_dph: float = 0.0,
) -> np.ndarray:
    """Inside-±2σ indicator, shape (draws, 21), of simulated imu_tk-style sessions (``poses`` static poses of random
    attitude, gravity-to-gravity moves between them) fitted by the triad fit, the Earth rate as ``earth`` says
    (:data:`EARTH_MODES`); with the latitude unknown the g-terms are compared with the truth plus the vertical Earth
    rate they absorb ((Ω sin φ / |a|) S, deg/h/g). Seeds ``first_seed`` … ``first_seed + draws − 1``;
    ``move_error_deg`` and ``bias_step_dph`` plant what the white-noise model leaves out (hand-move angle errors,
    bias steps; :func:`~gyrojax.simulation.triad.simulate_multiposition`)."""
    if earth not in EARTH_MODES:
        raise ValueError(f"earth must be one of {EARTH_MODES}, got {earth!r}")
    truth = truth or mems_truth()
    want = with_vertical_earth_rate(truth) if earth == "latitude unknown" else dict(truth)
    kw = {"earth_rate": earth != "off", "fit_latitude": earth == "latitude known", "latitude_deg": LATITUDE}
    kw.update(move_error_deg=move_error_deg, bias_step_dph=bias_step_dph)
    hits = []
    for seed in range(first_seed, first_seed + draws):
        res = fit_triad(simulate_multiposition(truth, poses=poses, seed=seed, **kw))
        hits.append([abs(res.values[q] - want[q]) <= 2 * res.stds[q] for q in truth])
    return np.array(hits)
