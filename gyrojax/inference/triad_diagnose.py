"""Diagnosis of a triad fit: which named effect, noise process or unnamed structure explains what the fit leaves.

The loop of :mod:`gyrojax.inference.diagnose` on ``imu-triad`` records (:mod:`gyrojax.inference.triad`). Every
candidate is a set of regressors R(ω, a, t, T) (deg/h per coefficient unit) added to the indicated rate of one
channel c — a named effect of the registry (conventions §6) through the channel's SDF inputs (Hu 2-45), a MEMS
candidate (conventions §9: ``bias_turn_on``, ``time_offset``) or a model-free shape (cross-axis rate products,
|ω|, a bias while moving, t²). Its columns in the fit's rows:

* static pose or known-angle rotation: the mean of R over the segment's samples (as the fit models a segment mean);
* gravity-to-gravity move: the first-order change of the move's attitude residual when channel c indicates R β
  more, ∂r/∂β = −Σ_l (∂r/∂g_{l,c}) R_l (one Jacobian of the move integration by the current linear model, at the
  fit), so that every candidate is carried along the moves as the fit carries its own terms.

Rows and columns are whitened as the fit whitens them (segment-mean covariance with the per-pose bias scatter,
move angle noise with the per-move angle component, both REML; :mod:`gyrojax.inference.triad_components`). The
score test of each candidate is that of :mod:`gyrojax.inference.diagnose`, S/k ~ F(k, ν), σ̃² estimated from the
residual left by the current model, and one Holm family holds every channel × candidate and every shape. Exact
aliases (X⊥ ≈ 0) name the model terms that already explain the candidate; statistical aliases are candidates
whose projected regressors are collinear. The two noise processes between segments — ``pose_bias_scatter`` (a
bias step at each move) and ``move_angle_noise`` (a per-move angle error) — are tested by the REML likelihood
ratio of their variance component against zero (boundary: p = ½ P(χ²₁ > LR)), as ``gauss_markov`` is on a
turntable; they are noise, never proposed as deterministic effects. Sizes are checked against the MEMS limits
of :mod:`gyrojax.physics.plausibility`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

from gyrojax.data.record import Record
from gyrojax.data.triad import gyro_dph
from gyrojax.data.triad_segments import triad_segments
from gyrojax.errors import ModelError
from gyrojax.inference import adequacy
from gyrojax.inference import triad as tf
from gyrojax.inference.diagnose import COLLINEAR, UNSEEN, Candidate, Diagnosis, effect_to_add, holm
from gyrojax.inference.tails import f_logsf
from gyrojax.inference.triad_candidates import (
    MEMS_CANDIDATES,
    SHAPE_LINES,
    Regressor,
    candidate_regressors,
    shape_regressors,
)
from gyrojax.inference.triad_components import Group, estimate_components, reml_objective
from gyrojax.physics import plausibility
from gyrojax.physics import triad as tp
from gyrojax.threads import narrow_blas

NOISE_PROCESSES = ("pose_bias_scatter", "move_angle_noise")
"""Variance components between segments (:mod:`gyrojax.inference.triad_components`), tested as noise."""


@dataclass
class TriadDiagnosis(Diagnosis):
    """A :class:`~gyrojax.inference.diagnose.Diagnosis` of a triad fit, with its noise processes and the χ² of the
    fit's rows whitened with the variance components (what a model that names them leaves)."""

    noise_processes: list = field(default_factory=list)
    chi2_components: float = float("nan")
    dof: int = 0

    @property
    def noise_floor(self) -> float:
        """RMS of the per-sample noise of the channels, deg/h (√ mean q)."""
        return float(np.sqrt(np.mean(self.fit.noise_q)))

    def to_json(self) -> dict:
        """The diagnosis JSON (conventions §7 shape) with ``noise_processes`` and ``chi2_with_components``."""
        d = super().to_json()
        d["instrument"] = "imu-triad"
        d["noise_processes"] = [c.to_json() for c in self.noise_processes]
        d["chi2_with_components"] = {"chi2": self.chi2_components, "dof": self.dof}
        return d

    def text(self) -> str:
        """The verdict, the candidates that matter, the noise processes and the unnamed structure."""
        lines = [f"verdict: {self.verdict} (alpha {self.alpha:g}, {self.tests} tests, Holm)"]
        lines.append(
            f"fit: chi2 {self.fit.chi2:.4g} on {self.fit.dof} dof (white noise); "
            f"{self.chi2_components:.4g} on {self.dof} with the variance components"
        )
        for c in self.noise_processes:
            est = ", ".join(f"{k} {v['value']:.3g} {v['unit']}" for k, v in c.estimate.items())
            lines.append(f"noise process {c.name}: LR {c.statistic:.3g}, p {c.p_value:.2g} ({est})")
        for c in self.candidates[:8]:
            if c.df == 0:
                lines.append(f"  {c.name}: indistinguishable from {', '.join(c.aliases) or 'the model'}")
                continue
            est = ", ".join(f"{k} {v['value']:.4g} {v['unit']}" for k, v in c.estimate.items())
            flag = f" [implausible: {c.implausible}]" if c.implausible else ""
            flag += f" [refused: {c.refused}]" if c.refused else ""
            alias = f" aliases {', '.join(c.aliases)}" if c.aliases else ""
            lines.append(f"  {c.name}: p_adj {c.p_adjusted:.2g} ({est}){alias}{flag}")
        for s in self.unexplained:
            lines.append(f"unexplained structure: {s.name}: p_adj {s.p_adjusted:.2g} ({SHAPE_LINES.get(s.effect, '')})")
        lines.append(f"proposal: {self.proposal}" if self.proposal else "proposal: none")
        return "\n".join(lines)


