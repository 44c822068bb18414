"""Monte Carlo of hand calibrations of a MEMS gyro triad: is the triad fit's σ honest?

Simulated Ferraris sessions (:func:`gyrojax.simulation.triad.simulate_ferraris`) are fitted by
:func:`gyrojax.inference.triad.fit_triad`; the fraction of coefficients inside θ̂ ± 2σ̂ should be 0.9545
(``benchmarks/bench_triad.py`` runs 400 draws in three settings).
"""

from __future__ import annotations

import math

import numpy as np

from gyrojax import units
from gyrojax.inference.triad import fit_triad
from gyrojax.physics.frames import site_gravity
from gyrojax.simulation.triad import simulate_ferraris, simulate_multiposition

LATITUDE = 49.6
"""Latitude of the simulated site, deg (its gravity is the simulations' default, the normal gravity there)."""


def with_vertical_earth_rate(truth: dict) -> dict:
    """The coefficients a fit with the latitude unknown should find: with the site's vertical Earth rate
    Ω sin φ u = (Ω sin φ / |a|) a left in the g-terms (deg/h/g), through each channel's scale factor and
    misalignment (at :data:`LATITUDE`, |a| its normal gravity)."""
    k = units.OMEGA_IE_DEG_PER_H * math.sin(math.radians(LATITUDE)) / (site_gravity(LATITUDE) / units.G0)
    want = dict(truth)
    for ch in "xyz":
        want[f"D_I[{ch}]"] += k * (1.0 + truth.get(f"E_SF[{ch}]", 0.0) * units.PPM)
        want[f"D_O[{ch}]"] += k * truth.get(f"M_O[{ch}]", 0.0) * units.ARCSEC
        want[f"D_S[{ch}]"] += k * truth.get(f"M_S[{ch}]", 0.0) * units.ARCSEC
    return want


def mems_truth(seed: int = 42) -> dict:
    """Per-channel MEMS-sized errors: bias ~500 deg/h, g-sensitivity ~30 deg/h/g, SF ~1 %, misalignment ~3000″."""
    rng = np.random.default_rng(seed)
    out = {}
    for ch in "xyz":
        out.update(
            {
                f"D_F[{ch}]": rng.normal(0, 500),
                f"D_I[{ch}]": rng.normal(0, 30),
                f"D_O[{ch}]": rng.normal(0, 30),
                f"D_S[{ch}]": rng.normal(0, 30),
                f"E_SF[{ch}]": rng.normal(0, 1e4),
                f"M_O[{ch}]": rng.normal(0, 3000),
                f"M_S[{ch}]": rng.normal(0, 3000),
            }
        )
    return out


def ferraris_coverage(draws: int, latitude_known: bool = True, angle_std_deg: float = 0.0, truth=None) -> np.ndarray:
    """Inside-±2σ indicator, shape (draws, 21), of simulated Ferraris sessions fitted by the triad fit.

    ``latitude_known``: the fit is told the site latitude (:data:`LATITUDE`, deg), else not (D_I then holds the
    vertical Earth rate, deg/h/g); ``angle_std_deg``: the hand's angle error, deg, simulated and declared."""
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


EARTH_MODES = ("latitude unknown", "latitude known", "off")
"""How a simulated session with moves holds the Earth rate: in the motion with the latitude unknown to the fit
(``null``) or given to it, or out of the motion and the record."""


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
