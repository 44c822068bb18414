"""The exact derivatives of the triad fit, each against an independent one: the moves' implicit Jacobian
(:func:`gyrojax.inference.triad_rows.move_rows`) against ``jax.jacfwd`` through the direct step product and against
central differences of a numpy/scipy integration of the same moves; the exact REML gradient (Harville 1977) against
central differences of −2ℓ_R; the accelerometer's Jacobian (Tedaldi et al. eq. 6) against central differences and
``jax.jacfwd`` of |T K (a − b)|, and the ellipsoid fit on it against scipy's own differences."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import optimize
from scipy.spatial.transform import Rotation

from gyrojax import units
from gyrojax.data.segments import ellipsoid_accelerometer, imutk_acc_jacobian, imutk_acc_model
from gyrojax.data.triad_segments import triad_segments
from gyrojax.inference import triad as tf
from gyrojax.inference import triad_components as tc
from gyrojax.inference import triad_rows as tr
from gyrojax.inference.triad_accel import _residual, residual_jacobian
from gyrojax.montecarlo.triad import mems_truth
from gyrojax.physics import triad as tp
from gyrojax.simulation.triad import simulate_multiposition

TRUTH = mems_truth(11)
LINEAR = tp.DEFAULT_ROTATION_TERMS
NONLINEAR = LINEAR + ("sf_asymmetry", "sf_quadratic", "bias_trend")
# central-difference steps in report units, each moving the rates by ~1 deg/h (a 30 s session: t ≤ 0.01 h; rates
# ≤ 100 deg/s): small beside the coefficients' MEMS sizes (500 deg/h, 30 deg/h/g, 1e4 ppm, 3000 arcsec), large
# beside the rounding of the residual
STEP = {"D_F": 1.0, "D_I": 0.3, "D_O": 0.3, "D_S": 0.3, "E_SF": 30.0, "M_O": 3.0, "M_S": 3.0, "E_A": 30.0}
STEP.update({"E_2": 0.3, "D_T": 100.0})


@pytest.fixture(scope="module")
def session():
    rec = simulate_multiposition(TRUTH, poses=6, static_s=2.0, move_s=1.5, seed=4, fit_latitude=True)
    segments, resid, _, moves = triad_segments(rec)
    return segments, resid, moves


def _theta(model, extra=None):
    values = {**TRUTH, **(extra or {})}
    names = [tp.channel_name(c, ch) for ch in tp.CHANNELS for c in model.coefficient_names]
    return names, np.array([values.get(n, 0.0) for n in names])


def _steps(names):
    return np.array([STEP[tp.split_channel_name(n)[0]] for n in names])


def _whitening(moves, resid):
    return tf.move_whitening(moves, tf.long_run_variance(resid), np.eye(3))


def _project(whitening, r):
    """Rows P_kᵀ r_k / σ_k of residuals r (M, 3) or their derivatives (M, 3, k)."""
    return np.concatenate([np.tensordot(p.T, r[i], axes=1) / sd for i, (p, sd) in enumerate(whitening)])


def _numpy_residual(values, moves):
    """u_to − Rᵀ u_from of every move by numpy and scipy alone: body rates ω = S⁻¹ (ω_ind − b − G a) of the matrix
    form (:func:`gyrojax.physics.triad.matrices`), R the product of scipy's exponentials of the steps' mean rates."""
    mats = tp.matrices(values)
    out = []
    for m in moves:
        w = np.linalg.solve(mats["S"], (m.g - mats["b"] - m.a @ mats["G"].T).T).T * units.DEG_PER_H
        rot = Rotation.identity()
        for v in 0.5 * (w[1:] + w[:-1]) * m.dt:
            rot = rot * Rotation.from_rotvec(v)
        out.append(m.u_to - rot.as_matrix().T @ m.u_from)
    return np.array(out)


def test_move_rows_match_an_independent_integration_and_its_central_differences(session):
    """Linear model at MEMS-sized θ (S far from I): the residual agrees with numpy/scipy's to rounding, the implicit
    Jacobian with central differences of numpy/scipy's to their truncation (h² terms, < 1e-6 of each column)."""
    _, resid, moves = session
    model = tp.channel_model(LINEAR)
    names, theta = _theta(model)
    w = _whitening(moves, resid)
    r, rows, jac = tr.move_rows(model, theta, tr.pack_moves(moves, bucketed=True), w)
    r_np = _numpy_residual(dict(zip(names, theta)), moves)
    np.testing.assert_allclose(r, r_np, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rows, _project(w, r_np), rtol=0, atol=1e-9 * np.abs(rows).max())
    h = _steps(names)
    cd = np.empty((len(rows), len(names)))
    for j, hj in enumerate(h):
        up, dn = theta.copy(), theta.copy()
        up[j] += hj
        dn[j] -= hj
        r_up = _numpy_residual(dict(zip(names, up)), moves)
        r_dn = _numpy_residual(dict(zip(names, dn)), moves)
        cd[:, j] = -_project(w, (r_up - r_dn) / (2 * hj))  # rows of "y − f": ∂f/∂θ = −∂r/∂θ
    scale = np.abs(cd).max(axis=0)
    assert np.all(scale > 0)
    err = np.abs(jac - cd).max(axis=0) / scale
    assert err.max() < 1e-6, dict(zip(names, err))


