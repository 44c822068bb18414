"""``bias_turn_on`` as a term of the triad fit (gyrojax.inference.triad_turn_on; conventions §9.3): one bias per
power-up, acting on its rests, rotations and moves alike.

Checked against what the code did not compute: the moves' derivative in a step against central differences of the
move residual; the fit's invariance when a power-up's every indicated sample is raised by β (the step is then β to
rounding, every other coefficient that of the two power-ups without a step); the step's size and σ on the
independent writer's two power-ups against the planted step and the plain reference's GLS of the rests
(tests/reference_analysis.py); refusals where it cannot be fitted; the loop (proposed, added, adequate) through
``gj.add_and_refit`` and a saved fit read back; the bias walk restarting at each power-up, against the reference's
covariance."""

import numpy as np
import pytest

import gyrojax as gj
from gyrojax.data.record import Record
from gyrojax.data.triad_segments import triad_segments
from gyrojax.errors import ModelError
from gyrojax.inference import triad as tf
from gyrojax.inference import triad_components as tc
from gyrojax.inference.triad_result import load_triad_fit
from gyrojax.inference.triad_rows import pack_moves
from gyrojax.inference.triad_turn_on import check, move_rows_with_steps, power_ups
from gyrojax.physics import triad as tp

from . import independent_triad_writer as itw
from . import reference_analysis as ra

SMALL = {"poses": 14, "rest_s": 2.0, "move_s": 1.5, "rate_hz": 50.0, "gap_s": 30.0, "scatter_dph": 5.0}
NOISE_DPS = 0.05  # the writer's gyro noise (its default)


@pytest.fixture(scope="module")
def step_session(tmp_path_factory):
    """Two power-ups of the independent writer, the second's bias 80 deg/h higher on x: (records, truth)."""
    recs, truth = itw.power_up_records(3, step={"x": 80.0}, **SMALL)
    paths = itw.write(tmp_path_factory.mktemp("turn-on"), recs)
    return gj.load_records(paths), truth, paths


def _shifted(record: Record, beta_dph, name: str, dt_s: float) -> Record:
    """``record`` renamed, later by ``dt_s`` and with every gyro sample raised by ``beta_dph`` (3,) deg/h."""
    cols = dict(record.columns)
    for c, ch in enumerate(tp.CHANNELS):
        cols[f"gyro_{ch}_dps"] = np.asarray(cols[f"gyro_{ch}_dps"]) + beta_dph[c] / 3600.0
    cols["time_s"] = np.asarray(cols["time_s"]) + dt_s
    return Record({**record.meta, "name": name}, cols)


def test_move_derivative_in_a_step_is_central_differences(step_session):
    """The moves' whitened rows at θ with the steps, differentiated in each step by central differences of the
    rows themselves (h = 1 deg/h: the rows are smooth in a bias of 100 deg/h to well below 1e-6), agree with the
    Jacobian columns the fit uses (the D_F columns on that power-up's moves) to 1e-6 of the column's size."""
    recs, _, _ = step_session
    model = tp.channel_model(itw.MODEL)
    moves, mv_rec = [], []
    for i, r in enumerate(recs):
        mv = triad_segments(r)[3]
        moves += mv
        mv_rec += [i] * len(mv)
    pu = power_ups(model, [], mv_rec, 2, True)
    packed = pack_moves(moves)
    w = tf.move_whitening(moves, np.full(3, 180.0**2), np.eye(3))
    theta = np.zeros(3 * model.size + 3)
    theta[[c * model.size for c in range(3)]] = [400.0, -300.0, 150.0]  # D_F of each channel
    theta[-3:] = [80.0, -20.0, 10.0]
    _r, _rows, jac = move_rows_with_steps(model, theta, packed, w, pu)
    for j in range(3 * model.size, len(theta)):
        hi, lo = theta.copy(), theta.copy()
        hi[j] += 1.0
        lo[j] -= 1.0
        fd = (move_rows_with_steps(model, hi, packed, w, pu)[1] - move_rows_with_steps(model, lo, packed, w, pu)[1]) / 2
        # the rows are y − f: their derivative is −∂f/∂β, the Jacobian's column is ∂f/∂β
        assert np.max(np.abs(-fd - jac[:, j])) < 1e-6 * np.max(np.abs(jac[:, j])), j
        first = np.repeat(np.asarray(mv_rec) == 0, 2)
        assert np.all(jac[first, j] == 0.0) and np.any(jac[~first, j] != 0.0)


