"""Monte Carlo pipeline: agreement with the measurement model, invariance to chunking and devices, and coverage.

Coverage is checked against probability, not against the code: for a correct linear fit with white noise,
z = (θ̂ − θ)/σ̂ is Student-t with m − p ≈ 1400 degrees of freedom (≈ N(0,1)), so over n draws the mean of z has
standard deviation 1/√n and the fraction of |z| ≤ 2 is binomial around 0.9545 with sd √(0.9545·0.0455/n).
"""

import json
import os
import subprocess
import sys
import textwrap
from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.cli import app as cli
from gyrojax.data import plans
from gyrojax.inference import identify
from gyrojax.inference.noisefit import small_sample_factor
from gyrojax.montecarlo import pipeline, results, runner
from gyrojax.montecarlo import study as mc
from gyrojax.physics.model import predict, predict_jit

ROOT = Path(__file__).resolve().parents[1]
NINE = list(mc.SDF_NINE_TERMS)
PRIORS = {c: {"normal": [0.0, 0.5]} for c in NINE}
SMALL = {"n": 24, "minutes": 2, "dt_s": 2}
P2 = 0.9545  # P(|N(0,1)| <= 2)


@pytest.fixture(scope="module")
def white_pipe():
    st = mc.Study(
        plan="multiposition", plan_options=SMALL, terms=NINE, priors=PRIORS, noise={"white": 0.01}, draws=4000, seed=11
    )
    return st, pipeline.build_pipeline(st)


@pytest.mark.parametrize(
    "plan, options",
    [("tumble", {"revolutions": 0.1, "dt_s": 60.0}), ("multiposition", {"n": 24, "minutes": 0.5, "dt_s": 10.0})],
)
def test_draw_measurements_are_the_measurement_model(plan, options):
    """The batched kinematics (vector rotations, small-angle encoder turns) give model.predict on the read angles."""
    st = mc.Study(
        plan=plan,
        plan_options=options,
        terms=["D_F", "D_I", "D_S"],
        priors={c: {"normal": [0.0, 1.0]} for c in NINE + ["sf_error"]},
        setup={
            "table_tilt": {"normal": [0, 30]},
            "table_azimuth": {"uniform": [-60, 60]},
            "encoder_harmonic": {"normal": [0, 20]},
        },
        noise={},
        draws=3,
        seed=3,
    )
    pipe = pipeline.build_pipeline(st)
    sim = jax.jit(pipe.simulate_draw)
    for d in range(3):
        theta, ys, reads = sim(jax.random.fold_in(jax.random.PRNGKey(st.seed), d))
        assert float(jnp.abs(theta[pipe.truth_model.slices()["encoder_harmonic"]]).max()) > 1.0
        for y, (rd, _) in zip(ys, reads):
            ref = predict_jit(pipe.truth_model, theta, rd)
            np.testing.assert_allclose(np.asarray(y), np.asarray(ref), rtol=0, atol=1e-11)


def test_static_run_reduction_is_the_sample_level_fit():
    """On a static plan the per-run sums give the sample-level least squares (set-up errors fitted, so three
    Gauss–Newton steps; Gauss–Markov noise, so the per-sample noise is not white); plans or models the reduction
    does not hold for (a tumble, a bias trend) keep the sample-level path."""
    from dataclasses import replace

    terms = ["D_F", "D_I", "D_O", "D_S", "table_tilt"]
    st = mc.Study(
        plan="multiposition",
        plan_options={"n": 8, "minutes": 1, "dt_s": 2},
        terms=terms,
        priors={c: {"normal": [0.0, 0.5]} for c in terms[:4]},
        setup={"table_tilt": {"normal": [0, 20]}, "encoder_harmonic": {"normal": [0, 5]}},
        noise={"white": 0.01, "gauss_markov": [0.1, 30.0]},
        draws=16,
        seed=2,
    )
    pipe = pipeline.build_pipeline(st)
    assert pipe.fit_method == "gls-position-means"  # coloured noise: GLS of the run means (test_mean_covariance)
    pipe = replace(pipe, whiten=None)  # the least squares the per-run sums reproduce
    assert pipe.runs is not None and [len(f) for _, f in pipe.runs] == [8]
    red = runner.run_study(st, pipeline=pipe)
    full = runner.run_study(st, pipeline=replace(pipe, runs=None, compiled={}))
    assert np.abs(red.estimate).max() > 0.1
    for k in ("truth", "estimate", "std", "rms"):
        np.testing.assert_allclose(getattr(red, k), getattr(full, k), rtol=1e-9, atol=1e-12)
    assert pipeline.build_pipeline(replace(st, priors={**st.priors, "D_T": {"normal": [0, 0.1]}})).runs is None
    tumble = replace(st, plan="tumble", plan_options={"revolutions": 0.1, "dt_s": 60.0})
    assert pipeline.build_pipeline(tumble).runs is None