@pytest.mark.parametrize("terms", [LINEAR, NONLINEAR], ids=["linear", "rate-nonlinear"])
def test_move_rows_jacobian_equals_jacfwd_through_the_step_product(session, terms):
    """The implicit Jacobian (body rates by the implicit-function theorem, first-order perturbation of the step
    product) against ``jax.jacfwd`` of the direct formulation (body rates by their chord iteration, the product by a
    scan of exponentials), and against central differences of that direct formulation; a rate-nonlinear model
    (E_A, E_2, a trend) takes the per-sample (∂f/∂ω)⁻¹ path."""
    _, resid, moves = session
    model = tp.channel_model(terms)
    names, theta = _theta(
        model, {f"E_{k}[{c}]": v * (i + 1) for i, c in enumerate("xyz") for k, v in (("A", 300.0), ("2", 30.0))}
    )
    w = _whitening(moves, resid)
    packed = tr.pack_moves(moves, bucketed=True)
    r, rows, jac = tr.move_rows(model, theta, packed, w)
    m = len(moves)
    r_direct = np.asarray(tr.moves_residual_jit(model, jnp.asarray(theta), *packed))[:m]
    np.testing.assert_allclose(r, r_direct, rtol=0, atol=1e-13)
    d_direct = np.asarray(tr.moves_jacobian_jit(model, jnp.asarray(theta), *packed))[:m]
    ref = -_project(w, d_direct)
    scale = np.abs(ref).max(axis=0)
    err = np.abs(jac - ref).max(axis=0) / np.where(scale > 0, scale, 1.0)
    assert err.max() < 1e-9, dict(zip(names, err))
    h = _steps(names)
    for j in range(len(names)):
        up, dn = theta.copy(), theta.copy()
        up[j] += h[j]
        dn[j] -= h[j]
        diff = np.asarray(tr.moves_residual_jit(model, up, *packed) - tr.moves_residual_jit(model, dn, *packed))
        cd = -_project(w, diff[:m] / (2 * h[j]))
        assert np.abs(jac[:, j] - cd).max() <= 1e-6 * max(np.abs(cd).max(), 1e-300), names[j]


def _groups(rng, rank_deficient: bool):
    """Synthetic REML groups: 12 poses (3 rows, base covariance SPD) and 10 moves (2 rows), 7 columns (one a copy of
    another when ``rank_deficient``), residuals with both components planted."""
    p = 7
    groups = []
    for i in range(22):
        d, kind, extra = (3, "pose", 4.0) if i < 12 else (2, "move", 0.5)
        a = rng.normal(size=(d, d))
        cov = a @ a.T + d * np.eye(d)
        jac = rng.normal(size=(d, p))
        if rank_deficient:
            jac[:, -1] = jac[:, 0]
        r = np.linalg.cholesky(cov + extra * np.eye(d)) @ rng.normal(size=d)
        groups.append(tc.Group(cov, r, jac, kind if i % 11 else ""))
    return groups


