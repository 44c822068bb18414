"""Seed 001's two-slope temperature bias as the registry's ``temperature_hinge``: its contribution against the seed's
procedure and the independent writer, the knee fitted against the plain reference analysis
(tests/reference_analysis.py), the sup score over the knee against the reference's simulated null law and its level,
and a planted two-slope bias found by the diagnosis loop as the hinge (power ≥ 0.999 shown first), ending adequate at
the noise floor with no colour named. The rates over many draws: ``python -m benchmarks.study_real_noise colour``."""

import numpy as np
import pytest
from scipy import stats

import gyrojax as gj
from gyrojax.data import plans
from gyrojax.errors import ModelError
from gyrojax.inference import knee
from gyrojax.physics import effects as fx
from gyrojax.simulation.simulator import simulate

from . import independent_writer as iw
from . import real_noise_cases as rc
from . import reference_analysis as ra


def test_hinge_beside_the_linear_term_is_seed_001s_two_slopes():
    """D_TEMP (T − 20) + D_HINGE |T − T_KNEE| with D_TEMP = (K_tx1 + K_tx2)/2, D_HINGE = (K_tx1 − K_tx2)/2 and
    T_KNEE = 20 °C is 001 §5.1's bias e + K_tx1 τ (hot), e + K_tx2 τ (cold), τ = T − 20 °C, as the independent writer
    draws it (less e, which D_F holds)."""
    k_hot, k_cold = 0.016, 0.004
    temp = np.linspace(-40.0, 70.0, 221)
    x = {"temperature_C": temp}
    model = fx.get("bias_temperature").contribution(x, [0.5 * (k_hot + k_cold)])
    model = model + fx.get("temperature_hinge").contribution(x, [0.5 * (k_hot - k_cold), 20.0])
    seed = iw.two_slope(k_hot, k_cold)
    np.testing.assert_allclose(model, [seed(0.0, t) for t in temp], rtol=1e-12, atol=1e-15)


def _null_problem(rng, n=400):
    """White N(0, 1) data beside an offset and a temperature cycle (10–32 °C), and the hinge at every knee."""
    t = np.linspace(0.0, 11520.0, n)
    temp = iw.chamber_cycle()(t)
    x0 = np.column_stack([np.ones(n), temp - 20.0])
    h = np.abs(temp[:, None] - knee.grid(temp)[None, :])
    return rng.standard_normal(n), x0, h


def test_sup_score_null_law_agrees_with_the_reference_and_holds_its_level():
    """The sup of the hinge's score over the knee: its p-value agrees with the reference's (its own Gaussian score
    process, 20 000 draws) within their Monte Carlo error; over 400 null draws it rejects at 5 % within the binomial
    99.9 % interval of 0.05, while the χ²₁ tail of the sup (as if the knee were known) rejects well above."""
    rng = np.random.default_rng(5)
    ours, naive = [], []
    for i in range(400):
        y, x0, h = _null_problem(rng)
        u0 = np.linalg.qr(x0)[0]
        r = y - u0 @ (u0.T @ y)
        stat, _, log10_p, _ = knee.sup_score(u0, r, h, 1.0, draws=4000)
        ours.append(10.0**log10_p)
        naive.append(stats.chi2.sf(stat, 1))
        if i < 20:  # against the reference, σ known on both sides
            lm, _, p_ref = ra.sup_score(y, x0, h)
            assert lm == pytest.approx(stat, rel=1e-9)
            assert abs(10.0**log10_p - p_ref) < 4 * np.sqrt(p_ref * (1 - p_ref) / 4000) + 1e-3, (10.0**log10_p, p_ref)
    lo, hi = stats.binom.ppf([0.0005, 0.9995], 400, 0.05) / 400
    rate = np.mean(np.array(ours) < 0.05)
    assert lo <= rate <= hi, rate
    assert np.mean(np.array(naive) < 0.05) > hi, np.mean(np.array(naive) < 0.05)


