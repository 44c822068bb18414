"""The covariance of static-position means (NoiseSpec.mean_covariance) against double integrals, the 1/f spectrum,
brute-force sums and a Monte Carlo of the simulator's own processes; the design's Fisher information built on it;
and the Monte Carlo study's GLS fit under coloured noise (coverage)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import jax
import numpy as np
import pytest
from scipy import integrate

from gyrojax.montecarlo.results import summarize
from gyrojax.montecarlo.runner import run_study
from gyrojax.montecarlo.study import study_from_dict
from gyrojax.noise import processes
from gyrojax.noise.meancov import flicker_poles, flicker_spectrum, gm_mean_covariance, rw_mean_covariance
from gyrojax.noise.spec import BI_FACTOR, NoiseModelError, NoiseSpec, gauss_markov_avar
from gyrojax.physics.model import Model
from gyrojax.planning import fisher

START = np.array([0.0, 130.0, 300.0])
SPAN = np.array([100.0, 140.0, 60.0])


def _dblquad(kernel):
    """(1/T_a T_b) ∫_a ∫_b kernel(t, s) ds dt over the intervals START/SPAN, by scipy."""
    n = len(START)
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            v, _ = integrate.dblquad(
                lambda s, t: kernel(t, s), START[i], START[i] + SPAN[i], START[j], START[j] + SPAN[j]
            )
            out[i, j] = v / (SPAN[i] * SPAN[j])
    return out


def test_gauss_markov_and_random_walk_against_double_integrals():
    tau = 50.0
    gm = _dblquad(lambda t, s: math.exp(-abs(t - s) / tau))
    np.testing.assert_allclose(np.asarray(gm_mean_covariance(START, SPAN, 1.0, tau)), gm, rtol=1e-7)
    rw = _dblquad(lambda t, s: min(t, s)) / 3600.0  # K = 1 deg/h/√h: Cov r(t) r(s) = min(t, s)/3600 (deg/h)²
    np.testing.assert_allclose(np.asarray(rw_mean_covariance(START, SPAN, 1.0)), rw, rtol=1e-7)


def test_sampled_forms_against_sums_over_the_samples():
    dt, tau = 10.0, 25.0
    ts = [s + dt * np.arange(int(round(T / dt))) for s, T in zip(START, SPAN)]
    gm = np.array([[np.mean(np.exp(-np.abs(a[:, None] - b[None, :]) / tau)) for b in ts] for a in ts])
    rw = np.array([[np.mean(np.minimum(a[:, None], b[None, :])) for b in ts] for a in ts]) / 3600.0
    np.testing.assert_allclose(np.asarray(gm_mean_covariance(START, SPAN, 1.0, tau, dt)), gm, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(rw_mean_covariance(START, SPAN, 1.0, dt)), rw, rtol=1e-12)


def test_flicker_poles_reproduce_the_spectral_integral_and_the_allan_floor():
    b, band = 1.0, (1.0, 1e4)
    # Cov(mean_a, mean_b) = 2∫_0^∞ S(f) sinc_a sinc_b cos(2πf(c_a − c_b)) df of the two-sided 1/f spectrum
    cen = START + SPAN / 2.0

    def spectral(i, j):
        def g(u):  # f = e^u
            f = math.exp(u)
            h = np.sinc(f * SPAN[i]) * np.sinc(f * SPAN[j]) * math.cos(2 * math.pi * f * (cen[i] - cen[j]))
            return 2.0 * float(flicker_spectrum(f, b, band)) * h * f

        return integrate.quad(g, math.log(1e-9), math.log(10.0), limit=800)[0]

    exact = np.array([[spectral(i, j) for j in range(3)] for i in range(3)])
    cov = np.asarray(NoiseSpec(bias_instability=b, flicker_band=band).mean_covariance(START, SPAN))
    np.testing.assert_allclose(cov, exact, rtol=5e-3)
    wide = flicker_poles(b, (1e-2, 1e6))
    taus = np.geomspace(1.0, 1e4, 9)
    floor = sum(gauss_markov_avar(taus, s, t) for s, t in wide)
    np.testing.assert_allclose(floor, (BI_FACTOR * b) ** 2, rtol=2e-2)  # IEEE 952 C.1: σ = 0.664 B


@pytest.mark.slow
def test_covariance_against_a_monte_carlo_of_the_simulator():
    """The simulator's white + quantization + GM + RW (each from its own generator) on a positions time line with
    gaps: the sample covariance of the run means within its sampling error (4 σ of a covariance element,
    Var ŝ_ij = (Σ_ii Σ_jj + Σ_ij²)/n for Gaussian means; quantisation's uniform angles are near enough)."""
    dt = 5.0
    spec = NoiseSpec(white=0.02, quantization=20.0, gauss_markov=((0.1, 60.0),), random_walk=0.3)
    starts, spans = np.array([0.0, 130.0, 300.0, 420.0]), np.array([100.0, 140.0, 90.0, 60.0])
    t = np.concatenate([s + dt * np.arange(int(T / dt)) for s, T in zip(starts, spans)])
    run = np.concatenate([np.full(int(T / dt), k) for k, T in enumerate(spans)])
    n = 6000
    keys = jax.random.split(jax.random.PRNGKey(3), n)
    x = np.asarray(jax.jit(jax.vmap(lambda k: processes.simulate(spec, k, t, dt)))(keys))
    means = np.stack([x[:, run == k].mean(axis=1) for k in range(len(spans))], axis=1)
    emp = np.cov(means, rowvar=False)
    cov = np.asarray(spec.mean_covariance(starts, spans, sample_s=dt))
    tol = 4.0 * np.sqrt((np.outer(np.diag(cov), np.diag(cov)) + cov**2) / n)
    assert np.all(np.abs(emp - cov) < tol), (emp - cov) / tol
    assert cov[0, 1] != 0 and cov[0, 3] != 0  # the positions are correlated (quantisation, GM, RW)


def test_static_fisher_reduces_to_the_independent_weights():
    model = Model.of(("D_F", "D_I", "D_O", "D_S"))
    tab = fisher.Table.two_axis()
    ang = np.deg2rad(np.array([[0, 0], [90, 0], [180, 90], [270, 45], [45, 180], [135, 270]], float))
    dwell = np.array([600.0, 900.0, 1200.0, 600.0, 900.0, 1500.0])
    rows = np.asarray(fisher.position_rows(model, tab, ang))
    old = lambda nz: np.einsum("cnp,n,cnq->pq", rows, 1.0 / np.asarray(nz.mean_variance(dwell)), rows)  # noqa: E731
    white = NoiseSpec(white=0.01)
    np.testing.assert_allclose(np.asarray(fisher.static_fisher(model, tab, ang, dwell, white)), old(white), rtol=1e-13)
    short = NoiseSpec(white=0.01, gauss_markov=((0.02, 2.0),))  # τ ≪ dwell and gap: the old approximation
    new = np.asarray(fisher.static_fisher(model, tab, ang, dwell, short))
    np.testing.assert_allclose(new, old(short), rtol=1e-6)
    slow = NoiseSpec(white=0.01, gauss_markov=((0.02, 600.0),))  # τ ~ dwell: correlated positions, not the old
    assert not np.allclose(np.asarray(fisher.static_fisher(model, tab, ang, dwell, slow)), old(slow), rtol=1e-2)


def test_terms_without_a_covariance_of_means_are_refused_by_name():
    for spec, word in (
        (NoiseSpec(white=0.01, rate_ramp=0.1), "rate_ramp"),
        (NoiseSpec(white=0.01, bias_instability=0.1), "flicker_band"),
        (NoiseSpec(white=0.01, ar=(0.5,), dt_s=1.0), "AR"),
    ):
        with pytest.raises(NoiseModelError, match=f"nm.json: .*{word}"):
            spec.mean_covariance(START, SPAN, where="nm.json")


STUDY = {
    "plan": "multiposition",
    "plan_options": {"dt_s": 10},
    "terms": ["D_F", "D_I", "D_O"],
    "priors": {"D_F": {"normal": [1, 0.1]}},
    "draws": 300,
}


@pytest.mark.slow
def test_monte_carlo_gls_coverage_under_coloured_noise():
    """300 draws under white + GM + RW + quantization: the GLS of the position means covers θ at ±2σ̂ as often as
    0.9545 within 4 binomial σ (±0.048); the white-noise OLS σ̂ of before covered D_F in about half the draws."""
    noise = NoiseSpec(white=0.01, gauss_markov=((0.05, 300.0),), random_walk=0.02, quantization=2.0)
    res = run_study(replace(study_from_dict(STUDY), noise=noise))
    summ = summarize(res)
    assert set(summ["fit"]) == {"gls-position-means"}
    tol = 4.0 * math.sqrt(0.9545 * 0.0455 / len(res.draw))
    assert np.all(np.abs(summ["cover_2sigma"] - 0.9545) < tol), summ


def test_cli_design_and_mc_take_a_flicker_and_random_walk_model(tmp_path, capsys):
    from gyrojax.cli.app import main

    nm = tmp_path / "nm.json"
    NoiseSpec(white=0.01, bias_instability=0.01, flicker_band=(10.0, 3000.0), random_walk=0.01).save(nm)
    common = ["--terms", "D_F,D_I,D_O", "--positions", "6", "--hours", "1", "--starts", "1"]
    common += ["--adam-steps", "20", "--lbfgs-steps", "0", "--json", "--noise-model"]
    assert main(["design", *common, str(nm), "--out", str(tmp_path / "plan.json")]) == 0
    assert json.loads(capsys.readouterr().out)["design"]["positions"]
    ramp = tmp_path / "ramp.json"
    NoiseSpec(white=0.01, rate_ramp=0.1).save(ramp)
    assert main(["design", *common, str(ramp), "--out", str(tmp_path / "p2.json")]) == 2
    assert "ramp.json: rate_ramp" in capsys.readouterr().err