@pytest.mark.parametrize("rank_deficient", [False, True], ids=["full-rank", "rank-deficient"])
def test_reml_gradient_equals_central_differences(rank_deficient):
    """∂(−2ℓ_R)/∂τ_k² by Harville's formula against central differences of −2ℓ_R, at components below, at and
    above the planted sizes (relative step 1e-4: truncation ~1e-8 of the gradient)."""
    groups = _groups(np.random.default_rng(3), rank_deficient)
    st = tc._Stacked(groups)
    col_scale = np.linalg.norm(st.whiten({})[1], axis=0)
    for tau2 in ({"pose": 0.3, "move": 0.05}, {"pose": 4.0, "move": 0.5}, {"pose": 30.0, "move": 3.0}):
        value, grad = tc._objective_and_gradient(st, tau2, col_scale, ("pose", "move"))
        assert value == pytest.approx(tc.reml_objective(groups, tau2, col_scale), rel=1e-13)
        for k in ("pose", "move"):
            h = 1e-4 * tau2[k]
            f_up = tc.reml_objective(st, {**tau2, k: tau2[k] + h}, col_scale)
            f_dn = tc.reml_objective(st, {**tau2, k: tau2[k] - h}, col_scale)
            cd = (f_up - f_dn) / (2 * h)
            assert grad[k] == pytest.approx(cd, rel=1e-6, abs=1e-9 * abs(value) / tau2[k]), (k, tau2)


def _accel_points(rng, params, n=14):
    """Pose means (raw) whose calibrated specific force is g in random directions, plus noise."""
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    t = np.array([[1.0, -params[0], params[1]], [0.0, 1.0, -params[2]], [0.0, 0.0, 1.0]])
    raw = np.linalg.solve(t @ np.diag(params[3:6]), u.T).T + params[6:9]
    return raw + 1e-3 * rng.normal(size=raw.shape)


PARAMS = np.array([0.01, -0.02, 0.015, 1.02, 0.97, 1.01, 0.03, -0.02, 0.05])


def test_accelerometer_jacobian_equals_central_differences_and_jacfwd():
    """∂|T K (a − b)|/∂p (Tedaldi et al. eq. 6) at off-nominal parameters against central differences of the
    residual and ``jax.jacfwd`` of the model written in jax."""
    means = _accel_points(np.random.default_rng(5), PARAMS)
    jac = residual_jacobian(PARAMS, means)
    np.testing.assert_array_equal(jac, imutk_acc_jacobian(PARAMS, means))
    h = 1e-6
    cd = np.column_stack(
        [(_residual(PARAMS + h * e, means, 1.0) - _residual(PARAMS - h * e, means, 1.0)) / (2 * h) for e in np.eye(9)]
    )
    np.testing.assert_allclose(jac, cd, rtol=0, atol=1e-8)

    def norm(p):
        t = jnp.array([[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]])
        return jnp.linalg.norm((t @ jnp.diag(p[3:6]) @ (jnp.asarray(means) - p[6:9]).T).T, axis=1)

    np.testing.assert_allclose(jac, np.asarray(jax.jacfwd(norm)(jnp.asarray(PARAMS))), rtol=0, atol=1e-13)


def test_ellipsoid_fit_on_the_exact_jacobian_finds_scipys_minimum():
    """The ellipsoid fit (exact Jacobian) reaches the minimum scipy's Levenberg–Marquardt finds with its own
    finite differences, to the latter's precision."""
    means = _accel_points(np.random.default_rng(6), PARAMS, n=20)
    got = ellipsoid_accelerometer(means, 1.0, 1.0, np.zeros(3))
    x0 = np.concatenate([np.zeros(3), np.ones(3), np.zeros(3)])
    ref = optimize.least_squares(
        lambda p: np.linalg.norm(imutk_acc_model(p, means), axis=1) - 1.0, x0, method="lm", x_scale="jac"
    ).x
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-7)
    np.testing.assert_allclose(got, PARAMS, rtol=0, atol=5e-3)