@dataclass
class Shape:
    """A significant model-free shape (the ``unexplained`` entries of the diagnosis)."""

    name: str
    effect: str
    statistic: float
    df: int
    p_value: float
    log10_p: float
    p_adjusted: float = 1.0

    def to_json(self) -> dict:
        """One entry of ``unexplained``."""
        return {
            "name": self.name,
            "shape": self.effect,
            "description": SHAPE_LINES.get(self.effect, ""),
            "statistic": float(self.statistic),
            "df": int(self.df),
            "p_value": float(self.p_value),
            "p_adjusted": float(self.p_adjusted),
        }


def default_terms(records) -> tuple:
    """The terms :func:`~gyrojax.inference.triad.fit_triad` takes by default for ``records``: the linear model
    with scale factor and misalignment when a rotation or move segment is there, else bias and g-terms."""
    recs = [records] if isinstance(records, Record) else list(records)
    moving = any(s["type"] in ("rotation", "move") for r in recs for s in r.meta["segments"])
    return tf.DEFAULT_ROTATION_TERMS if moving else tf.DEFAULT_STATIC_TERMS


# ---- the rows of the fit ----------------------------------------------------------------------------------------

_move_dr_dg = jax.jit(
    jax.vmap(jax.jacrev(tf.move_residual, argnums=2), in_axes=(None, None, 0, 0, 0, 0, 0, 0, 0, 0)), static_argnums=0
)


