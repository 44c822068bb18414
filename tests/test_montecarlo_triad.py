"""Monte Carlo studies of MEMS gyro triads through the vmapped pipeline (:mod:`gyrojax.montecarlo.triad`).

Each draw is a hand session (a heading, the gyro's and accelerometer's white noise, each known-angle turn's angle
error) fitted with the noise known, as :func:`gyrojax.inference.triad.fit_triad` weighs the rows. Checked against
what nobody here wrote: the ±2σ̂ coverage of a normal estimate (0.9545) and the binomial spread of a coverage count;
and against the design's Fisher information (:mod:`gyrojax.planning.triad_fisher`, itself checked against the fit's
own derivatives): the stated σ̂ and the spread of the estimates over the draws both equal the predicted σ.
"""

from __future__ import annotations

import math

import jax
import numpy as np
import pytest
from scipy import stats

from gyrojax.montecarlo.results import summarize
from gyrojax.montecarlo.runner import run_study
from gyrojax.montecarlo.study import Study, StudyError, study_from_dict
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.physics.triad import channel_names
from gyrojax.planning import triad_protocol as tpr
from gyrojax.planning.triad_fisher import TriadNoise

TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")
PRIORS = {k: {"normal": [0.0, abs(v)]} for k, v in mems_truth().items()}  # MEMS-sized, per channel


def _coverage_bounds(n: int) -> tuple[float, float]:
    """The two-sided 99.9 % binomial interval of the ±2σ coverage fraction of n effectively independent checks."""
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, 0.9545) / n
    return lo, hi