def _walking_groups(rng, tau_w2: float, n_seg: int = 30, p: int = 4):
    """Segments in time order whose bias walks (cumulative sums of N(0, τ_w²) steps drawn per channel, the first
    level absorbed by a bias column), each followed by a move whose 2 rows see the bias through a random (2, 3)
    map, and white noise of known covariance."""
    steps = rng.normal(scale=np.sqrt(tau_w2), size=(2 * n_seg, 3))
    level = np.cumsum(steps, axis=0) - steps[0]  # the bias at clock k/2: a walk on the half-steps of the segments
    groups = []
    for k in range(n_seg):
        jac = np.column_stack([np.eye(3), rng.normal(size=(3, p - 3))])
        cov = (0.5 + rng.uniform()) * np.eye(3)
        r = level[2 * k] + np.linalg.cholesky(cov) @ rng.normal(size=3)
        groups.append(tc.Group(cov, r, jac, "pose", step=float(k)))
        if k < n_seg - 1:
            g = rng.normal(size=(2, 3))
            r_mv = g @ level[2 * k + 1] + 0.3 * rng.normal(size=2)
            groups.append(tc.Group(0.09 * np.eye(2), r_mv, rng.normal(size=(2, p)) * 0.1, "move", k + 0.5, g))
    return groups


def test_walk_objective_is_the_dense_restricted_likelihood():
    """−2ℓ_R with the bias walk against its definition written out in numpy: V = blockdiag(covariances, pose
    component) + τ_w² [min(k, l) G_k G_lᵀ], log|V| + log|XᵀV⁻¹X| + rᵀ(V⁻¹ − V⁻¹X(XᵀV⁻¹X)⁻¹XᵀV⁻¹)r (X scaled by its
    column norms); its gradient against central differences."""
    groups = _walking_groups(np.random.default_rng(5), 4.0)
    sizes = [len(g.r) for g in groups]
    n = sum(sizes)
    tau2 = {"pose": 0.7, "move": 0.02, "walk": 3.0}
    v = np.zeros((n, n))
    g_rows, clocks, lo = [], [], 0
    for g, d in zip(groups, sizes):
        v[lo : lo + d, lo : lo + d] = g.cov + tau2.get(g.kind, 0.0) * np.eye(d)
        g_rows.append(np.eye(3) if g.bias_rows is None else g.bias_rows)
        clocks += [g.step] * d
        lo += d
    big_g = np.concatenate(g_rows)
    v += tau2["walk"] * np.minimum.outer(np.array(clocks), np.array(clocks)) * (big_g @ big_g.T)
    x = np.concatenate([g.jac for g in groups])
    r = np.concatenate([g.r for g in groups])
    col = np.linalg.norm(tc.whiten_rows(groups, {})[1], axis=0)
    xs = x / col
    vi = np.linalg.inv(v)
    m = xs.T @ vi @ xs
    p_mat = vi - vi @ xs @ np.linalg.solve(m, xs.T @ vi)
    want = np.linalg.slogdet(v)[1] + np.linalg.slogdet(m)[1] + r @ p_mat @ r
    assert tc.reml_objective(groups, tau2, col) == pytest.approx(want, rel=1e-10)
    st = tc._Dense(groups)
    value, grad = tc._dense_objective_and_gradient(st, tau2, col, tuple(tau2))
    for k in tau2:
        h = 1e-4 * tau2[k]
        cd = tc.reml_objective(st, {**tau2, k: tau2[k] + h}, col) - tc.reml_objective(st, {**tau2, k: tau2[k] - h}, col)
        assert grad[k] == pytest.approx(cd / (2 * h), rel=1e-6, abs=1e-9 * abs(value) / tau2[k]), k


def test_walk_estimate_recovers_the_planted_walk():
    """REML of the walk on segments and moves whose bias is an explicit cumulative sum (steps of variance 1.5 every
    half-clock: τ_w² = 3 per clock unit): the mean estimate over 20 draws within 4 standard errors of 3 (the draws'
    own spread), and a walk of zero mostly estimated as zero beside the pose scatter."""
    rng = np.random.default_rng(11)
    est = [tc.estimate_components(_walking_groups(rng, 1.5), ("pose", "move", "walk"))[0]["walk"] for _ in range(20)]
    assert abs(np.mean(est) - 3.0) < 4 * np.std(est) / np.sqrt(len(est)), (np.mean(est), np.std(est))
    zero = [tc.estimate_components(_walking_groups(rng, 0.0), ("pose", "move", "walk"))[0]["walk"] for _ in range(10)]
    assert np.median(zero) < 0.1, zero
