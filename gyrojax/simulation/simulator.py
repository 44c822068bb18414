"""Quasi-static simulation of a plan into records (conventions §5).

The instrument's indicated output comes from the same measurement model the fit uses
(:func:`gyrojax.physics.model.predict`, through its compiled code kept across processes,
:func:`gyrojax.physics.kept_model.kept_predict`), with the truth's coefficients and set-up errors, plus random drift.
Servo runs integrate the servo axis in time (``lax.scan``, RK4 between samples) so that the table angle is the
integral of the balance equation (Hu 3-59). Deterministic for a given key.
"""

from __future__ import annotations

import copy
import functools
from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.data.arrays import record_data
from gyrojax.data.plans import Plan, Run
from gyrojax.data.record import FORMAT, Record
from gyrojax.data.truth import TriadTruth, Truth, truth_from_dict
from gyrojax.errors import PlanError, TruthError
from gyrojax.noise.processes import random_drift
from gyrojax.physics import effects as fx
from gyrojax.physics import frames
from gyrojax.physics.kept_model import kept_predict
from gyrojax.physics.model import (
    Model,
    RecordData,
    check_servo,
    encoder_error,
    instrument_inputs,
    servo_rate,
    setup_values,
)


def truth_model(truth: Truth, kind: str) -> tuple[Model, np.ndarray]:
    """The model holding every effect the truth sets, and its θ."""
    coeffs = truth.all_coefficients()
    names = []
    for c, v in coeffs.items():
        e = fx.effect_of_coefficient(c)
        if v != 0.0 and e not in names:
            if kind not in fx.get(e).kinds:
                continue
            names.append(e)
    model = Model(tuple(names), kind)
    return model, model.pack({c: v for c, v in coeffs.items() if fx.effect_of_coefficient(c) in names})


def run_meta(plan: Plan, run: Run) -> dict:
    """The record JSON (conventions §5) of one run: site (latitude in deg, gravity in m/s², WGS-84 normal gravity
    when the plan gives none), table axes, instrument, mode and nominal scale factor (deg/h/mA or g/mA)."""
    g = plan.gravity_mps2
    if g is None:
        g = float(frames.normal_gravity(np.deg2rad(plan.latitude_deg)))
    kind = run.instrument["kind"]
    sf_key = "scale_factor_g_per_mA" if kind == fx.ACCEL else "scale_factor_deg_per_h_per_mA"
    return {
        "format": FORMAT,
        "name": run.name,
        "site": {"latitude_deg": plan.latitude_deg, "gravity_mps2": g},
        "table": {"axes": [{"name": n, "axis_enu": list(map(float, u))} for n, u in run.axes]},
        "instrument": copy.deepcopy(run.instrument),
        "mode": run.mode,
        sf_key: run.scale_factor,
        "servo_axis": run.servo_axis,
        "notes": f"simulated by gyrojax from plan {plan.name!r}",
    }


def run_samples(run: Run, t0: float):
    """Time (n,), true angles (n,k) deg, true rates (n,k) deg/s, segment labels (n,) of a run."""
    ts, angs, rates, labels = [], [], [], []
    t = t0
    for j, seg in enumerate(run.segments):
        tt, a, r = seg.samples()
        ts.append(t + tt)
        angs.append(a)
        rates.append(r)
        labels.append(np.full(len(tt), j if seg.label is None else seg.label))
        t = t + seg.duration_s + run.gap_s
    return np.concatenate(ts), np.concatenate(angs), np.concatenate(rates), np.concatenate(labels)


def _temperature(run: Run, t: np.ndarray) -> np.ndarray | None:
    spec = run.temperature_C
    if spec is None:
        return None
    spec = np.atleast_1d(np.asarray(spec, dtype=float))
    frac = (t - t[0]) / max(t[-1] - t[0], 1e-9)
    if spec.size == 1:
        return np.full_like(t, spec[0])
    if spec.size == 2:
        return spec[0] + (spec[1] - spec[0]) * frac
    return spec[0] + spec[1] * np.sin(2 * np.pi * (t - t[0]) / spec[2])