def test_knee_fit_agrees_with_the_reference(tmp_path):
    """A two-slope bias hinged at 23 °C (not the paper's 20 °C: the profile is not anchored there) on the 24-position
    test in white noise: gyrojax's fit of D_F…D_S, bias_temperature and temperature_hinge (knee started by its
    profile, σ by Gauss–Newton) gives the reference's GLS knee and σ (tests/reference_analysis.py fit_knee), the knee
    within 2σ of 23 °C and the slopes within 3σ of the truth."""
    run = iw.twenty_four_positions(name="knee23", dwell=480.0, dt=6.0, temperature=iw.chamber_cycle())
    truth = dict(rc.TURNTABLE_BASE)
    hinged = iw.two_slope(0.016, 0.004, 23.0)
    paths = iw.write_campaign(tmp_path, [run], truth, noise_white=rc.ARW, seed=4, extra=hinged)
    res = gj.fit(gj.load_records(paths), rc.DRIFT4 + ("bias_temperature", "temperature_hinge"))
    k, sd = res.values["T_KNEE"], res.stds["T_KNEE"]
    tt = ra.turntable(paths)
    wh = ra.whitener(ra.turntable_covariance(tt, rc.ARW))
    ref = ra.fit_knee(tt, list(rc.DRIFT4) + ["bias_temperature"], wh, k)
    assert abs(k - ref["knee_C"]) < 0.1 * sd, (k, ref)
    assert 0.8 < sd / ref["knee_std_C"] < 1.25, (sd, ref)
    assert abs(k - 23.0) < 2 * sd, (k, sd)
    assert abs(res.values["D_HINGE"] - 0.006) < 3 * res.stds["D_HINGE"]
    assert abs(res.values["D_TEMP"] - 0.010) < 3 * res.stds["D_TEMP"]


def test_a_hinge_needs_a_varying_temperature_and_a_turntable():
    """Records without a temperature column cannot carry the hinge (the fit names the column); the triad's linear fit
    refuses a knee."""
    recs = simulate(plans.multiposition(6, minutes=0.2, dt_s=4.0), {"coefficients": {"D_F": 0.5}}, seed=1)
    with pytest.raises(ModelError, match="temperature_C"):
        gj.fit(recs, ["D_F", "temperature_hinge"])
    from gyrojax.physics.triad import channel_model

    with pytest.raises(ModelError, match="knee"):
        channel_model(["D_F", "temperature_hinge"])


def test_two_slopes_found_as_the_hinge_then_adequate_at_the_floor(tmp_path):
    """Seed 001's two slopes (0.016 and 0.004 deg/h/°C about 20 °C) on a 24-position test whose temperature goes
    10–32 °C, at a draw of its own: the hinge's test has power ≥ 0.999 at the truth (first Holm step of a family of
    60, beside a quadratic in temperature too); then gyrojax's loop from D_F…D_S adds bias_temperature, then
    temperature_hinge, whose knee is within 2σ of 20 °C, and ends adequate at the noise floor with no colour named."""
    case = rc.CASES["two-slope-temperature"]
    paths, _ = case.build(tmp_path, 2)
    p = rc.planted_power(case, paths, families=(60,))
    assert p["power_F60"] >= 0.999 and p["power_beside_rivals_F60"] >= 0.999, p
    chain = rc.gyrojax_loop(paths, rc.DRIFT4)
    assert [c["proposal"] for c in chain] == ["bias_temperature", "temperature_hinge", None], chain
    res = gj.fit(gj.load_records(paths), chain[-1]["terms"])
    k, sd = res.values["T_KNEE"], res.stds["T_KNEE"]
    assert k == pytest.approx(chain[1]["estimate"]["T_KNEE"], rel=1e-9) and abs(k - 20.0) < 2 * sd, (k, sd)
    last = chain[-1]
    assert last["verdict"] == "adequate" and not last["unexplained"]
    assert last["rms"] <= 1.1 * last["floor"]
    assert "gauss_markov" not in last["noise"]