def session_data(records, fit, earth_rate=None) -> dict:
    """The fit's rows rebuilt at its θ: segments and moves, the whitened residual and Jacobian of the current model
    (with the fit's variance components), and each segment's and move's channel inputs for the regressors (rates
    in deg/h, specific force in g, time in h); ``earth_rate`` as :func:`gyrojax.inference.triad.fit_triad` takes it."""
    recs = [records] if isinstance(records, Record) else list(records)
    model, theta = fit.model, np.asarray(fit.theta, dtype=float)
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
    b, s_mat, g_mat = (np.asarray(m) for m in tf.linear_matrices(model, jnp.asarray(theta)))
    comp = fit.variance_components or {}
    tau2 = {
        "pose": comp.get("pose_bias_scatter_indicated_deg_per_h", comp.get("pose_bias_scatter_deg_per_h", 0.0)) ** 2,
        "move": math.radians(comp.get("move_angle_noise_deg", 0.0)) ** 2,
    }
    arrays = tf.pack_segments(segments)
    th = jnp.asarray(theta)
    y = np.concatenate([sg.y for sg in segments])
    resid = y - np.asarray(tf.segment_means_jit(model, th, arrays))
    jac = np.asarray(tf.segment_jacobian_jit(model, th, arrays))
    t_all = np.concatenate([sg.t_h for sg in segments] + [t for t, _ in mv_times])
    t_mid = 0.5 * (t_all.min() + t_all.max())
    inputs = []
    for sg, ri in zip(segments, seg_rec):
        n = len(sg.t_h)
        inputs.append(
            {
                "w": sg.w * np.ones((n, 3)),
                "a": sg.a * np.ones((n, 3)),
                "t_h": sg.t_h,
                "temperature_C": sg.temp,
                "record": np.full(n, ri),
                "moving": np.full(n, sg.kind == "rotation"),
                "t_mid": t_mid,
                "g_dot": np.zeros((n, 3)),
            }
        )
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
        "seg_inputs": inputs,
    }
    data["inputs"] = list(inputs)
    data["seg_stacked"] = _stacked(inputs)
    if moves:
        packed = tf.pack_moves(moves)
        move_w = tf._move_whitening(moves, q, s_mat, tau2["move"])
        mr, mj = tf._move_rows(model, theta, packed, move_w)
        data.update(packed=packed, move_w=move_w, move_r=mr, move_j=mj)
        data["dr_dg"] = np.asarray(_move_dr_dg(model, th, *packed))  # (M, 3, L, 3)
        mv_inputs = []
        for m, ri, (t_h, temp) in zip(moves, mv_rec, mv_times):
            w_cal = np.linalg.solve(s_mat, (m.g - b - m.a @ g_mat.T).T).T  # deg/h, the calibrated body rate
            a_dot = np.gradient(m.a, m.dt, axis=0) if len(m.a) > 1 else np.zeros_like(m.a)
            n = len(m.g)
            mv_inputs.append(
                {
                    "w": w_cal,
                    "a": m.a,
                    "t_h": t_h[:n],
                    "temperature_C": temp[:n],
                    "record": np.full(n, ri),
                    "moving": np.ones(n, dtype=bool),
                    "t_mid": t_mid,
                    "g_dot": a_dot @ g_mat.T,
                }
            )
        data["move_inputs"] = mv_inputs
        data["move_stacked"] = _stacked(mv_inputs)
        data["inputs"] += mv_inputs
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
    big = np.column_stack([data["jac"]] + [s for s, _ in cols]) if cols else data["jac"]
    rw, jw = tf.whiten_segments(data["segments"], data["resid"], big, data["q"], data["s_mat"], data["tau2"]["pose"])
    rw = rw - jw[:, :p0] @ np.zeros(p0)  # the rows are at θ̂ already
    blocks_r, blocks_j = [rw], [jw]
    if data["moves"]:
        mx = []
        for m, (p, sd) in enumerate(data["move_w"]):
            mx.append(np.concatenate([p.T @ mv[m] / sd for _, mv in cols], axis=1) if cols else np.zeros((2, 0)))
        blocks_r.append(data["move_r"])
        blocks_j.append(np.column_stack([data["move_j"], np.concatenate(mx, axis=0)]))
    r_all = np.concatenate(blocks_r)
    j_all = np.concatenate(blocks_j, axis=0)
    xs, i0 = [], p0
    for r in regs:
        k = len(r.coefficients)
        xs.append(j_all[:, i0 : i0 + k])
        i0 += k
    return r_all, j_all[:, :p0], xs, [sg for sg, _ in cols]


# ---- the tests --------------------------------------------------------------------------------------------------