def _servo_integrate(model, theta, data: RecordData, setup, start, drift_rate):
    """Integrate the servo axis: θ_{k+1} = θ_k + RK4 of the null-keeping rate + ν_k Δt (rad)."""
    s = data.servo_axis

    def rate_at(angle, k):
        one = replace(
            data,
            time_s=data.time_s[k][None],
            angles=data.angles[k][None].at[0, s].set(angle),
            rates=data.rates[k][None],
            temperature=data.temperature[k][None],
            command=data.command[k][None],
            y=jnp.zeros(1),
            weight=jnp.ones(1),
            dt=jnp.zeros(0),
            rates_derived=False,
        )
        no_enc = {"delta": setup["delta"], "encoder": jnp.zeros(4)}
        r, _ = servo_rate(model, theta, one, no_enc)
        return r[0]

    def step(angle, inp):
        k, dt, nu = inp
        k1 = rate_at(angle, k)
        k2 = rate_at(angle + 0.5 * dt * k1, k)
        k3 = rate_at(angle + 0.5 * dt * k2, k)
        k4 = rate_at(angle + dt * k3, k)
        new = angle + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4) + nu * units.DEG_PER_H * dt
        return new, new

    n = data.time_s.shape[0]
    dt = jnp.diff(data.time_s)
    _, rest = jax.lax.scan(step, start, (jnp.arange(n - 1), dt, drift_rate[1:]))
    return jnp.concatenate([jnp.atleast_1d(start), rest])


_servo_integrate_jit = jax.jit(_servo_integrate, static_argnums=0)
"""Compiled once per model and record shape: a Monte Carlo of servo runs must not compile (and map code) per call."""


def plan_records(plan: Plan) -> list[Record]:
    """Geometry-only records of every run of a plan, on the campaign clock (s): the table motion and zero current
    (mA), what regressors and design need."""
    out, t0 = [], 0.0
    for run in plan.runs:
        out.append(_run_columns(plan, run, t0)[0])
        t0 += run.duration_s + plan.gap_between_runs_s
    return out


def _run_columns(plan: Plan, run: Run, t0: float):
    kind = run.instrument["kind"]
    meta = run_meta(plan, run)
    t, ang, rates, labels = run_samples(run, t0)
    cols = {"time_s": t}
    for i, (name, _) in enumerate(run.axes):
        cols[f"angle_{name}_deg"] = ang[:, i].copy()
    for i, (name, _) in enumerate(run.axes):
        cols[f"rate_{name}_dps"] = rates[:, i].copy()
    cols["segment"] = labels.astype(float)
    temp = _temperature(run, t)
    if temp is not None:
        cols["temperature_C"] = temp
    if kind == fx.TDF:
        cols["current_x_mA"] = np.zeros(len(t))
        cols["current_y_mA"] = np.zeros(len(t))
    else:
        cols["current_mA"] = np.zeros(len(t))
    return Record(meta, cols), meta, cols, t, ang


LOOP_MAX_STEP_S = 0.5
"""Longest step of the loop's exact discretisation (the matrix exponential of a stiff loop over seconds overflows)."""

LOOP_KINDS = {
    fx.SDF: "RebalanceParams",
    fx.FOG: "RebalanceParams",
    fx.RLG: "RebalanceParams",
    fx.ACCEL: "RebalanceParams",
    fx.TDF: "TDFParams",
}
"""The parameter type of the capture loop that ``simulate(dynamics="loop")`` runs each instrument kind through."""