def _dense_gain(r, d0, xc, white_var, gm_var, tau, times, knee_params):
    """The colour-against-shape BIC difference by dense matrices (scipy): −2ℓ of GLS under V = σ_w² I +
    σ_g² exp(−|Δt|/τ) (log det V + ẽᵀẽ) with 2 colour parameters, less n log(|e|²/n) + n of OLS with the shape."""
    from scipy import linalg

    n = len(r)
    v = white_var * np.eye(n) + gm_var * np.exp(-np.abs(times[:, None] - times[None, :]) / tau)
    c = linalg.cholesky(v, lower=True)
    rw, dw = linalg.solve_triangular(c, r, lower=True), linalg.solve_triangular(c, d0, lower=True)
    e = rw - dw @ np.linalg.lstsq(dw, rw, rcond=None)[0]
    m2c = 2.0 * np.sum(np.log(np.diag(c))) + e @ e
    d1 = np.column_stack([d0, xc])
    e1 = r - d1 @ np.linalg.lstsq(d1, r, rcond=None)[0]
    m2w = n * np.log(e1 @ e1 / n) + n
    return (m2c + 2 * np.log(n)) - (m2w + (xc.shape[1] + knee_params) * np.log(n))


@pytest.mark.parametrize("planted", [0.0, 0.05])
def test_colour_against_shape_is_the_dense_likelihood(planted):
    """The likelihood judgement of colour against a shape (white + the hinge against Gauss–Markov colour alone, BIC)
    equals the same difference computed with the dense covariance and scipy's Cholesky, to 1e-6; it is negative on
    Gauss–Markov drift alone and positive when the hinge is there and the noise white."""
    from gyrojax.inference.campaign import Linearized
    from gyrojax.inference.turntable_diagnosis import colour_against_shape
    from gyrojax.noise.spec import NoiseSpec

    rng = np.random.default_rng(3)
    n, dt, tau, gm_var, white_var = 300, 6.0, 300.0, 0.02**2, 0.01**2
    t = np.arange(n) * dt
    temp = iw.chamber_cycle(period_s=n * dt)(t)
    hinge = np.abs(temp - 20.0)
    d0 = np.column_stack([np.ones(n), temp - 20.0])
    if planted:
        r = planted * hinge + np.sqrt(white_var) * rng.standard_normal(n)
    else:
        phi = np.exp(-dt / tau)
        g = np.zeros(n)
        g[0] = np.sqrt(gm_var) * rng.standard_normal()
        for k in range(1, n):
            g[k] = phi * g[k - 1] + np.sqrt(gm_var * (1 - phi**2)) * rng.standard_normal()
        r = g + np.sqrt(white_var) * rng.standard_normal(n)
    nz = NoiseSpec.from_sample_variances(white_var, dt, gm=((gm_var, tau),), method="reml")
    jac = np.column_stack([d0[:, 1:], hinge, np.zeros(n)])  # the model's temperature column, then D_HINGE, T_KNEE
    lin = [Linearized(r, jac, np.zeros(n, dtype=int), t)]
    gain = colour_against_shape(lin, [nz], np.array([0]), np.array([1, 2]), "temperature_C")
    want = _dense_gain(r, d0, hinge[:, None], white_var, gm_var, tau, t, 1)
    assert gain == pytest.approx(want, rel=1e-6, abs=1e-6)
    assert (gain > 0) == bool(planted), gain


def test_a_monte_carlo_study_refuses_a_knee():
    """The Monte Carlo pipeline's solver starts every coefficient at zero, where a knee is not seen: a study whose
    terms hold the hinge is refused, naming it, instead of answering from a singular start."""
    from gyrojax.montecarlo import study as mc
    from gyrojax.montecarlo.pipeline import build_pipeline

    options = {"n": 8, "minutes": 1, "dt_s": 5}
    st = mc.Study(plan="multiposition", plan_options=options, terms=["D_F", "temperature_hinge"])
    with pytest.raises(mc.StudyError, match="temperature_hinge"):
        build_pipeline(st)
