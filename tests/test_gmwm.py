"""GMWM noise models: recovery of simulated sums of processes within their stated uncertainty, model selection,
AVLR, adequacy, JSON round trip, the mappings onto GMNoise / noise dicts / design.Noise, and a real MEMS smoke test."""

import json
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from gyrojax.noise import allan, gmwm
from gyrojax.noise import wavelet as wv

DT = 0.01
SPEC = gmwm.ModelSpec(white=True, random_walk=True, n_gm=1)
TRUE = {"white": 0.05, "random_walk": 10.0, "gm1_sigma": 2.0, "gm1_tau": 5.0}
"""White 0.05 deg/√h, RRW 10 deg/h/√h, GM 2 deg/h with T = 5 s, sampled at 100 Hz: each process dominates a band."""


def _components(spec, values, dt):
    p = gmwm.latent_parameters(spec, jnp.asarray(gmwm.theta_from_natural(spec, values, dt)))
    out = {k: float(p[k]) for k in ("white", "quantization", "random_walk") if getattr(spec, k)}
    out["gauss_markov"] = [(float(s), float(a)) for s, a in zip(p["gm_var"], p["gm_rate"])]
    return out


def _series(n, seed, spec=SPEC, values=TRUE, dt=DT):
    return np.asarray(wv.simulate_components(jax.random.PRNGKey(seed), n, _components(spec, values, dt)))


@pytest.fixture(scope="module")
def long_fit():
    y = _series(2**20, 11)
    return y, gmwm.fit_gmwm(y, DT, model=SPEC)


def test_recovers_every_parameter(long_fit):
    _, m = long_fit
    par = m.parameters()
    for k, v in TRUE.items():
        assert abs(par[k]["value"] - v) < 3 * par[k]["std"], (k, par[k], v)
        lo, hi = par[k]["ci95"]
        assert lo < par[k]["value"] < hi
    # and the stated uncertainty is small enough to mean something
    assert par["white"]["std"] / TRUE["white"] < 0.01 and par["gm1_tau"]["std"] / TRUE["gm1_tau"] < 0.25
    assert 0.001 < m.p_value <= 1.0


def test_theta_round_trip():
    th = gmwm.theta_from_natural(SPEC, TRUE, DT)
    vals, names, _ = gmwm.natural_parameters(SPEC, jnp.asarray(th), DT)
    assert dict(zip(names, np.asarray(vals))) == pytest.approx(TRUE, rel=1e-12)


def test_selection_finds_the_simulated_sum(long_fit):
    y, _ = long_fit
    m = gmwm.fit_gmwm(y, DT)
    assert m.spec == SPEC, m.selection
    wic = {r["model"]: r["wic"] for r in m.selection}
    assert wic["white+gm+rw"] < wic["white+gm"] - 10 and wic["white+gm+rw"] < wic["white+rw"] - 10


def test_selection_keeps_white_noise_white():
    y = np.asarray(4.0 * jax.random.normal(jax.random.PRNGKey(2), (2**16,)))
    m = gmwm.fit_gmwm(y, 1.0)
    # whatever else is admitted carries a negligible share: the model ADEV is the white one within 2 %
    taus = np.array([1.0, 16.0, 512.0])
    np.testing.assert_allclose(m.adev(taus), 4.0 / np.sqrt(taus), rtol=0.03)


def test_avlr_consistent_and_wider(long_fit):
    y, g = long_fit
    a = gmwm.fit_gmwm(y, DT, model=SPEC, method="avlr")
    pa, pg = a.parameters(), g.parameters()
    for k, v in TRUE.items():
        assert abs(pa[k]["value"] - v) < 4 * pa[k]["std"], (k, pa[k])
    # GMWM is the efficient estimator: its standard errors are not larger than AVLR's (sandwich)
    assert pg["white"]["std"] <= pa["white"]["std"] * 1.05


def test_json_round_trip_and_mappings(long_fit, tmp_path):
    _, m = long_fit
    p = tmp_path / "noise.json"
    p.write_text(json.dumps({"model": m.to_json()}))
    back = gmwm.load_noise_model(p)
    taus = np.geomspace(0.01, 1000, 7)
    np.testing.assert_allclose(back.adev(taus), m.adev(taus), rtol=1e-12)
    np.testing.assert_allclose(back.adev_std(taus), m.adev_std(taus), rtol=1e-9)
    nd = m.noise_dict()
    assert set(nd) == {"white", "random_walk", "gauss_markov"}
    assert nd["gauss_markov"][1] == pytest.approx(m.parameters()["gm1_tau"]["value"])
    with pytest.raises(gmwm.NoiseModelError, match="random_walk"):
        m.whitening_model(1.0)
    with pytest.raises(gmwm.NoiseModelError, match="random_walk"):
        m.white_gm()


def test_white_gm_maps_onto_gmnoise_and_the_design_noise():
    spec = gmwm.ModelSpec(white=True, n_gm=1)
    vals = {"white": 0.01, "gm1_sigma": 0.3, "gm1_tau": 200.0}
    m = gmwm.NoiseModel(spec, gmwm.theta_from_natural(spec, vals, 0.1), np.zeros((3, 3)), 0.1)
    g = m.whitening_model(2.0)
    assert g.white_var == pytest.approx((60 * 0.01) ** 2 / 2.0) and g.gm_var == pytest.approx(0.09)
    assert g.tau_s == pytest.approx(200.0)
    arw, gm = m.white_gm()
    assert arw == pytest.approx(0.01) and gm == pytest.approx((0.3, 200.0))