def loop_params(loop, kind: str, where: str = "simulate"):
    """The loop parameters a run of instrument ``kind`` goes through with ``dynamics="loop"``.

    ``loop`` is None (defaults: ``loops.default_rebalance()``, ``tdfloop.default_tdf()``), one parameter object
    (``RebalanceParams`` for sdf-gyro, fog, rlg and pendulous-accel runs, ``TDFParams`` for tdf-gyro runs) or a dict
    {instrument kind: parameters} for plans that mix kinds (kinds left out take the defaults). A parameter object of
    the wrong type for the kind raises :class:`PlanError` naming the run and the kind.
    """
    from gyrojax.dynamics.loops import RebalanceParams, default_rebalance
    from gyrojax.dynamics.tdfloop import TDFParams, default_tdf

    want = TDFParams if kind == fx.TDF else RebalanceParams
    if kind not in LOOP_KINDS:
        raise PlanError(
            f"{where}: no capture-loop model for instrument kind {kind!r}; dynamics='loop' covers {sorted(LOOP_KINDS)}"
        )
    if isinstance(loop, dict):
        unknown = sorted(set(loop) - set(LOOP_KINDS))
        if unknown:
            raise PlanError(f"{where}: loop dict has unknown instrument kind(s) {unknown}; valid: {sorted(LOOP_KINDS)}")
        loop = loop.get(kind)
    if loop is None:
        return default_tdf() if kind == fx.TDF else default_rebalance()
    if not isinstance(loop, want):
        raise PlanError(
            f"{where}: a {kind} run needs loop={want.__name__} (gyrojax.dynamics."
            f"{'tdfloop' if kind == fx.TDF else 'loops'}), got {type(loop).__name__}; for a plan mixing instrument "
            f"kinds pass a dict {{kind: parameters}}"
        )
    return loop


@functools.cache
def _sdf_rate_jit():
    """``loops.loop_indicated_rate`` compiled once per input length (the hold step is traced)."""
    from gyrojax.dynamics.loops import loop_indicated_rate

    return jax.jit(loop_indicated_rate)


@functools.cache
def _tdf_rates_jit():
    """``tdfloop.tdf_indicated_rates`` compiled once per input length (the hold step is traced)."""
    from gyrojax.dynamics.tdfloop import tdf_indicated_rates

    return jax.jit(tdf_indicated_rates)


def _hold_blocks(rec: Record):
    """(sample indices, hold step s, sub-steps per sample) of each continuous segment with two samples or more.

    Each sample's input is held for the segment's median interval, split into ``m`` equal sub-steps of at most
    LOOP_MAX_STEP_S; the loop starts each segment at the equilibrium of its first input (the table moved unlogged
    in between, conventions §5)."""
    seg, t = rec.segment_id, rec.time_s
    for sid in np.unique(seg):
        idx = np.flatnonzero(seg == sid)
        if len(idx) < 2:
            continue
        dt = float(np.median(np.diff(t[idx])))
        m = max(1, int(np.ceil(dt / LOOP_MAX_STEP_S)))  # a long hold is the same hold repeated in shorter steps
        yield idx, dt / m, m


def _through_loop(ind: np.ndarray, rec: Record, loop) -> np.ndarray:
    """Pass a quasi-static indicated rate through the rebalance loop's dynamics, continuous segment by segment
    (each sample held for its interval, Hu 2-50 to 2-56). The torquer's own scale-factor errors are the effect
    model's (``sf_error`` …), so the loop's are zeroed here to count them once."""
    import dataclasses

    params = dataclasses.replace(loop, E_SF=0.0, E_A=0.0, E_2=0.0)
    out = np.array(ind, dtype=float)
    for idx, h, m in _hold_blocks(rec):
        held = np.repeat(out[idx], m)
        out[idx] = np.asarray(_sdf_rate_jit()(params, held, h))[m - 1 :: m]
    return out


def _through_tdf_loop(omega: np.ndarray, sensed: np.ndarray, rec: Record, params) -> np.ndarray:
    """Both TDF channels (n, 2) through the DTG capture loops (:mod:`gyrojax.dynamics.tdfloop`), segment by segment as
    :func:`_through_loop`: the case rate ``omega`` (n, 2) about X, Y (deg/h) enters as the rate input, the rest of
    the quasi-static sensed rate ``sensed`` − ``omega`` (drift coefficients and random drift, deg/h) as the drift
    torque; each reading is the loop's S_nom·i at the end of the sample's hold (Hu 3-94, 5-64 to 5-68). The
    loop's torquer errors (E_SF_X, E_SF_Y, μ_XY, μ_YX) are kept: no TDF effect models them."""
    out = np.array(sensed, dtype=float)
    drift = out - omega
    for idx, h, m in _hold_blocks(rec):
        w, d = np.repeat(omega[idx], m, axis=0), np.repeat(drift[idx], m, axis=0)
        out[idx] = np.asarray(_tdf_rates_jit()(params, w, h, d))[m - 1 :: m]
    return out


