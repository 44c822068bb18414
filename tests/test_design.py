"""Optimal design: the fast Fisher path against the fitting Jacobian, designed vs classical plans, Monte Carlo
check of the Cramér–Rao stds, and a detectability design for the omitted D_OO."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.data.planfile import load_plan
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.noise.meancov import gm_mean_factor
from gyrojax.noise.processes import gauss_markov, random_drift, white
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.planning import criteria, fisher
from gyrojax.planning import optimal as D
from gyrojax.simulation.simulator import simulate

ARW = 0.01  # deg/√h
NOISE = NoiseSpec(white=ARW)
FAST = {"starts": 3, "adam_steps": 300, "lbfgs_steps": 0}
# the 6-term sub-model the classical 8-position set identifies (N = 8 positions of one scalar each cannot
# identify the 9-term model: rank F ≤ 8)
SDF6 = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_IS")


def _plan_fisher(model, plan):
    """Jᵀ J / σ² from the fitting code's Jacobian of a noise-free simulation (σ² = (60 N)²/Δt per sample)."""
    recs = simulate(plan, {"coefficients": {}})
    camp = Campaign.of(recs)
    f = np.zeros((model.size, model.size))
    for (_r, j, _lab, _t), d in zip(linearize(model, np.zeros(model.size), camp), camp.data):
        dt = float(np.asarray(d.dt)[0])
        f += j.T @ j / ((60.0 * ARW) ** 2 / dt)
    return f


@pytest.fixture(scope="module")
def d24():
    return D.design(D.SDF9, 24, hours=4.0, noise=NOISE, dt_s=30.0, seed=1, **FAST)


def test_fast_fisher_equals_linearize_jacobian():
    model = Model.of(D.SDF9 + ("D_OO", "sf_error", "table_tilt"))
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, 360, (7, 2))
    dwell = np.array([60.0, 120.0, 30.0, 90.0, 150.0, 60.0, 240.0])
    segs = tuple(plans.Segment(tuple(p), t, 10.0, label=i) for i, (p, t) in enumerate(zip(pos, dwell)))
    plan = plans.Plan("p", (plans.Run("r", plans.TWO_AXIS, plans.SKEW_MOUNT, segs),))
    f_ref = _plan_fisher(model, plan)
    f = np.asarray(
        fisher.static_fisher(
            model, fisher.Table.two_axis(), jnp.deg2rad(jnp.asarray(pos)), jnp.asarray(dwell), NOISE, 10.0
        )
    )
    assert np.max(np.abs(f - f_ref)) <= 1e-9 * np.max(np.abs(f_ref))


def test_gauss_markov_mean_factor_against_discrete_covariance():
    # Var(mean of n GM samples)/σ² = (1/n²) Σ_ij φ^|i−j|, φ = e^{−Δt/τ}; → f(T/τ) as Δt → 0
    tau, T, n = 50.0, 120.0, 2000
    dt = T / n
    i = np.arange(n)
    ref = np.exp(-np.abs(i[:, None] - i[None, :]) * dt / tau).mean()
    assert float(gm_mean_factor(T / tau)) == pytest.approx(ref, rel=2e-3)
    # and against the project's generator: white + GM position means, 4000 draws (std error of a variance 2.2 %)
    keys = jax.random.split(jax.random.PRNGKey(2), 4000)
    dts = jnp.full(120, 1.0)
    gm = jax.vmap(lambda k: gauss_markov(k, dts, 0.02, tau))(keys)
    wh = jax.vmap(lambda k: white(jax.random.fold_in(k, 1), 120, 1.0, ARW))(keys)
    var = float(jnp.var(jnp.mean(gm + wh, axis=1)))
    assert var == pytest.approx(float(NoiseSpec(white=ARW, gauss_markov=((0.02, tau),)).mean_variance(120.0)), rel=0.08)
    assert float(gm_mean_factor(1e-6)) == pytest.approx(1.0, rel=1e-6)
    assert float(gm_mean_factor(1e4)) == pytest.approx(2e-4, rel=1e-3)