def _score_all(r, j0, xs, regs, model_names, raw=None):
    """Score statistic and F p-value of every regressor (module doc of :mod:`gyrojax.inference.diagnose`); with
    ``raw`` = (segment residual, its Jacobian, each regressor's raw segment rows) the RMS of the segment-mean
    residuals after adding it (one step, deg/h)."""
    u0 = adequacy.basis(j0)
    r_perp = r - u0 @ (u0.T @ r)
    dof = max(len(r) - u0.shape[1], 1)
    sigma2 = float(r_perp @ r_perp) / dof
    out, perps = [], {}
    for i_reg, (reg, x) in enumerate(zip(regs, xs)):
        xn = float(np.sqrt((x * x).sum()))
        if xn == 0.0:
            out.append((reg, None))
            continue
        xp = x - u0 @ (u0.T @ x)
        if float(np.sqrt((xp * xp).sum())) / xn < UNSEEN:
            b, *_ = np.linalg.lstsq(j0, x, rcond=None)
            weight = np.abs(b).max(axis=1) * np.linalg.norm(j0, axis=0)
            idx = np.flatnonzero(weight > 1e-3 * weight.max())
            out.append((reg, Candidate(reg.name, 0.0, 0, 1.0, 1.0, sorted({model_names[i] for i in idx}), math.nan)))
            continue
        uc = adequacy.perp_basis(u0, x, tol=1e-7)
        proj = uc.T @ r_perp
        stat = float(proj @ proj) / sigma2
        df = uc.shape[1]
        logp = float(f_logsf(stat / df, df, dof))
        beta, *_ = np.linalg.lstsq(xp, r_perp, rcond=None)
        rms = math.nan
        if raw is not None:
            res0, jac0, xr = raw
            b_model = np.linalg.lstsq(j0, x, rcond=None)[0]
            rms = float(np.sqrt(np.mean((res0 - (xr[i_reg] - jac0 @ b_model) @ beta) ** 2)))
        est = {
            (f"{n}[{reg.name.split('[')[1]}" if "[" in reg.name else n): {"value": float(v), "unit": u}
            for n, v, u in zip(reg.coefficients, beta, reg.units)
        }
        cand = Candidate(reg.name, stat, df, math.exp(logp), 1.0, [], rms, est, log10_p=logp / math.log(10))
        out.append((reg, cand))
        perps[reg.name] = uc
    return out, perps, dof


def _groups(data: dict, extra: list) -> list:
    """The fit's rows as REML groups (natural units), the Jacobian extended by the raw columns ``extra`` of the
    candidates taken in (:func:`raw_columns`), the moves without their angle component (what is estimated)."""
    model, theta = data["model"], data["theta"]
    groups = []
    for i, seg in enumerate(data["segments"]):
        sl = slice(3 * i, 3 * i + 3)
        cov = np.diag(data["q"] / seg.n) + data["s_mat"] @ seg.extra @ data["s_mat"].T
        jac = np.column_stack([data["jac"][sl]] + [sg[sl] for sg, _ in extra])
        groups.append(Group(cov, data["resid"][sl], jac, "pose" if seg.kind == "static" else ""))
    if data["moves"]:
        r = np.asarray(tf.moves_residual_jit(model, jnp.asarray(theta), *data["packed"]))
        j = -np.asarray(tf.moves_jacobian_jit(model, jnp.asarray(theta), *data["packed"]))
        for k, (p, sd) in enumerate(tf._move_whitening(data["moves"], data["q"], data["s_mat"])):
            jac = np.column_stack([p.T @ j[k]] + [p.T @ mv[k] for _, mv in extra])
            groups.append(Group(sd**2 * np.eye(2), p.T @ r[k], jac, "move"))
    return groups


def with_components(data: dict, extra: list) -> dict:
    """``data`` whitened with the variance components re-estimated by REML with the candidates ``extra`` (raw
    columns) among the fixed effects: a missing effect is then not taken for pose scatter (deg/h) or move angle
    noise (rad)."""
    tau2, _why = estimate_components(_groups(data, extra))
    out = dict(data)
    out["tau2"] = {"pose": tau2.get("pose", 0.0), "move": tau2.get("move", 0.0)}
    if data["moves"]:
        out["move_w"] = tf._move_whitening(data["moves"], data["q"], data["s_mat"], out["tau2"]["move"])
        out["move_r"], out["move_j"] = tf._move_rows(data["model"], data["theta"], data["packed"], out["move_w"])
    return out