def test_a_raised_power_up_is_its_step(step_session):
    """The first power-up and a copy of it 1 h later with every gyro sample raised by β: fitted with bias_turn_on the
    step is β to rounding, every channel coefficient and χ² are those of the fit of the two copies unraised without
    a step (the normal equations are the same: the copy's residuals are the first's), and so is every σ but D_F's,
    which is then the first power-up's bias alone (larger)."""
    recs, _, _ = step_session
    beta = np.array([37.0, -55.0, 12.5])
    a = recs[0]
    raised = tf.fit_triad([a, _shifted(a, beta, "raised", 3600.0)], itw.MODEL + ("bias_turn_on",), components=False)
    plain = tf.fit_triad([a, _shifted(a, np.zeros(3), "copy", 3600.0)], itw.MODEL, components=False)
    steps = [raised.values[f"D_F_step_1[{c}]"] for c in tp.CHANNELS]
    assert np.allclose(steps, beta, rtol=0, atol=1e-6), steps
    n = len(plain.names)
    assert raised.names[:n] == plain.names and raised.terms[-1] == "bias_turn_on"
    assert np.allclose(raised.theta[:n], plain.theta, rtol=1e-7, atol=1e-6)
    bias = np.array([name.startswith("D_F[") for name in plain.names])
    assert np.allclose(raised.std[:n][~bias], plain.std[~bias], rtol=1e-6)
    assert np.all(raised.std[:n][bias] > plain.std[bias])  # D_F: the first power-up's bias alone
    assert raised.chi2 == pytest.approx(plain.chi2, rel=1e-7)


def test_step_against_the_planted_and_the_reference(step_session):
    """On the writer's two power-ups (80 deg/h on x, 5 deg/h scatter between rests) the fitted steps are within 3σ
    of the truth on every channel, and the x step and its σ agree with the reference's GLS of the rests at the true
    scatter (within 2 of its σ; σ within 30 %: gyrojax estimates the scatter by REML and sees the moves too)."""
    recs, truth, paths = step_session
    fit = gj.fit(recs, itw.MODEL + ("bias_turn_on",))
    for c in tp.CHANNELS:
        name = f"D_F_step_1[{c}]"
        z = (fit.values[name] - truth["coefficients"][name]) / fit.stds[name]
        assert abs(z) < 3, (name, fit.values[name], fit.stds[name])
    ref = ra.triad_gls(paths, NOISE_DPS, {"scatter": SMALL["scatter_dph"] ** 2}, ("bias_turn_on[x]",))
    value, sd = ref["bias_turn_on[x]"]
    assert abs(fit.values["D_F_step_1[x]"] - value) < 2 * sd, (fit.values["D_F_step_1[x]"], value, sd)
    assert fit.stds["D_F_step_1[x]"] == pytest.approx(sd, rel=0.3)