def test_designed_beats_classical_on_D(d24):
    # N = 24, the 9-term model (D_OO left out), same total dwell (4 h)
    m9 = Model.of(D.SDF9)
    classical = plans.multiposition(24, minutes=10.0, dt_s=30.0)
    d_classical = criteria.criterion_values(_plan_fisher(m9, classical), m9)["D"]
    d_designed = criteria.criterion_values(_plan_fisher(m9, d24.plan()), m9)["D"]
    assert np.isfinite(d_classical)
    assert d_designed > d_classical + 0.1  # det ratio > 1.1
    assert d24.grad_norm < 1e-3 * abs(d24.loss)
    assert d24.converged and d24.summary()["converged"] is True
    # N = 8: the classical set identifies only a 6-term sub-model; the designed one does better on it
    m6 = Model.of(SDF6)
    res = D.design(m6, 8, hours=2.0, noise=NOISE, dt_s=30.0, **FAST)
    c8 = criteria.criterion_values(_plan_fisher(m6, plans.multiposition(8, minutes=15.0, dt_s=30.0)), m6)["D"]
    assert np.isfinite(c8)
    assert criteria.criterion_values(_plan_fisher(m6, res.plan()), m6)["D"] > c8 + 0.1


def test_monte_carlo_confirms_cramer_rao(d24):
    """Linear LS fits of 400 simulated records of the designed plan scatter as the fast path predicts.

    Tolerance: the sample std of M = 400 draws has relative standard error 1/√(2M) = 3.5 %; over 9 coefficients
    the largest deviation stays below ~3.2 of those (11 %) with probability > 99 %, hence 12 %.
    """
    m9 = Model.of(D.SDF9)
    plan = d24.plan()
    truth = {"coefficients": {"D_F": 1.0, "D_I": 0.3, "D_SS": 0.05}, "noise": {"white": ARW}}
    rec = simulate(plan, truth, seed=0)[0]
    camp = Campaign.of([rec])
    ((r, j, _, _),) = linearize(m9, np.zeros(m9.size), camp)
    y = np.asarray(camp.data[0].y)
    t = np.asarray(rec.time_s)
    # the simulator's record is noise-free output + random_drift(fold_in(key, run 0)): draw more of the same
    key0 = jax.random.fold_in(jax.random.PRNGKey(0), 0)
    y0 = y - np.asarray(random_drift(key0, t, {"white": ARW}))
    rec1 = simulate(plan, truth, seed=1)[0]
    key1 = jax.random.fold_in(jax.random.PRNGKey(1), 0)
    np.testing.assert_allclose(
        np.asarray(record_data(rec1).y), y0 + np.asarray(random_drift(key1, t, {"white": ARW})), rtol=0, atol=1e-9
    )
    keys = jax.random.split(jax.random.PRNGKey(7), 400)
    noise = np.asarray(jax.vmap(lambda k: random_drift(k, t, {"white": ARW}))(keys))
    # residuals at θ = 0 (the Earth-rate input removed): y − h(0) = Jθ + noise
    r0 = y0 - (y - r)
    theta, *_ = np.linalg.lstsq(j, (r0[None, :] + noise).T, rcond=None)
    emp = theta.std(axis=1, ddof=1)
    angles = jnp.deg2rad(jnp.asarray([s.start_deg for s in plan.runs[0].segments]))
    dwell = jnp.asarray([s.duration_s for s in plan.runs[0].segments])
    pred = np.sqrt(np.diag(np.linalg.inv(np.asarray(fisher.static_fisher(m9, d24.table, angles, dwell, NOISE, 30.0)))))
    np.testing.assert_allclose(emp, pred, rtol=0.12)
    truth_theta = m9.pack(truth["coefficients"])
    assert np.all(np.abs(theta.mean(axis=1) - truth_theta) < 4 * pred / np.sqrt(400))