def _noise_processes(data: dict, alpha: float, extra: list) -> tuple[list, dict]:
    """REML likelihood-ratio test of each variance component between segments against zero, beside the candidates
    ``extra`` the diagnosis took in; (candidates, τ̂²)."""
    groups = _groups(data, extra)
    tau2, _why = estimate_components(groups)
    col = np.linalg.norm(np.concatenate([np.linalg.solve(np.linalg.cholesky(g.cov), g.jac) for g in groups]), axis=0)
    col[col == 0] = 1.0
    best = reml_objective(groups, tau2, col)
    out = []
    for kind, name in (("pose", "pose_bias_scatter"), ("move", "move_angle_noise")):
        if kind not in tau2:
            continue
        lr = max(reml_objective(groups, {**tau2, kind: 0.0}, col) - best, 0.0)
        p = 0.5 * float(stats.chi2.sf(lr, 1)) if lr > 0 else 1.0
        sd = tf.components_report({kind: tau2[kind]}, data["s_mat"])  # the fit's report units (pose: calibrated)
        if kind == "pose":
            est = {"tau": {"value": sd["pose_bias_scatter_deg_per_h"], "unit": "deg/h"}}
        else:
            est = {"tau": {"value": sd["move_angle_noise_deg"], "unit": "deg"}}
        cand = Candidate(name, lr, 1, p, p, [], math.nan, est, log10_p=math.log10(max(p, 1e-300)))
        if p < alpha:
            out.append(cand)
    return out, tau2


def _implausible(c: Candidate, overrides) -> str | None:
    est = {k.split("[")[0]: v for k, v in c.estimate.items()}
    return plausibility.implausible(est, overrides, kind="imu-triad")


