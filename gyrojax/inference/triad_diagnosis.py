"""The triad records' part of the diagnosis (:mod:`gyrojax.inference.diagnose`): the candidates of a hand session,
its rows and its noise between segments.

Every candidate is a set of regressors R(ω, a, t, T) (deg/h per coefficient unit) added to the indicated rate of one
channel c — a named effect of the registry through the channel's SDF inputs (Hu 2-45; conventions §6), a MEMS
candidate (conventions §9: ``bias_turn_on``, ``time_offset``) or a model-free shape (cross-axis rate products,
|ω|, a bias while moving, t²). Its columns in the fit's rows:

* static pose or known-angle rotation: the mean of R over the segment's samples (as the fit models a segment mean);
* gravity-to-gravity move: the first-order change of the move's attitude residual when channel c indicates R β
  more, ∂r/∂β = −Σ_l (∂r/∂g_{l,c}) R_l (one Jacobian of the move integration by the current linear model, at the
  fit), so that every candidate is carried along the moves as the fit carries its own terms.

Rows and columns are whitened as the fit whitens them (segment-mean covariance with the per-pose bias scatter,
move angle noise with the per-move angle component, both REML; :mod:`gyrojax.inference.triad_components`), and the
forward selection of the noise re-estimates those components with the candidates it takes in. The shapes compete in
that selection with the named candidates, and are tested beside every named candidate with σ̃² after them all
(F law). The noise processes between segments — ``pose_bias_scatter`` (an independent bias level at each pose),
``move_angle_noise`` (a per-move angle error) and ``bias_random_walk`` (a bias that walks from pose to pose: steps
at each move that persist, or a rate random walk; each power-up's from its own turn-on bias) — are tested by the
REML likelihood ratio of their variance component against zero (boundary: p = ½ P(χ²₁ > LR); the walk's against
the independent scatter alone, the other components re-estimated), as ``gauss_markov`` is on a turntable; they are
noise, never proposed as deterministic effects. Where the walk is significant it whitens every test (the rows then
as one dense covariance), from the first round of the forward selection on: a trend enters only when it beats the
walk, and a candidate that the walk and it explain alike is said to be indistinguishable from drift. Sizes are
checked against the MEMS limits of :mod:`gyrojax.physics.plausibility`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import jax
import numpy as np

from gyrojax import units
from gyrojax.data.record import Record
from gyrojax.data.triad import gyro_dph
from gyrojax.data.triad_segments import triad_segments
from gyrojax.errors import ModelError
from gyrojax.inference import triad as tf
from gyrojax.inference.adequacy import near_aliases
from gyrojax.inference.instrument import Rules, Session
from gyrojax.inference.scoring import ALPHA, candidates, residual_variance, score, score_beside, score_tests
from gyrojax.inference.subspace import WhitenedSystem, basis
from gyrojax.inference.triad_components import (
    boundary_p,
    column_scale,
    estimate_components,
    reml_objective,
    select_components,
    whiten_rows,
)
from gyrojax.inference.triad_rows import (
    channel_matrices,
    move_residual,
    pack_moves,
    pack_segments,
    segment_rows,
)
from gyrojax.inference.triad_turn_on import TURN_ON, move_rows_with_steps, power_ups
from gyrojax.inference.verdict import Candidate, Structure
from gyrojax.physics import effects as fx
from gyrojax.physics import plausibility
from gyrojax.physics import triad as tp
from gyrojax.physics.kept_model import kept_call

NOISE_PROCESSES = {"pose": "pose_bias_scatter", "move": "move_angle_noise", "walk": "bias_random_walk"}
"""Variance components between segments (:mod:`gyrojax.inference.triad_components`), tested as noise, by the names
the diagnosis gives them."""
RULES = Rules(retest_shapes=False, refit_budget=None, skip_aliased=True, plausible_before_refit=True)
"""Triad proposals: a candidate's size is judged on its one-step estimate, and an implausible or aliased candidate
(two channels' columns collinear) is passed over before any refit; every significant candidate may be refitted in
rank order until one is accepted; the shapes are tested once, beside every named candidate."""
SHAPE_VERSUS = {
    "rate_cross": "body-rate products",
    "rate_magnitude": "|ω|",
    "motion_bias": "motion",
    "time_quadratic": "time",
}
"""The input each model-free shape is a shape of."""

MEMS_CANDIDATES = ("bias_turn_on", "time_offset")
"""Triad candidates beyond the registry (conventions §9): a bias step at each turn-on (one level per record after
the first, per channel, deg/h; the fit's term :mod:`gyrojax.inference.triad_turn_on`) and a time offset between the
gyro and accelerometer streams (one for the triad, s; no fit term)."""

SHAPES = ("rate_cross", "rate_magnitude", "motion_bias", "time_quadratic")
"""Model-free residual shapes per channel: ω_I ω_O, ω_I ω_S, ω_O ω_S ((deg/s)²); |ω| (deg/s); a bias present only
while the body moves (the residual against a move's duration); t² (h²)."""
SHAPE_LINES = {
    "rate_cross": "products of body rates about two axes (ω_I ω_O, ω_I ω_S, ω_O ω_S), deg/h per (deg/s)²",
    "rate_magnitude": "the body rate's magnitude |ω| (peak rate of a move), deg/h per deg/s",
    "motion_bias": "a bias present only while the body moves (∝ a move's duration), deg/h",
    "time_quadratic": "a quadratic drift in time, deg/h/h²",
}


@dataclass(frozen=True)
class Regressor:
    """One candidate or shape on one channel (``channel`` None: on all three at once, as ``time_offset``)."""

    name: str
    effect: str
    channel: int | None
    coefficients: tuple
    units: tuple
    func: object  # (inputs dict of one channel or of the triad) -> (n, k) deg/h per coefficient unit


def _named(name: str, c: int) -> Regressor:
    eff = fx.get(name)

    def func(x, eff=eff):
        k = len(eff.coefficients)
        return np.column_stack(
            [np.asarray(eff.contribution(x, np.eye(k)[i])) * np.ones(len(x["t_h"])) for i in range(k)]
        )

    return Regressor(f"{name}[{tp.CHANNELS[c]}]", name, c, eff.coefficients, eff.units, func)


def _shape(name: str, c: int) -> Regressor:
    def func(x, name=name):
        dps = 1.0 / units.SECONDS_PER_HOUR
        wi, wo, ws = (np.asarray(x[k]) * dps for k in ("w_I", "w_O", "w_S"))
        if name == "rate_cross":
            return np.column_stack([wi * wo, wi * ws, wo * ws])
        if name == "rate_magnitude":
            return np.sqrt(wi**2 + wo**2 + ws**2)[:, None]
        if name == "motion_bias":
            return np.asarray(x["moving"], dtype=float)[:, None]
        return ((np.asarray(x["t_h"]) - x["t_mid"]) ** 2 * np.ones(len(wi)))[:, None]

    n_coef = 3 if name == "rate_cross" else 1
    unit = {"rate_cross": "deg/h/(deg/s)^2", "rate_magnitude": "deg/h/(deg/s)", "motion_bias": "deg/h"}
    return Regressor(
        f"{name}[{tp.CHANNELS[c]}]", name, c, (name,) * n_coef, (unit.get(name, "deg/h/h^2"),) * n_coef, func
    )


def candidate_regressors(model, data, candidates=None) -> list:
    """The named and MEMS candidates of every channel absent from ``model`` that the session can carry."""
    names = candidates
    if names is None:
        temp = np.concatenate([x["temperature_C"] for x in data["inputs"]])
        names = [
            n
            for n in fx.names(fx.SDF)
            if n not in model.terms
            and n not in tp.TURNTABLE_ONLY
            and fx.get(n).knee is None  # a knee is fitted on turntable records only
            and (n != "bias_temperature" or np.ptp(temp) > 1e-6)
        ]
        fitted = data["power_ups"].count > 1  # the fit has the steps: no candidate of them
        names += [n for n in MEMS_CANDIDATES if n != TURN_ON or (data["n_records"] > 1 and not fitted)]
    out = []
    for n in names:
        if n == "bias_turn_on":
            k = data["n_records"] - 1
            if k < 1:
                raise ModelError("bias_turn_on needs records of two or more turn-ons")
            for c in range(3):
                out.append(
                    Regressor(
                        f"bias_turn_on[{tp.CHANNELS[c]}]",
                        n,
                        c,
                        tuple(f"D_F_step_{i + 1}" for i in range(k)),
                        ("deg/h",) * k,
                        lambda x, k=k: np.eye(k + 1)[np.asarray(x["record"], dtype=int)][:, 1:],
                    )
                )
        elif n == "time_offset":
            out.append(Regressor("time_offset", n, None, ("dt_acc",), ("s",), lambda x: x["g_dot"][..., None]))
        elif n in fx.names(fx.SDF) and n not in tp.TURNTABLE_ONLY:
            out.extend(_named(n, c) for c in range(3))
        else:
            raise ModelError(f"unknown triad candidate {n!r} (registry effects, {', '.join(MEMS_CANDIDATES)})")
    return out


def shape_regressors() -> list:
    """The model-free shapes of every channel (:data:`SHAPES`)."""
    return [_shape(s, c) for s in SHAPES for c in range(3)]


# ---- the rows of the fit ----------------------------------------------------------------------------------------

_move_dr_dg = jax.vmap(jax.jacrev(move_residual, argnums=2), in_axes=(None, None, 0, 0, 0, 0, 0, 0, 0, 0))
_move_dr_dg_jit = jax.jit(_move_dr_dg, static_argnums=0)


def move_dr_dg(model, theta, packed) -> np.ndarray:
    """∂r/∂g (M, 3, L, 3) of every move's residual in its indicated samples at θ (the channel coefficients),
    ``packed`` from :func:`~gyrojax.inference.triad_rows.pack_moves`; one compiled pass, kept across processes."""
    th = np.asarray(theta, dtype=float)
    return np.asarray(kept_call("triad_move_dr_dg", _move_dr_dg, _move_dr_dg_jit, model, th, *packed))


def session_data(records, fit, earth_rate=None) -> dict:
    """The fit's rows rebuilt at its θ: segments and moves, the whitened residual and Jacobian of the current model
    (with the fit's variance components), and each segment's and move's channel inputs for the regressors (rates
    in deg/h, specific force in g, time in h); ``earth_rate`` as :func:`gyrojax.inference.triad.fit_triad` takes it."""
    recs = [records] if isinstance(records, Record) else list(records)
    model, theta = fit.model, np.asarray(fit.theta, dtype=float)
    if fit.power_ups > 1 and fit.power_ups != len(recs):
        raise ModelError(f"the fit has the bias of {fit.power_ups} power-ups; {len(recs)} records are diagnosed")
    segments, moves, seg_rec, mv_rec, mv_times = [], [], [], [], []
    for i, r in enumerate(recs):
        s, _q, _mode, mv = triad_segments(r, earth_rate)
        segments.extend(s)
        moves.extend(mv)
        seg_rec += [i] * len(s)
        mv_rec += [i] * len(mv)
        mv_times.extend((m.t_h, m.temp) for m in mv)  # the samples the fit integrates
        gyro_dph(r)  # refuses a record without gyro columns here, by name
    q = np.asarray(fit.noise_q, dtype=float)
    pu = power_ups(model, seg_rec, mv_rec, len(recs), fit.power_ups > 1)
    th_ch = pu.split(theta)[0]  # the channel coefficients, without the power-ups' bias steps (triad_turn_on)
    b, s_mat, g_mat = channel_matrices(model, th_ch)
    comp = fit.variance_components or {}
    tau2_fit = tf.components_tau2(comp)
    tau2 = {"pose": tau2_fit.get("pose", 0.0), "move": tau2_fit.get("move", 0.0)}
    arrays = pack_segments(segments)
    y = np.concatenate([sg.y for sg in segments])
    y_model, jac_model = segment_rows(model, th_ch, arrays, len(segments))
    resid = y - y_model - pu.bias_of(theta, seg_rec).reshape(-1)
    jac = pu.segment_jacobian(jac_model)
    t_all = np.concatenate([sg.t_h for sg in segments] + [t for t, _ in mv_times])
    t_mid = 0.5 * (t_all.min() + t_all.max())

    def x(w, a, t_h, temp, record, moving, g_dot):  # one segment's or move's channel inputs, sample by sample
        n = len(t_h)
        keys = ("w", "a", "t_h", "temperature_C", "record", "moving", "g_dot")
        out = dict(zip(keys, (w * np.ones((n, 3)), a * np.ones((n, 3)), t_h, temp, np.full(n, record), moving, g_dot)))
        return {**out, "t_mid": t_mid}

    inputs = [
        x(sg.w, sg.a, sg.t_h, sg.temp, ri, np.full(len(sg.t_h), sg.kind == "rotation"), np.zeros((len(sg.t_h), 3)))
        for sg, ri in zip(segments, seg_rec)
    ]
    data = {
        "model": model,
        "theta": theta,
        "segments": segments,
        "moves": moves,
        "q": q,
        "s_mat": s_mat,
        "tau2": tau2,
        "resid": resid,
        "jac": jac,
        "n_records": len(recs),
        "power_ups": pu,
        "seg_inputs": inputs,
        "components_memo": {},
    }
    data["inputs"] = list(inputs)
    data["seg_stacked"] = _stacked(inputs)
    if moves:
        packed = pack_moves(moves)
        move_w = tf.move_whitening(moves, q, s_mat, tau2["move"])
        _, mr, mj = move_rows_with_steps(model, theta, packed, move_w, pu)
        data.update(packed=packed, move_w=move_w, move_r=mr, move_j=mj)
        # the rows without the angle noise, whose REML groups estimate it (_groups)
        if tau2["move"] > 0:
            bare_w = tf.move_whitening(moves, q, s_mat)
            data["moves_bare"] = (bare_w, move_rows_with_steps(model, theta, packed, bare_w, pu)[1:])
        else:
            data["moves_bare"] = (move_w, (mr, mj))
        data["dr_dg"] = move_dr_dg(model, th_ch, pu.shifted_moves(packed, theta))  # (M, 3, L, 3)
        mv_inputs = []
        for m, ri, (t_h, temp) in zip(moves, mv_rec, mv_times):
            bias = b + pu.bias_of(theta, ri)  # the power-up's own
            w_cal = np.linalg.solve(s_mat, (m.g - bias - m.a @ g_mat.T).T).T  # deg/h, the calibrated body rate
            a_dot = np.gradient(m.a, m.dt, axis=0) if len(m.a) > 1 else np.zeros_like(m.a)
            n = len(m.g)
            mv_inputs.append(x(w_cal, m.a, t_h[:n], temp[:n], ri, np.ones(n, dtype=bool), a_dot @ g_mat.T))
        data["move_inputs"] = mv_inputs
        data["move_stacked"] = _stacked(mv_inputs)
        data["inputs"] += mv_inputs
        data["move_bias"] = np.stack([data["dr_dg"][k, :, : len(m.g), :].sum(axis=1) for k, m in enumerate(moves)])
    clock, move_clock = tf.walk_clocks(segments, moves)  # the bias walk's (triad_components)
    move_bias = [p.T @ g for (p, _sd), g in zip(data.get("move_w", []), data.get("move_bias", []))]
    data["walk"] = (clock, move_clock, move_bias, np.asarray(seg_rec), np.asarray(mv_rec))
    if "walk" in tau2_fit:  # the fit's σ carry a walk: the rows start from the independent components alone
        data = with_tau2(data, estimate_components(_groups(data, []))[0])
    return data


def _channel_x(x: dict, c: int) -> dict:
    out = tp.channel_inputs(x["w"], x["a"], x["t_h"], x["temperature_C"], c)
    out.update({k: x[k] for k in ("record", "moving", "t_mid")})
    out["g_dot"] = x["g_dot"][:, c]
    return out


def _stacked(inputs: list) -> tuple[dict, np.ndarray]:
    """The inputs of several segments as one (one evaluation of a regressor serves them all) and their bounds."""
    keys = ("w", "a", "t_h", "temperature_C", "record", "moving", "g_dot")
    x = {k: np.concatenate([np.asarray(d[k]) for d in inputs]) for k in keys}
    x["t_mid"] = inputs[0]["t_mid"]
    return x, np.cumsum([0] + [len(d["t_h"]) for d in inputs])


def raw_columns(reg: Regressor, data: dict) -> tuple[np.ndarray, np.ndarray]:
    """(segment-mean rows (3m, k), move rows (M, 3, k)) of a regressor, unwhitened (deg/h and dimensionless)."""
    chans = range(3) if reg.channel is None else (reg.channel,)
    k = len(reg.coefficients)
    seg = np.zeros((3 * len(data["segments"]), k))
    x, bounds = data["seg_stacked"]
    for c in chans:
        f = np.asarray(reg.func(_channel_x(x, c)), dtype=float)
        seg[c::3] = np.add.reduceat(f, bounds[:-1], axis=0) / np.diff(bounds)[:, None]
    mv = np.zeros((len(data["moves"]), 3, k))
    if data["moves"]:
        x, bounds = data["move_stacked"]
        for c in chans:
            f = np.asarray(reg.func(_channel_x(x, c)), dtype=float)
            for m in range(len(data["moves"])):
                lo, hi = bounds[m], bounds[m + 1]
                mv[m] += data["dr_dg"][m, :, : hi - lo, c] @ f[lo:hi]  # −∂r/∂β, the model indicating R β more
    return seg, mv


def whitened_system(data: dict, regs: list, cols: list):
    """(r̃, J̃₀, [X̃ of each regressor], [raw segment-mean rows of each]) stacked as the fit whitens its rows
    (segments, then 2 rows per move); ``cols`` the :func:`raw_columns` of ``regs``, in deg/h per coefficient unit."""
    p0 = data["jac"].shape[1]
    if data["tau2"].get("walk", 0.0) > 0:  # the walk couples every row: whitened as one (triad_components)
        r_all, j_all = whiten_rows(_groups(data, cols), data["tau2"])
    else:
        big = np.column_stack([data["jac"]] + [s for s, _ in cols]) if cols else data["jac"]
        rw, jw = tf.whiten_segments(
            data["segments"], data["resid"], big, data["q"], data["s_mat"], data["tau2"]["pose"]
        )
        blocks_r, blocks_j = [rw], [jw]
        if data["moves"]:
            mx = []
            for m, (p, sd) in enumerate(data["move_w"]):
                mx.append(np.concatenate([p.T @ mv[m] / sd for _, mv in cols], axis=1) if cols else np.zeros((2, 0)))
            blocks_r.append(data["move_r"])
            blocks_j.append(np.column_stack([data["move_j"], np.concatenate(mx, axis=0)]))
        r_all, j_all = np.concatenate(blocks_r), np.concatenate(blocks_j, axis=0)
    bounds = np.cumsum([p0] + [len(r.coefficients) for r in regs])
    return r_all, j_all[:, :p0], [j_all[:, a:b] for a, b in zip(bounds[:-1], bounds[1:])], [sg for sg, _ in cols]


def _groups(data: dict, extra: list) -> list:
    """The fit's rows as REML groups (:func:`gyrojax.inference.triad.component_groups`), beside the raw columns
    ``extra`` of the candidates taken in (:func:`raw_columns`), the moves without their angle component (what is
    estimated)."""
    move_w, moves_at = data.get("moves_bare", ([], (np.zeros(0), np.zeros((0, data["jac"].shape[1])))))
    return tf.component_groups(
        data["segments"], data["resid"], data["jac"], data["q"], data["s_mat"], moves_at, move_w, extra, data["walk"]
    )


def components(data: dict, extra: list, alpha: float) -> tuple[dict, float, list]:
    """The variance components by REML beside the candidates ``extra`` (raw columns): (τ̂², the bias walk's
    likelihood ratio, the REML groups), the walk among them only where it is significant at ``alpha``
    (:func:`gyrojax.inference.triad_components.select_components`, the rule the fit's σ follow too). The groups do
    not depend on the variance components ``data`` is whitened with (:func:`with_tau2`), so the answer is kept in
    ``data["components_memo"]``, which every ``data`` derived by :func:`with_tau2` shares."""
    key = (tuple(map(id, extra)), alpha)
    memo = data["components_memo"]
    if key not in memo:  # the extra columns are held beside the answer, so that their ids are not reused
        groups = _groups(data, extra)
        memo[key] = (list(extra), *select_components(groups, alpha), groups)
    _extra, tau2, lr, groups = memo[key]
    return dict(tau2), lr, groups


def with_components(data: dict, extra: list, alpha: float) -> dict:
    """``data`` whitened with the variance components re-estimated by REML with the candidates ``extra`` (raw
    columns) among the fixed effects (:func:`components`): a missing effect is then not taken for pose scatter
    (deg/h), move angle noise (rad) or a bias walk, and a walk is not taken for a missing effect."""
    return with_tau2(data, components(data, extra, alpha)[0])


def with_tau2(data: dict, tau2: dict) -> dict:
    """``data`` whitened with the variance components ``tau2`` ((deg/h)² per pose, rad² per move, (deg/h)² per pose
    of the walk; the moves' rows redone with their angle noise)."""
    out = dict(data)
    out["tau2"] = {"pose": tau2.get("pose", 0.0), "move": tau2.get("move", 0.0), "walk": tau2.get("walk", 0.0)}
    if data["moves"]:
        out["move_w"] = tf.move_whitening(data["moves"], data["q"], data["s_mat"], out["tau2"]["move"])
        rows = move_rows_with_steps(data["model"], data["theta"], data["packed"], out["move_w"], data["power_ups"])
        _, out["move_r"], out["move_j"] = rows
    return out


def _noise_processes(data: dict, alpha: float, extra: list) -> tuple[list, dict]:
    """REML likelihood-ratio test of each variance component between segments against zero, beside the candidates
    ``extra`` the diagnosis took in (the walk's, :func:`components`, against the independent scatter alone);
    (candidates, τ̂²)."""
    tau2, lr_walk, groups = components(data, extra, alpha)
    col = column_scale(groups)
    best = reml_objective(groups, tau2, col)
    out = []
    for kind, name in NOISE_PROCESSES.items():
        if kind not in tau2:
            continue
        lr = lr_walk if kind == "walk" else max(reml_objective(groups, {**tau2, kind: 0.0}, col) - best, 0.0)
        p = boundary_p(lr)
        sd = tf.components_report({kind: tau2[kind]}, data["s_mat"])  # the fit's report units (pose: calibrated)
        if kind == "pose":
            est = {"tau": {"value": sd["pose_bias_scatter_deg_per_h"], "unit": "deg/h"}}
        elif kind == "walk":
            est = {"tau": {"value": sd["bias_walk_deg_per_h_per_sqrt_pose"], "unit": "deg/h/sqrt(pose)"}}
        else:
            est = {"tau": {"value": sd["move_angle_noise_deg"], "unit": "deg"}}
        cand = Candidate(name, lr, 1, p, p, [], math.nan, est, log10_p=math.log10(max(p, 1e-300)))
        if p < alpha:
            out.append(cand)
    return out, tau2


# ---- the session --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Round:
    """One round of the forward selection: the rows with the variance components re-estimated (``data``), the score
    tests of every regressor under them (``scored``: (regressor, Candidate or None) for the named candidates, then
    the shapes), the whitened system they were computed on (``r``, ``j0``, ``xs``) and its residual ``dof``."""

    data: dict
    scored: list
    n_named: int
    perps: dict
    r: np.ndarray
    j0: np.ndarray
    xs: list
    dof: int
    under_scatter: dict | None = None  # name -> log10 p without the walk, where the walk whitens this round

    @property
    def candidates(self) -> list:
        """The named candidates tested (the spanned ones with df 0)."""
        return [c for _reg, c in self.scored[: self.n_named] if c is not None]

    @property
    def unexcited(self) -> list:
        """The named candidates the session does not excite."""
        return [reg.name for reg, c in self.scored[: self.n_named] if c is None]


@dataclass(frozen=True)
class TriadSession(Session):
    """Triad records at a fit, as the diagnosis sees them: the records, the fit, its rows rebuilt at θ̂
    (:func:`session_data`), the regressors of the candidates and of the shapes, and their raw columns (deg/h per
    coefficient unit); ``earth_rate`` as the triad fit takes it."""

    records: list
    fit: object
    data: dict
    regressors: list
    n_named: int
    columns: list
    earth_rate: bool | None = None
    alpha: float = ALPHA
    rules: Rules = RULES
    kind: str = fx.SDF

    @classmethod
    def of(
        cls, records, terms=None, result=None, candidates=None, earth_rate=None, model_free=True, alpha=ALPHA
    ) -> TriadSession:
        """The session of ``records`` at ``result`` (default: the triad fit of ``terms``); ``model_free``: the shapes
        are among the regressors; ``alpha`` the level at which a bias walk enters the noise model."""
        recs = [records] if isinstance(records, Record) else list(records)
        res = result or tf.fit_triad(recs, terms, earth_rate=earth_rate)
        data = session_data(recs, res, earth_rate)
        regs = candidate_regressors(res.model, data, candidates)
        allr = regs + (shape_regressors() if model_free else [])
        return cls(recs, res, data, allr, len(regs), [raw_columns(g, data) for g in allr], earth_rate, alpha)

    def _cols(self, names) -> list:
        by = {g.name: c for g, c in zip(self.regressors, self.columns)}
        return [by[n] for n in names]

    # ---- the forward selection -------------------------------------------------------------------------------

    def score(self, taken: list, previous: Round | None) -> Round:
        """The rows whitened with the variance components re-estimated with the regressors ``taken`` among the
        fixed effects, and the score tests of every regressor. Before any is taken: the fit's own components, or
        where the poses' bias walks (:func:`components`) with the walk among them — a candidate then enters the
        noise fit only when it beats the walk, and the tests without the walk are kept to say which candidates
        the walk cannot be told from (:meth:`finish`)."""
        if taken:
            rnd = self._round(with_components(self.data, self._cols(taken), self.alpha))
            return Round(**{**rnd.__dict__, "under_scatter": previous.under_scatter if previous else None})
        first = self._round(self.data)
        walking = with_components(self.data, [], self.alpha)
        if walking["tau2"]["walk"] <= 0.0:
            return first
        rnd = self._round(walking)
        scatter = {c.name: c.log10_p for _reg, c in first.scored if c is not None and c.df > 0}
        return Round(**{**rnd.__dict__, "under_scatter": scatter})

    def _round(self, data: dict) -> Round:
        """The score tests of every regressor (:func:`gyrojax.inference.scoring.candidates`) in the rows ``data``,
        each coefficient of an estimate named with its regressor's channel (``E_A[x]``), the RMS after adding it
        that of the segment-mean residuals (one step, deg/h)."""
        r, j0, xs, xr = whitened_system(data, self.regressors, self.columns)
        tests, regs, names = score_tests(r, j0, xs), self.regressors, list(self.fit.names)
        coefs = [[f"{n}[{g.name.split('[')[1]}" if "[" in g.name else n for n in g.coefficients] for g in regs]
        raw, aliases = (data["resid"], data["jac"], xr), lambda spanned_by: sorted({names[i] for i in spanned_by})
        scored, perps = candidates(
            [g.name for g in regs], tests, coefs, [g.units for g in regs], raw, aliases, math.nan
        )
        return Round(data, list(zip(regs, scored)), self.n_named, perps, r, j0, xs, tests.dof)

    def selectable(self, rnd: Round) -> list:
        """What competes to be taken into the components' fit: the named candidates and the shapes."""
        return [c for _reg, c in rnd.scored if c is not None]

    # ---- shapes, proposals ------------------------------------------------------------------------------------

    def structure(self, rnd: Round, explaining: list) -> list:
        """The shapes tested beside the model and the named candidates ``explaining``, σ̃² after them all (F law),
        unadjusted."""
        keep = set(explaining)
        named = [x for (reg, c), x in zip(rnd.scored[: self.n_named], rnd.xs) if c is not None and reg.name in keep]
        u_all = basis(np.column_stack([rnd.j0] + named))
        r_perp, s2, dof_all = residual_variance(u_all, rnd.r)
        out = []
        for (reg, c), x in zip(rnd.scored[self.n_named :], rnd.xs[self.n_named :]):
            if c is None or c.df == 0:
                continue
            sc = score(u_all, r_perp, x, s2, dof_all)
            if sc is not None:
                ch = reg.name.split("[")[1].rstrip("]")
                versus = f"{SHAPE_VERSUS[reg.effect]} (channel {ch})"
                out.append(
                    Structure(
                        reg.name,
                        versus,
                        reg.effect,
                        sc.statistic,
                        sc.df,
                        sc.p_value,
                        sc.log10_p,
                        description=SHAPE_LINES[reg.effect],
                    )
                )
        return out

    def beside(self, rnd: Round, name: str, stronger: list, shapes: list):
        """The score test of ``name`` beside the regressors of the candidates ``stronger`` and of the shapes
        ``shapes``, in this round's whitening."""
        xs = {reg.name: x for (reg, _c), x in zip(rnd.scored, rnd.xs)}
        others = [xs[n] for n in [*stronger, *(sh.name for sh in shapes)] if n in xs and n != name]
        if name not in xs:
            return None
        sc = score_beside(rnd.r, rnd.j0, xs[name], others)
        return 0.0 if sc is None else sc.log10_p

    def near_aliases(self, rnd: Round, names: list, alpha: float) -> dict:
        """The named candidates each of ``names`` cannot be told from at level ``alpha``, in this round's whitening
        (:func:`gyrojax.inference.adequacy.near_aliases`, the rule every instrument follows)."""
        live = [(c.name, x) for (_reg, c), x in zip(rnd.scored[: self.n_named], rnd.xs) if c is not None and c.df > 0]
        if not live:
            return {}
        p0 = rnd.j0.shape[1]
        bounds = np.cumsum([p0] + [x.shape[1] for _n, x in live])
        slices = {n: slice(int(a), int(b)) for (n, _x), a, b in zip(live, bounds[:-1], bounds[1:])}
        jw = np.column_stack([rnd.j0] + [x for _n, x in live])
        system = WhitenedSystem.of(rnd.r, jw, np.zeros((len(rnd.r), 0)), [], p0)
        return near_aliases(None, None, p0, slices, names, alpha, system)

    def no_term(self, c: Candidate) -> str | None:
        """Why the fit cannot add ``c`` (``time_offset`` has no fit term; ``bias_turn_on`` has,
        :mod:`gyrojax.inference.triad_turn_on`), or None."""
        effect = self.effect_of(c)
        if effect in MEMS_CANDIDATES and effect != TURN_ON:
            return f"{effect} is a diagnosis candidate; fit_triad has no term for it yet"
        return None

    def implausible(self, c: Candidate, overrides) -> str | None:
        """Sizes beyond the MEMS limits (:mod:`gyrojax.physics.plausibility`), per coefficient of any channel."""
        est = {k.split("[")[0]: v for k, v in c.estimate.items()}
        return plausibility.implausible(est, overrides, kind="imu-triad")

    def effect_of(self, c: Candidate) -> str:
        """The effect a candidate adds on every channel (``sf_asymmetry`` for ``sf_asymmetry[x]``)."""
        return c.name.split("[")[0]

    def fit_terms(self, terms):
        """The triad fit of ``terms`` to the session's records."""
        return tf.fit_triad(self.records, terms, earth_rate=self.earth_rate)

    # ---- what the diagnosis adds after its verdict ------------------------------------------------------------

    def noise_processes(self, rnd: Round, taken: list, alpha: float) -> list:
        """The variance components between segments that are significant at ``alpha`` (:func:`_noise_processes`),
        beside the regressors ``taken``."""
        return _noise_processes(rnd.data, alpha, self._cols(taken))[0]

    def finish(
        self, rnd: Round, ranked: list, significant: list, family: int, alpha: float, noise: list, suggest_tests: bool
    ) -> list:
        """The candidates as reported: where the bias walk is named, a candidate significant under the independent
        scatter alone (first Holm step of the family) that is not beside the walk, and that does not leave the
        walk significant beside itself, cannot be told from the walk with these poses: ``indistinguishable``
        from ``bias_random_walk``."""
        if not rnd.under_scatter or not any(c.name == NOISE_PROCESSES["walk"] for c in noise):
            return ranked
        out = []
        for c in ranked:
            was = rnd.under_scatter.get(c.name)
            if c.name not in significant and was is not None and was + math.log10(family) < math.log10(alpha):
                _tau2, lr, _g = components(self.data, self._cols([c.name]), alpha)
                if boundary_p(lr) >= alpha:
                    c = replace(c, indistinguishable=[*c.indistinguishable, NOISE_PROCESSES["walk"]])
            out.append(c)
        return out

    def components_chi2(self, rnd: Round) -> tuple:
        """χ² and degrees of freedom of the rows whitened with the variance components, the residual projected off
        the model's columns (the fit's θ is generalised least squares under its own components, not under a walk)."""
        r_perp, _s2, _dof = residual_variance(basis(rnd.j0), rnd.r)
        return float(r_perp @ r_perp), rnd.dof