def test_the_loop_adds_the_step_and_closes(step_session, tmp_path):
    """gj.add_and_refit: the step proposed, added, then adequate with nothing proposed; the fit saved and read back
    keeps its steps and terms, and apply calibrates each fitted power-up with its own bias."""
    recs, _, _ = step_session
    d = gj.diagnose(recs, itw.MODEL)
    assert d.proposal == "bias_turn_on" and d.candidates[0].name == "bias_turn_on[x]"
    terms, fit, after, added = gj.add_and_refit(recs, itw.MODEL, diagnosis=d)
    assert added == "bias_turn_on" and terms[-1] == "bias_turn_on" and fit.terms == terms
    assert after.verdict == "adequate" and after.proposal is None
    assert not [c for c in after.candidates if c.name.startswith("bias_turn_on")]
    assert after.to_json()["terms"][-1] == "bias_turn_on"
    back = load_triad_fit(fit.save(tmp_path / "fit.json"))
    assert back.names == fit.names and back.terms == fit.terms and np.allclose(back.theta, fit.theta)
    w0, w1 = fit.apply(recs[0]), fit.apply(recs[1])
    first = tf.fit_triad(recs, itw.MODEL + ("bias_turn_on",))  # the same fit: the second power-up by its own bias
    assert np.allclose(w1, first.apply(recs[1])) and w0.shape == fit.apply(recs[0]).shape
    s_inv = np.linalg.inv(fit.matrices()["S"])
    without = fit.apply(Record({**recs[1].meta, "name": "another power-up"}, recs[1].columns))
    step = np.array([fit.values[f"D_F_step_1[{c}]"] for c in tp.CHANNELS])
    assert np.allclose(without - w1, s_inv @ step, atol=1e-6)  # a power-up not fitted: the first's bias


def test_refused_where_it_cannot_be_fitted(step_session):
    """One record (one power-up has no step), a model without D_F, a power-up without a rest (rotations alone): each
    refused naming why."""
    recs, _, _ = step_session
    with pytest.raises(ModelError, match="two or more power-ups.*1 record"):
        gj.fit(recs[:1], itw.MODEL + ("bias_turn_on",))
    with pytest.raises(ModelError, match="add D_F"):
        gj.fit(recs, ("sf_error", "bias_turn_on"))
    model = tp.channel_model(itw.MODEL)
    with pytest.raises(ModelError, match="power-up 'b' has no rest"):  # a power-up of rotations alone
        check(model, ["a", "b"], [["static", "rotation"], ["rotation", "rotation"]])
    check(model, ["a", "b"], [["static"], ["static", "rotation"]])


def test_single_power_up_fits_are_unchanged(step_session):
    """Without the term a fit of two power-ups has no step coefficient and its terms are the channel model's; the
    diagnosis offers bias_turn_on as a candidate only with two or more records."""
    recs, _, _ = step_session
    fit = gj.fit(recs, itw.MODEL)
    assert fit.terms == itw.MODEL and fit.power_ups == 1 and len(fit.names) == 3 * fit.model.size
    one = gj.diagnose(recs[:1], itw.MODEL)
    assert not [c for c in one.candidates if c.name.startswith("bias_turn_on")]


def test_the_walk_restarts_at_each_power_up():
    """The bias walk's covariance over the rests of two power-ups (5 and 4 rests, on one clock) is the reference's
    (tests/reference_analysis.py: min(rank k, rank l) within a record, 0 across): each power-up walks from its own
    turn-on bias, so a walk never passes for a step between power-ups."""
    record = np.array([0] * 5 + [1] * 4)
    rank = np.concatenate([np.arange(5), np.arange(4)]).astype(float)
    k = len(record)
    rests = ra.Rests(
        np.zeros((k, 3)), np.tile([0.0, 0.0, 1.0], (k, 1)), np.ones(k), np.arange(k, dtype=float),
        np.zeros((k, 2)), record, rank, 45.0,
    )  # fmt: skip
    want = ra.triad_covariances(rests, NOISE_DPS)["steps"]
    groups = [tc.Group(np.eye(3), np.zeros(3), np.zeros((3, 1)), "pose", float(i), power_up=int(p))
              for i, p in enumerate(record)]  # fmt: skip
    offsets = np.arange(0, 3 * k + 1, 3)
    assert np.array_equal(tc.walk_covariance(groups, offsets), want)