def test_d_oo_is_invisible_to_every_static_plan(d24):
    """a_I² + a_O² + a_S² = (g/g0)² in every static 1-g position, so the D_OO regressor is D_F·(g/g0)² − D_II − D_SS:
    the D_OO score test of the 9-term model has zero noncentrality for any static plan, and design refuses it."""
    m10 = Model.of(D.SDF9 + ("D_OO",))
    rows = np.asarray(fisher.position_rows(m10, d24.table, jnp.deg2rad(jnp.asarray(d24.angles_deg))))[0]
    g2 = (d24.table.template.gravity / 9.80665) ** 2
    np.testing.assert_allclose(rows[:, 9], g2 * rows[:, 0] - rows[:, 4] - rows[:, 5], atol=1e-12)
    with pytest.raises(ModelError, match="D_OO"):
        D.design(D.SDF9, 24, hours=4.0, criterion="detect:D_OO", **FAST)


def test_detect_design_raises_noncentrality(d24):
    """A detect:sf_error plan beats the D-optimal plan (same length) on the score-test noncentrality of the
    omitted scale-factor error E_SF (regressor ω_I: the Earth rate along IA).

    Checked independently of the design code: λ = δ² ‖(I − P_X) x‖² / σ² from the fitting Jacobians of the
    simulated plans (P_X the projector on the 9-term regressors).
    """
    delta = 1000.0  # ppm
    det = D.design(D.SDF9, 24, hours=4.0, criterion=f"detect:sf_error={delta}", noise=NOISE, dt_s=30.0, seed=1, **FAST)
    m10 = Model.of(D.SDF9 + ("sf_error",))

    def lam(plan):
        recs = simulate(plan, {"coefficients": {}})
        ((_, j, _, _),) = linearize(m10, np.zeros(10), Campaign.of(recs))
        x, a = j[:, :9], j[:, 9]
        resid = a - x @ np.linalg.lstsq(x, a, rcond=None)[0]
        return delta**2 * resid @ resid / ((60.0 * ARW) ** 2 / 30.0)

    lam_d, lam_det = lam(d24.plan()), lam(det.plan())
    assert lam_det > 1.5 * lam_d
    summary = det.summary()
    assert summary["noncentrality"] == pytest.approx(lam_det, rel=0.02)  # dwell rounding to whole samples
    assert summary["power_1pct"] > criteria.detect_power(lam_d)
    # the model stays estimable in the detectability plan
    assert np.isfinite(criteria.criterion_values(det.fisher, Model.of(D.SDF9))["D"])


def test_cli_design_writes_a_runnable_plan(tmp_path, capsys):
    from gyrojax.cli.app import main

    out = tmp_path / "plan.json"
    # the same configuration as the N = 8 design above: the compiled optimiser is reused
    rc = main(
        [
            "design",
            "--terms",
            ",".join(SDF6),
            "--positions",
            "8",
            "--hours",
            "2",
            "--criterion",
            "D",
            "--out",
            str(out),
            "--json",
            "--starts",
            "3",
            "--adam-steps",
            "300",
            "--lbfgs-steps",
            "0",
            "--dt",
            "30",
            "--arw",
            str(ARW),
        ]
    )
    assert rc == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["design"]["criterion"] == "D"
    plan = load_plan(out)
    assert len(plan.runs[0].segments) == 8
    rc = main(["simulate", str(out), "--out", str(tmp_path / "recs")])
    assert rc == 0


def test_a_design_cut_short_says_so():
    with pytest.warns(ConvergenceWarning, match="design did not converge"):
        res = D.design(D.SDF9, 24, hours=4.0, noise=NOISE, dt_s=30.0, seed=1, starts=2, adam_steps=5, lbfgs_steps=0)
    assert not res.converged
    s = res.summary()
    assert s["converged"] is False and "iterations" in s["reason"]