def simulate_run(
    plan: Plan, run: Run, truth: Truth, key, t0: float = 0.0, dynamics: str = "quasi-static", loop=None
) -> Record:
    """One record of a plan (see :func:`simulate`; ``t0``: the run's start on the campaign clock, s)."""
    kind = run.instrument["kind"]
    where = f"plan {plan.name!r}, run {run.name!r}"
    rec, meta, cols, t, ang = _run_columns(plan, run, t0)
    model, theta = truth_model(truth, kind)
    theta = jnp.asarray(theta)
    data = record_data(rec)
    setup = _setup_dict(truth)
    enc = rec.encoder_axis_index
    if run.mode == "servo":
        check_servo(data, where)
        s = rec.servo_axis_index
        drift = random_drift(key, t, truth.noise)
        start = jnp.deg2rad(ang[0, s])
        true_s = np.asarray(_servo_integrate_jit(model, theta, data, setup, start, drift))
        read = true_s + (np.asarray(encoder_error(setup["encoder"], jnp.asarray(true_s))[0]) if s == enc else 0.0)
        cols[f"angle_{run.axes[s][0]}_deg"] = np.rad2deg(read)
        cols[f"rate_{run.axes[s][0]}_dps"] = np.rad2deg(np.gradient(true_s, t))
        return Record(meta, cols)
    params = loop_params(loop, kind, where) if dynamics == "loop" else None
    # rebalance: read angle on the encoder axis carries h(θ_true)
    h = np.asarray(encoder_error(setup["encoder"], jnp.deg2rad(jnp.asarray(ang[:, enc])))[0])
    cols[f"angle_{run.axes[enc][0]}_deg"] = ang[:, enc] + np.rad2deg(h)
    data = record_data(Record(meta, cols))
    ind = np.asarray(kept_predict(model, theta, data))
    if kind == fx.TDF:
        k1, k2 = jax.random.split(key)
        n = len(t)
        sensed = np.stack(
            [
                ind[:n] + np.asarray(random_drift(k1, t, truth.noise)),
                ind[n:] + np.asarray(random_drift(k2, t, truth.noise)),
            ],
            axis=1,
        )
        if params is not None:
            x = instrument_inputs(data, setup_values(model, theta))
            omega = np.stack([np.asarray(x["w_X"]), np.asarray(x["w_Y"])], axis=1)
            sensed = _through_tdf_loop(omega, sensed, Record(meta, cols), params)
        cols["current_x_mA"] = sensed[:, 0] / run.scale_factor
        cols["current_y_mA"] = sensed[:, 1] / run.scale_factor
    else:
        if params is not None:
            ind = _through_loop(ind, Record(meta, cols), params)
        # an accelerometer's noise terms are in its output unit, g in place of deg/h (docs/conventions.md §9.6)
        noise = np.asarray(random_drift(key, t, truth.noise))
        cols["current_mA"] = (ind + noise) / run.scale_factor
    return Record(meta, cols)


def _setup_dict(truth: Truth) -> dict:
    tilt = truth.setup.get("table_tilt", (0.0, 0.0))
    az = truth.setup.get("table_azimuth", (0.0,))
    enc = truth.setup.get("encoder_harmonic", (0.0, 0.0, 0.0, 0.0))
    delta = jnp.asarray([tilt[0], tilt[1], az[0]]) * units.ARCSEC
    return {"delta": delta, "encoder": jnp.asarray(enc, dtype=jnp.float64) * units.ARCSEC}