def test_study_errors_name_the_key(tmp_path):
    good = {"plan": "multiposition", "terms": ["D_F"], "priors": {"D_F": {"normal": [0, 1]}}}
    mc.study_from_dict(good)
    cases = [
        ({"plann": "x"}, "plann"),
        ({"plan": "nope"}, "plan"),
        ({"priors": {"D_Q": 1.0}}, "priors.D_Q"),
        ({"priors": {"D_F": {"gauss": [0, 1]}}}, "priors.D_F"),
        ({"priors": {"D_F": {"uniform": [1, 0]}}}, "priors.D_F"),
        ({"setup": {"D_F": {"normal": [0, 1]}}}, "setup.D_F"),
        ({"priors": {"table_tilt": 1.0}}, "priors.table_tilt"),
        ({"noise": {"pink": 1}}, "noise"),
        ({"draws": 0}, "draws"),
        ({"terms": []}, "terms"),
    ]
    for patch, key in cases:
        with pytest.raises(mc.StudyError, match=key.replace(".", r"\.")):
            mc.study_from_dict({**good, **patch})
    # round trip through JSON
    st = mc.study_from_dict({**good, "noise": {"gauss_markov": [0.1, 30]}})
    assert mc.study_from_dict(json.loads(st.to_json())) == st


def test_chunking_does_not_change_draws_and_white_coverage(white_pipe):
    st, pipe = white_pipe
    a = runner.run_study(st, pipeline=pipe, chunk=4000)
    b = runner.run_study(st, pipeline=pipe, draws=1000, chunk=96)  # 11 chunks, the last one padded
    for k in ("truth", "estimate", "std", "rms"):
        np.testing.assert_allclose(getattr(b, k), getattr(a, k)[:1000], rtol=1e-12, atol=1e-15)
    # the draws start where asked: draws 1000.. of a run from 1000 are the same draws
    c = runner.run_study(st, pipeline=pipe, draws=200, chunk=96, start=1000)
    np.testing.assert_allclose(c.estimate, a.estimate[1000:1200], rtol=1e-12, atol=1e-15)

    n = len(a.draw)
    s = results.summarize(a)
    # white noise of ARW N: σ = N·60/√Δt deg/h per sample (IEEE 952, noise.white); residual rms² = σ²(m−p)/m
    sigma = 0.01 * 60.0 / np.sqrt(2.0)
    m, p = pipe.n_measurements, 9
    assert abs(a.rms.mean() / (sigma * np.sqrt((m - p) / m)) - 1.0) < 0.005  # sd of the mean ≈ 1/√(2mn) ≈ 3e-4
    # mean of z: sd 1/√n = 0.016 → 4.5 sd = 0.071 (< 0.1 σ); fraction in ±2σ: binomial sd 0.0033 → 4.5 sd
    tol_mean = 4.5 / np.sqrt(n)
    tol_cov = 4.5 * np.sqrt(P2 * (1 - P2) / n)
    assert (s["mean_z"].abs() < tol_mean).all(), s
    assert ((s["cover_2sigma"] - P2).abs() < tol_cov).all(), s
    assert ((s["cover_1sigma"] - 0.6827).abs() < 4.5 * np.sqrt(0.6827 * 0.3173 / n)).all(), s
    assert ((s["std_z"] - 1.0).abs() < 4.5 / np.sqrt(2 * n)).all(), s
    # the stated std is the textbook σ √((JᵀJ)⁻¹) of the nominal design (numpy, independent of the JAX solve)
    j = np.stack([np.asarray(jax.jacfwd(lambda t: predict(pipe.fit_model, t, pipe.data[0]))(jnp.zeros(p)))])[0]
    ref = sigma * np.sqrt(np.diag(np.linalg.inv(j.T @ j)))
    np.testing.assert_allclose(s["mean_std"], ref, rtol=0.01)


