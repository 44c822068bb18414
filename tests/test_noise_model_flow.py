"""Every model ``gyrojax noise`` can choose reaches ``design`` and ``mc`` through --noise-model (issue 25): the
variance of a static mean with quantization against a Monte Carlo of the angle-difference rate, a two-Gauss–Markov
model in a study file and back, and the CLI taking such a model."""

import json

import numpy as np
import pytest

from gyrojax.cli.app import main
from gyrojax.montecarlo.study import Study, study_from_dict
from gyrojax.noise.spec import NoiseModelError, NoiseSpec

TWO_GM = NoiseSpec(white=0.003, quantization=0.05, gauss_markov=((0.02, 60.0), (0.01, 900.0)), dt_s=0.5)


def test_mean_variance_with_quantization_against_monte_carlo():
    """Rate y_k = (e_{k+1} − e_k)/Δt, e white of std Q arcsec (= deg/h·s): the variance of the mean over T s, from
    4000 draws, matches 2Q²/T² within 3 binomial-χ² standard errors (√(2/draws) relative)."""
    q, dt, n, draws = 2.0, 0.1, 50, 4000
    e = np.random.default_rng(1).normal(0.0, q, (draws, n + 1))
    y = np.diff(e, axis=1) / dt
    v = float(np.var(y.mean(axis=1)))
    expect = float(NoiseSpec(quantization=q).mean_variance(n * dt))
    assert v == pytest.approx(expect, rel=3 * np.sqrt(2 / draws))
    with pytest.raises(NoiseModelError, match="random_walk"):
        NoiseSpec(white=0.1, random_walk=1.0).mean_variance(10.0)


def test_study_round_trips_a_two_gauss_markov_model():
    st = Study(plan="multiposition", terms=("D_F",), priors={"D_F": 0.1}, noise=NoiseSpec.simulation_terms(TWO_GM))
    back = study_from_dict(json.loads(json.dumps(st.to_dict())))
    assert back.noise.gauss_markov == TWO_GM.gauss_markov and back.noise.quantization == 0.05
    assert back.noise.white == 0.003 and back.noise.cov == ()
    one = Study(plan="multiposition", terms=("D_F",), noise=NoiseSpec(white=0.01, gauss_markov=((0.02, 60.0),)))
    assert one.to_dict()["noise"] == {"white": 0.01, "gauss_markov": [0.02, 60.0]}  # still a truth dict


def test_design_takes_a_two_gauss_markov_model(tmp_path, capsys):
    model = tmp_path / "noise.json"
    model.write_text(json.dumps({"model": TWO_GM.to_json()}))
    out = tmp_path / "plan.json"
    args = ["design", "--out", str(out), "--positions", "10", "--hours", "1", "--noise-model", str(model)]
    rc = main(args + ["--starts", "1", "--adam-steps", "20", "--lbfgs-steps", "5", "--json"])
    assert rc == 0 and out.exists()
    # a rate ramp is a deterministic drift, not noise a plan's means average: refused by name, nothing written
    ramp = tmp_path / "ramp.json"
    ramp.write_text(json.dumps({"model": NoiseSpec(white=0.003, rate_ramp=0.1, dt_s=0.5).to_json()}))
    rc = main(["design", "--out", str(tmp_path / "p2.json"), "--noise-model", str(ramp)])
    assert rc == 2 and "rate_ramp" in capsys.readouterr().err and not (tmp_path / "p2.json").exists()


def test_design_refuses_fewer_positions_than_coefficients(tmp_path, capsys):
    """8 positions of a one-output gyro give 8 means for the 9 SDF coefficients: F is singular for every plan (its
    log-determinant is round-off, which one CPU climbs to NaN and another to a meaningless plan), so no plan is
    written and the message names the count."""
    out = tmp_path / "plan.json"
    rc = main(["design", "--out", str(out), "--positions", "8", "--hours", "1", "--starts", "1", "--adam-steps", "2"])
    err = capsys.readouterr().err
    assert rc == 2 and not out.exists()
    assert "8 independent means for the 9 coefficients" in err and "at least 9 positions" in err