@narrow_blas
def diagnose_triad(
    records,
    terms=None,
    *,
    alpha: float = 0.01,
    candidates=None,
    result=None,
    model_free: bool = True,
    plausible: dict | None = None,
    earth_rate: bool | None = None,
    vet: bool = True,
) -> TriadDiagnosis:
    """Rank what the triad fit of ``terms`` to ``records`` is missing (module doc).

    Args:
      records: ``imu-triad`` records of one instrument.
      terms: the current model (effect names on every channel); default as :func:`~gyrojax.inference.triad.fit_triad`.
      alpha: family-wise level of the verdict (Holm over channels × candidates and shapes).
      candidates: effect names to test (default: every registry effect a triad channel can carry and the session
        excites, and :data:`MEMS_CANDIDATES`).
      result: the fit of ``terms`` to these records, if at hand.
      model_free: test the shapes :data:`SHAPES` too.
      plausible: overrides of the MEMS plausible sizes, by coefficient or effect name.
      vet: refit with the top significant candidate to see whether :func:`fit_triad` accepts it (``refused``).

    Returns: a :class:`TriadDiagnosis`, verdict ``missing-effect`` or ``adequate``; estimates in report units.
    """
    recs = [records] if isinstance(records, Record) else list(records)
    res = result or tf.fit_triad(recs, terms, earth_rate=earth_rate)
    data = session_data(recs, res, earth_rate)
    regs = candidate_regressors(res.model, data, candidates)
    shapes = shape_regressors() if model_free else []
    allr = regs + shapes
    cols = [raw_columns(g, data) for g in allr]
    # forward selection as on a turntable: the components re-estimated with the most significant candidate among
    # the fixed effects, until none is significant (a strong missing effect then does not pass for noise)
    taken: list[int] = []
    for _round in range(4):
        r, j0, xs, xr = whitened_system(data, allr, cols)
        scored, perps, dof = _score_all(r, j0, xs, allr, list(res.names), (data["resid"], data["jac"], xr))
        live_i = [i for i, (_g, c) in enumerate(scored) if c is not None and c.df > 0]  # shapes too
        if not live_i:
            break
        best = min(live_i, key=lambda i: scored[i][1].log10_p)
        if scored[best][1].log10_p + math.log10(len(live_i)) >= math.log10(alpha) or best in taken:
            break
        taken.append(best)
        data = with_components(data, [cols[i] for i in taken])
    tested = [c for reg, c in scored[: len(regs)] if c is not None]
    unexcited = [reg.name for reg, c in scored[: len(regs)] if c is None]
    shape_c = [(reg, c) for reg, c in scored[len(regs) :] if c is not None and c.df > 0]
    live = [c for c in tested if c.df > 0]
    # shapes a named candidate explains: tested beside every named candidate (their projection out)
    named_cols = [x for (reg, c), x in zip(scored[: len(regs)], xs[: len(regs)]) if c is not None and c.df > 0]
    shape_list = []
    if shape_c:
        u_all = adequacy.basis(np.column_stack([j0] + named_cols)) if named_cols else adequacy.basis(j0)
        r_perp = r - u_all @ (u_all.T @ r)
        dof_all = max(len(r) - u_all.shape[1], 1)
        s2 = float(r_perp @ r_perp) / dof_all
        for (reg, _c), x in zip(scored[len(regs) :], xs[len(regs) :]):
            if _c is None or _c.df == 0:
                continue
            uc = adequacy.perp_basis(u_all, x, tol=1e-7)
            if uc.shape[1] == 0:
                continue
            proj = uc.T @ r_perp
            stat = float(proj @ proj) / s2
            logp = float(f_logsf(stat / uc.shape[1], uc.shape[1], dof_all))
            shape_list.append(Shape(reg.name, reg.effect, stat, uc.shape[1], math.exp(logp), logp / math.log(10)))
    adj = holm(np.array([10.0**c.log10_p for c in live] + [10.0**s.log10_p for s in shape_list]))
    for c, a in zip(live + shape_list, adj):
        c.p_adjusted = float(a)
    family = len(live) + len(shape_list)

    # statistical aliases: collinear projected regressors
    names_t = [c.name for c in live]
    for i, a in enumerate(names_t):
        for b in names_t[i + 1 :]:
            s = np.linalg.svd(perps[a].T @ perps[b], compute_uv=False)
            if s.size and s[0] > COLLINEAR:
                next(c for c in live if c.name == a).aliases.append(b)
                next(c for c in live if c.name == b).aliases.append(a)
    for c in live:
        c.implausible = _implausible(c, plausible)
    tested.sort(key=lambda c: (c.log10_p if c.df > 0 else 0.0, -c.statistic))
    significant = [c for c in tested if c.df > 0 and c.p_adjusted < alpha]
    unexplained = sorted([s for s in shape_list if s.p_adjusted < alpha], key=lambda s: s.log10_p)
    proposal = None
    for c in significant:
        effect = c.name.split("[")[0]
        if c.implausible or c.aliases:
            continue
        if effect in MEMS_CANDIDATES:
            c.refused = f"{effect} is a diagnosis candidate; fit_triad has no term for it yet"
            continue
        if vet:
            try:
                tf.fit_triad(recs, tuple(res.model.terms) + (effect,), earth_rate=earth_rate)
            except ModelError as e:
                c.refused = str(e)
                continue
        proposal = effect
        break
    noise, _tau2 = _noise_processes(data, alpha, [cols[i] for i in taken])
    verdict = "missing-effect" if significant or unexplained else "adequate"
    return TriadDiagnosis(
        verdict, res, tested, alpha, unexcited, unexplained, proposal, family, noise, float(r @ r), dof
    )


def add_and_refit_triad(records, terms=None, effect: str | None = None, *, diagnosis=None, **kw):
    """Add ``effect`` (default: the diagnosis' proposal) to every channel's terms, refit, diagnose again.

    Returns ``(new_terms, new_fit, new_diagnosis, added)``."""
    recs = [records] if isinstance(records, Record) else list(records)
    d = diagnosis or diagnose_triad(recs, terms, **kw)
    effect = effect_to_add(d, effect)
    new_terms = tuple(d.fit.model.terms) + (effect,)
    new_fit = tf.fit_triad(recs, new_terms, earth_rate=kw.get("earth_rate"))
    return new_terms, new_fit, diagnose_triad(recs, new_terms, result=new_fit, **kw), effect