SUBPROCESS = textwrap.dedent("""
    import json, numpy as np, jax
    from gyrojax.montecarlo import pipeline, runner
    from gyrojax.montecarlo import study as mc
    assert len(jax.devices()) == 4, jax.devices()
    st = mc.Study(plan="multiposition", plan_options={"n": 8, "minutes": 1, "dt_s": 5}, terms=["D_F", "D_I", "D_O"],
                  priors={"D_F": {"normal": [0, 1]}, "D_I": {"uniform": [-1, 1]}, "D_O": 0.3},
                  setup={"table_tilt": {"normal": [0, 20]}}, noise={"white": 0.01, "gauss_markov": [0.1, 30.0]},
                  draws=90, seed=5)
    pipe = pipeline.build_pipeline(st)
    one = runner.run_study(st, pipeline=pipe, devices=jax.devices()[:1], chunk=32)
    four = runner.run_study(st, pipeline=pipe, chunk=40)
    print(json.dumps({k: float(np.abs(getattr(one, k) - getattr(four, k)).max()) for k in
                      ("truth", "estimate", "std", "rms")} | {"scale": float(np.abs(one.estimate).max())}))
""")


def test_one_and_four_devices_agree():
    env = dict(
        os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4", PYTHONPATH=str(ROOT), JAX_PLATFORMS="cpu"
    )
    out = subprocess.run([sys.executable, "-c", SUBPROCESS], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    d = json.loads(out.stdout.strip().splitlines()[-1])
    assert d["scale"] > 0.1
    for k in ("truth", "estimate", "std", "rms"):
        assert d[k] <= 1e-12, d


@pytest.mark.slow
def test_gauss_markov_gls_std_is_honest_and_white_ls_is_not():
    """Coloured drift: the white-noise LS σ̂ is too small (coverage far below 0.954); the GLS fit of identify.fit
    (white + Gauss–Markov noise pooled over the campaign, Student-t widened; numpy) on draws written as records
    states an honest σ̂."""
    st = mc.Study(
        plan="multiposition",
        plan_options=SMALL,
        terms=NINE,
        priors=PRIORS,
        noise={"white": 0.01, "gauss_markov": [0.3, 60.0]},
        draws=N_GLS,
        seed=2,
    )
    pipe = replace(pipeline.build_pipeline(st), whiten=None)  # white least squares (its default is the means' GLS)
    fast = runner.run_study(st, pipeline=pipe)
    truth = fast.truth_of_fit()
    z_fast = (fast.estimate - truth) / fast.std
    # the records carry exactly the draw's measurements: a white fit of them is the fast path's estimate and σ̂
    w = identify.fit(pipeline.draw_records(pipe, 0), NINE, noise="white")
    np.testing.assert_allclose(w.theta, fast.estimate[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(w.std, fast.std[0], rtol=1e-6)
    z = []
    for d in range(N_GLS):
        f = identify.fit(pipeline.draw_records(pipe, d), NINE, noise="ar")
        z.append((f.theta - truth[d]) / f.std)
    z = np.array(z)
    inside = (np.abs(z) <= 2.0).mean()
    # pooled over 9 coefficients the draws are not independent; take n_eff = N_GLS (conservative), 4 sd band
    band = 4.0 * np.sqrt(P2 * (1 - P2) / N_GLS)
    assert (np.abs(z_fast) <= 2.0).mean() < 0.7  # white LS under this drift: σ̂ far too small (the check has teeth)
    assert np.abs(z.mean(axis=0)).max() < 4.0 / np.sqrt(N_GLS)  # GLS: unbiased
    # measured 2026-11-30 (bench_coverage, 500 draws): 0.930 for τ = 60 s, 0.943 for τ = 300 s
    assert abs(inside - P2) < band, (inside, z.std(axis=0).round(2))


N_GLS = 50
N_SLOW = 100


@pytest.mark.slow
def test_slow_drift_on_eight_positions_small_sample_standard_errors():
    """Drift as slow as a position (τ = 300 s, 5-min positions): it shows only in the scatter of 8 position means, a
    handful of degrees of freedom for 5 coefficients. The pooled REML noise model with Satterthwaite's effective
    dof ν and Student-t widening covers ±2σ at the nominal rate; and ν means what it says: across draws the relative
    variance of the (unwidened) GLS variance estimate is 2/ν."""
    terms = ["D_F", "D_I", "D_O", "D_S", "D_II"]
    st = mc.Study(
        plan="eight-position",
        plan_options={"minutes": 5, "dt_s": 2},
        terms=terms,
        priors={c: {"normal": [0.0, 0.5]} for c in terms},
        noise={"white": 0.001, "gauss_markov": [0.05, 300.0]},
        draws=N_SLOW,
        seed=4,
    )
    pipe = pipeline.build_pipeline(st)
    truth = runner.run_study(st, pipeline=pipe).truth_of_fit()
    z, var_plain, nu = [], [], []
    for d in range(N_SLOW):
        f = identify.fit(pipeline.draw_records(pipe, d), terms)
        z.append((f.theta - truth[d]) / f.std)
        nu_d = f.dof_eff if f.dof_eff is not None else np.full(len(terms), np.inf)
        var_plain.append((f.std / small_sample_factor(nu_d)) ** 2)
        nu.append(nu_d)
    z, var_plain, nu = np.array(z), np.array(var_plain), np.array(nu)
    inside = (np.abs(z) <= 2.0).mean()
    # 5 correlated coefficients pooled: take n_eff = N_SLOW, 3 sd band (measured 0.95; plug-in σ̂ alone 0.88–0.90)
    assert abs(inside - P2) < 3.0 * np.sqrt(P2 * (1 - P2) / N_SLOW), (inside, z.std(axis=0))
    assert np.abs(z.mean(axis=0)).max() < 4.0 / np.sqrt(N_SLOW)
    assert np.median(nu) < 30  # few effective dof: the correction is at work here
    rel_var = var_plain.var(axis=0) / var_plain.mean(axis=0) ** 2
    predicted = np.mean(2.0 / np.minimum(nu, 1e6), axis=0)
    assert np.all((rel_var > predicted / 2.5) & (rel_var < predicted * 2.5)), (rel_var, predicted)


def test_cli_mc_writes_table_study_and_plot(tmp_path, capsys):
    study = {
        "plan": "multiposition",
        "plan_options": {"n": 8, "minutes": 1, "dt_s": 5},
        "terms": ["D_F", "D_I"],
        "priors": {"D_F": {"normal": [0, 1]}, "D_I": {"normal": [0, 1]}},
        "noise": {"white": 0.01},
        "draws": 40,
        "seed": 1,
    }
    sp = tmp_path / "study.json"
    sp.write_text(json.dumps(study))
    out = tmp_path / "res"
    assert cli.main(["mc", str(sp), "--out", str(out), "--draws", "30", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["draws"] == 30 and len(res["summary"]) == 2
    saved = json.loads((out / "study.json").read_text())
    assert saved["draws"] == 30 and saved["plan"] == "multiposition"
    table = Path(res["files"]["draws"])
    import pandas as pd

    df = pd.read_parquet(table) if table.suffix == ".parquet" else pd.read_csv(table)
    assert len(df) == 30 and {"D_F_truth", "D_F_estimate", "D_F_std", "rms"} <= set(df.columns)
    assert (out / "coverage.png").stat().st_size > 1000
    assert cli.main(["mc", str(sp), "--out", str(out)]) == 2  # refuses to overwrite
    assert "--force" in capsys.readouterr().err
    sp.write_text(json.dumps({**study, "priors": {"D_F": {"normal": [0, -1]}}}))
    assert cli.main(["mc", str(sp), "--out", str(tmp_path / "x")]) == 2
    assert "priors.D_F" in capsys.readouterr().err
    _ = plans  # plans are built by name inside the study