def test_bad_model_files(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("{not json")
    with pytest.raises(gmwm.NoiseModelError, match="not JSON"):
        gmwm.load_noise_model(p)
    p.write_text(json.dumps({"model": {"spec": "white+gm", "theta": [1.0], "theta_cov": [[1.0]], "dt_s": 1.0}}))
    with pytest.raises(gmwm.NoiseModelError, match="do not match"):
        gmwm.load_noise_model(p)
    with pytest.raises(gmwm.NoiseModelError, match="unknown part"):
        gmwm.ModelSpec.parse("white+pink")


def test_adequacy_flags_a_wrong_model():
    """White + GM data: the white-only model falls outside the empirical 95 % band, the right one does not."""
    spec = gmwm.ModelSpec(white=True, n_gm=1)
    vals = {"white": 0.05, "gm1_sigma": 3.0, "gm1_tau": 2.0}
    y = _series(2**17, 5, spec, vals)
    res, _ = allan.analyze([y], DT)
    lo, hi = allan.confidence_interval(res.adev, res.edf, 0.95)
    good = gmwm.fit_gmwm(y, DT, model=spec)
    bad = gmwm.fit_gmwm(y, DT, model="white")
    a_good = gmwm.adequacy(res.taus_s, res.adev, lo, hi, good.adev(res.taus_s))
    a_bad = gmwm.adequacy(res.taus_s, res.adev, lo, hi, bad.adev(res.taus_s))
    assert a_good["n_outside"] <= 2
    assert a_bad["n_outside"] > len(res.taus_s) // 2
    assert a_good["max_rel_deviation_well_measured"] < 0.1


def test_derived_figures(long_fit):
    """ARW read where the model slope is −½ equals N within its error; the RRW read at +½ is near K."""
    _, m = long_fit
    d = m.derived(DT, 2**17 * DT)
    assert d["arw"]["value"] == pytest.approx(TRUE["white"], rel=0.05)
    assert d["arw"]["tau_s"] < 0.2 and d["arw"]["std"] > 0
    assert d["rrw"]["value"] == pytest.approx(TRUE["random_walk"], rel=0.5)
    assert d["bias_instability"]["value"] > 0 and 1 < d["bias_instability"]["tau_s"] < 1000


@pytest.mark.slow
def test_monte_carlo_coverage():
    """100 simulated white + GM + RW series (2^18 samples): each log-parameter within ±2σ of the truth in a fraction
    of draws consistent with 0.95 (binomial, 3σ: ≥ 0.885); estimates unbiased (mean z within ±0.35)."""
    n, draws = 2**18, 100
    th = gmwm.theta_from_natural(SPEC, TRUE, DT)
    comps = _components(SPEC, TRUE, DT)
    sim = jax.jit(lambda k: wv.simulate_components(k, n, comps))
    z = []
    for d in range(draws):
        m = gmwm.fit_gmwm(np.asarray(sim(jax.random.PRNGKey(100 + d))), DT, model=SPEC)
        z.append((m.theta - th) / np.sqrt(np.diag(m.cov)))
    z = np.array(z)
    cover = np.mean(np.abs(z) <= 2, axis=0)
    floor = 0.95 - 3 * math.sqrt(0.95 * 0.05 / draws)
    assert np.all(cover >= floor), dict(zip(SPEC.names, cover))
    assert np.all(np.abs(np.median(z, axis=0)) < 0.35), np.median(z, axis=0)
    assert stats.binomtest(int(np.sum(np.abs(z) <= 2)), z.size, 0.95).pvalue > 1e-3


DATA = Path(__file__).resolve().parent / "data" / "imucal" / "annotated_session.csv"


def test_real_mems_static_faces_smoke():
    """A real MEMS gyro (BMI160 class, 204.8 Hz): the six static faces (~5 s each) pooled per axis. The selected
    model stays inside the empirical 95 % band at all but a few τ, and the ARW is in the datasheet
    neighbourhood (BMI160: 0.007 deg/s/√Hz = 0.42 deg/√h; here 16.4 counts per deg/s, imucal's K_g)."""
    import pandas as pd

    df = pd.read_csv(DATA)
    cal = json.loads((DATA.parent / "example_cal.json").read_text())
    for i, ax in enumerate(("gyr_x", "gyr_y", "gyr_z")):
        to_dph = 3600.0 / cal["K_g"][i][i]
        segs = [df[df.part == f][ax].to_numpy(float) * to_dph for f in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")]
        m = gmwm.fit_gmwm(segs, 1 / 204.8)
        res, _ = allan.analyze(segs, 1 / 204.8)
        lo, hi = allan.confidence_interval(res.adev, res.edf, 0.95)
        a = gmwm.adequacy(res.taus_s, res.adev, lo, hi, m.adev(res.taus_s))
        assert a["n_outside"] <= 4, (ax, a)
        arw = m.derived(res.taus_s.min(), res.taus_s.max())["arw"]
        assert 0.2 < arw["value"] < 1.5, (ax, arw)