def quantise_angles(records, q_arcsec: float) -> list[Record]:
    """The records with every table angle read through a readout of step ``q_arcsec`` (arcsec): rounded to the
    nearest step, as an encoder or a digitised resolver reads it (its error uniform, variance q²/12)."""
    if not q_arcsec > 0:
        raise PlanError(f"the readout step must be > 0 arcsec, got {q_arcsec!r}")
    q_deg = q_arcsec / 3600.0
    out = []
    for r in records:
        cols = dict(r.columns)
        for a in r.axis_names:
            key = f"angle_{a}_deg"
            cols[key] = np.round(np.asarray(cols[key]) / q_deg) * q_deg
        out.append(Record(r.meta, cols))
    return out


def simulate(
    plan: Plan, truth, key=None, seed: int = 0, dynamics: str = "quasi-static", loop=None, start_s: float = 0.0
) -> list[Record]:
    """Simulate every run of ``plan`` with ``truth`` (a :class:`Truth` or a truth dict) into records.

    Runs follow each other on one campaign clock, the first starting at ``start_s`` (s; a later test of a campaign
    starts after the earlier ones, so that a trend in time is continuous). Each run draws its noise from
    ``fold_in(key, run index)``, so a run's noise does not depend on the others. Records carry conventions §5 units:
    time in s, angles in deg, rates in deg/s, current in mA.

    ``dynamics="quasi-static"`` (default) writes the balance equation sample by sample. ``dynamics="loop"`` passes
    what the instrument senses through its capture loop, continuous segment by segment (each sample held for its
    interval, the loop starting each segment at equilibrium), and records the loop's torquer current at the end of
    each hold; at the plans' low input frequencies it reproduces the quasi-static record within the loop's static
    error, and it shows the loop's lag on oscillating or fast-changing tables. ``loop`` chooses the loop per kind:

    - ``sdf-gyro``, ``fog``, ``rlg``: the analog rebalance loop (:mod:`gyrojax.dynamics.loops`, Hu 2-50 to 2-56),
      ``loop`` a ``RebalanceParams`` (default ``default_rebalance()``); the torquer's E_SF, E_A, E_2 are the truth's
      effects, so the loop's own are zeroed. fog and rlg have no loop model of their own: they get this one as a
      stand-in with unit DC gain and the loop's bandwidth.
    - ``tdf-gyro``: both channels through the DTG capture loops (:mod:`gyrojax.dynamics.tdfloop`), ``loop`` a
      ``TDFParams`` (default ``default_tdf()``): the case rate about X, Y is the rate input, the truth's drift terms
      and random drift the drift torque. A constant input reads S⁻¹(ω + d) (``tdf_static_matrix``); the loop's torquer
      errors E_SF_X, E_SF_Y, μ_XY, μ_YX are kept (no TDF effect carries them).
    - ``pendulous-accel``: the pendulum obeys the float's equation with pendulosity·a in place of H·ω (Hu 3-38),
      so its indicated output (g) goes through the rebalance loop of ``loop`` (a ``RebalanceParams``) as a rate
      would: same closed-loop transfer, unit DC gain.

    A plan that mixes kinds takes a dict {kind: parameters} (kinds left out get the defaults). A parameter object
    of the wrong type for a run's kind raises :class:`~gyrojax.errors.PlanError` naming the run and the kind.
    Servo runs are integrated in time (the table's balance, Hu 3-59) either way.
    """
    if dynamics not in ("quasi-static", "loop"):
        raise ValueError(f"dynamics must be 'quasi-static' or 'loop', got {dynamics!r}")
    if not isinstance(truth, (Truth, TriadTruth)):
        truth = truth_from_dict(truth)
    if isinstance(truth, TriadTruth):
        raise TruthError(
            "an imu-triad truth is simulated by hand sessions (gyrojax.simulation.triad_session, gyrojax campaign), "
            "not on a turntable plan"
        )
    if key is None:
        key = jax.random.PRNGKey(seed)
    out, t0 = [], float(start_s)
    for i, run in enumerate(plan.runs):
        out.append(simulate_run(plan, run, truth, jax.random.fold_in(key, i), t0, dynamics, loop))
        t0 += run.duration_s + plan.gap_between_runs_s
    return out