def test_ferraris_study_is_honest_with_turn_angle_errors():
    """300 Ferraris sessions, a 0.5° angle error per hand turn, latitude known: the ±2σ̂ coverage of 21 coefficients
    (at most 4 effectively independent groups per channel: n = 300 × 21/4) and the sd of (θ̂ − θ)/σ̂ near 1."""
    opts = {"latitude_deg": 49.6, "fit_latitude": True, "angle_std_deg": 0.5}
    study = Study("ferraris", TERMS, PRIORS, noise={"white": 1.2}, draws=300, plan_options=opts, instrument="imu-triad")
    res = run_study(study)
    s = summarize(res)
    assert res.fit == "gls-triad-known-noise" and res.estimate.shape == (300, 21)
    lo, hi = _coverage_bounds(300 * 21 // 4)
    assert lo <= s["cover_2sigma"].mean() <= hi, s["cover_2sigma"].mean()
    # sd of z from 300 draws: relative sampling sd 1/√(2 × 299) = 0.041 per coefficient
    assert np.all(np.abs(s["std_z"] - 1.0) < 4 * 0.041), s["std_z"].round(3).tolist()


@pytest.fixture(scope="module")
def protocol():
    noise = TriadNoise(arw=1.2, acc_noise_g=0.002, rate_hz=50.0, placement_deg=0.5)
    return tpr.design_protocol(TERMS, 7, 5.0, "D", noise, starts=2, steps=160, seed=1, turn_pairs=(0, 1))


@pytest.mark.slow
def test_design_prediction_is_the_monte_carlo_of_its_protocol(protocol):
    """The designed protocol's steps as a study (Earth rate on, latitude unknown, random heading; known-angle turns
    with √2 × 0.5° angle errors, moves): the σ̂ the draws state equals the design's predicted σ within 3 % for every
    coefficient (the same rows and noise, from the fit's data path against the design's closed form), and the sd of
    the estimates over 240 draws equals it within the sampling error: the mean of (sd / σ)² over 21 coefficients
    within 4 × √(2/239) / √(21/4) of 1."""
    noise = protocol.noise
    opts = {
        "steps": protocol.steps,
        "start_attitude": np.asarray(protocol.start_attitude).tolist(),
        "rate_hz": noise.rate_hz,
        "placement_deg": noise.placement_deg,
        "acc_noise_g": noise.acc_noise_g,
        "latitude_deg": 49.6,
        "fit_latitude": False,
    }
    study = Study(
        "protocol",
        TERMS,
        PRIORS,
        noise={"white": noise.arw},
        draws=240,
        plan_options=opts,
        seed=3,
        instrument="imu-triad",
    )
    res = run_study(study)
    model = tpr.triad_model(TERMS)
    names = list(channel_names(model))
    pred = np.array([tpr.sigma(protocol.fisher(), model)[k] for k in names])
    assert list(res.fit_names) == names
    stated = res.std.mean(axis=0)
    assert np.all(np.abs(stated / pred - 1.0) < 0.03), np.round(stated / pred, 3)
    err = res.estimate - res.truth_of_fit()
    v = err.var(axis=0, ddof=1) / pred**2
    tol = 4.0 * math.sqrt(2.0 / (240 - 1)) / math.sqrt(21.0 / 4.0)
    assert abs(v.mean() - 1.0) < tol, (v.mean(), tol, np.round(np.sqrt(v), 2))


def test_triad_study_file_round_trips_and_errors_name_the_key():
    study = Study(
        "multiposition",
        TERMS,
        {"D_F[x]": 3.0, "sf_error": {"uniform": [-100, 100]}},
        noise={"white": 1.2},
        draws=5,
        plan_options={"poses": 8},
        instrument="imu-triad",
    )
    d = study.to_dict()
    assert d["instrument"] == "imu-triad" and study_from_dict(d) == study
    assert "instrument" not in Study("tumble", ("D_F",)).to_dict()  # turntable study files stay as they were
    with pytest.raises(StudyError, match="'plan'.*imu-triad plans: ferraris, multiposition, protocol"):
        study_from_dict({**d, "plan": "tumble"})
    with pytest.raises(StudyError, match="'instrument'"):
        study_from_dict({**d, "instrument": "ring-laser"})
    with pytest.raises(StudyError, match="'terms'.*turntable"):
        study_from_dict({**d, "terms": ["D_F", "table_tilt"]})
    with pytest.raises(StudyError, match="'priors.D_F\\[w\\]'"):
        run_study(Study("ferraris", TERMS, {"D_F[w]": 1.0}, noise={"white": 1.2}, draws=2, instrument="imu-triad"))
    with pytest.raises(StudyError, match="'noise'.*white"):
        run_study(Study("ferraris", TERMS, noise={"random_walk": 0.1}, draws=2, instrument="imu-triad"))


def test_a_draw_is_what_the_triad_fit_finds_on_its_record():
    """A draw's session written as a record and fitted by fit_triad told the same white noise: the estimates within
    0.25 σ̂ of the draw's own fit and σ̂ within 5 % (fit_triad's regressors carry the accelerometer's noise and its
    covariance is taken at the fitted S; the draw's at the noise-free session and S = I)."""
    from gyrojax.inference.triad import fit_triad
    from gyrojax.montecarlo.pipeline import build_pipeline

    opts = {"latitude_deg": 49.6, "fit_latitude": True, "angle_std_deg": 0.5}
    study = Study("ferraris", TERMS, PRIORS, noise={"white": 1.2}, draws=1, plan_options=opts, instrument="imu-triad")
    pipe = build_pipeline(study)
    draw = {k: np.asarray(v) for k, v in jax.jit(pipe.draw)(0).items()}
    q = np.full(3, float(pipe.arrays["gyro_sd"]) ** 2)
    fit = fit_triad(pipe.draw_record(0), list(TERMS), noise_q=q, components=False)
    est = np.array([fit.values[k] for k in pipe.fit_model.coefficient_names])
    std = np.array([fit.stds[k] for k in pipe.fit_model.coefficient_names])
    assert np.all(np.abs(est - draw["estimate"]) < 0.25 * draw["std"]), np.round((est - draw["estimate"]) / std, 3)
    assert np.all(np.abs(std / draw["std"] - 1.0) < 0.05), np.round(std / draw["std"], 3)
