"""Joint calibration of a MEMS gyro triad from static poses and known-angle rotations, with honest σ.

Each channel is an SDF-like rate gyro (:mod:`gyrojax.physics.triad`); the three are fitted jointly from the
segments of ``imu-triad`` records (:mod:`gyrojax.data.triad`, as arrays by :mod:`gyrojax.data.triad_segments`):

* **static pose** k: the mean indicated rate of each channel over the pose, modelled at the pose's mean specific
  force (accelerometer, g) with the inertial rate of a body at rest, the Earth rate (below);
* **rotation** r of a known angle Θ about a body axis n, angle history unknown: the integral constraint
  ∫ ω_ind dt = (model of the rotation) dt, in which the body rate is n·Θ·s(t)/∫s dt — the history's *shape* s(t)
  taken from the indicated rate about n itself, its *total* fixed to Θ (sign from the data). Every effect linear in
  the rate (scale factor, misalignment, bias, g-terms) then depends on Θ only, never on the invented shape; the
  rate-nonlinear ones (E_A, E_2) use the shape to first order.

A **gravity-to-gravity move** is integrated from the body rates the whole channel model inverts
(:func:`gyrojax.physics.triad.body_rates`: every named effect of the fit, E_A, E_2, trend and temperature
included), its residual the Up direction carried against the one measured. The accelerometer's imu_tk model is
fitted from the same rests (:mod:`gyrojax.inference.triad_accel`).

Every coefficient enters the segment means linearly, so one generalized-least-squares solve fits them (exact
derivatives by ``jax.jacfwd`` of the same measurement model), through the one rank-cut least-squares core
(:func:`gyrojax.inference.solver.solve`) after the one identifiability analysis
(:func:`gyrojax.inference.identifiability.alias_analysis`). The covariance of the segment means is built from

* each channel's **long-run noise variance** q_c, estimated from the static residuals by a Bartlett-window
  (Newey–West 1987) sum of the pooled autocovariance, so filtered, correlated MEMS noise gives honest pose means
  (Var(mean of N) = q_c / N);
* the **unknown heading** of each hand-placed pose, a nuisance marginalised with a uniform prior: the horizontal
  Earth rate of magnitude Ω cos φ adds (Ω cos φ)²/2 (I − u uᵀ) to the pose's 3×3 block (u: Up in the body
  frame, from the accelerometer);
* the **angle error** of a hand rotation (``angle_std_deg``), σ_Θ² n nᵀ / T² on the rotation's block;
* in a session with moves, the **variance components between segments** (:mod:`gyrojax.inference.triad_components`,
  REML): a per-pose bias scatter, a per-move angle noise, and a bias walk from pose to pose where its likelihood ratio
  is significant — it couples every segment, so the fit is then generalised least squares under one dense
  covariance (Gauss–Newton from the fit without it) and the notes say so.

Earth rate (ω_ie = 15.04 deg/h): with the site latitude φ its vertical part Ω sin φ·u is modelled exactly; the
horizontal part enters as above. With the latitude unknown (``null``), the vertical part cannot be told from a
g-sensitivity along each sensing axis (both are ∝ a_I): it stays in D_I[c] (the result says so), and the horizontal
part is marginalised with its mean square over the sites of the sphere, Ω² E[cos² φ] = (2/3) Ω².
``earth_rate=False`` switches both off (a record's ``"earth_rate": false`` does too). In a gravity-to-gravity move
the Earth turns Up unseen by Ω_h T (T the move's duration): a variance (Ω_h T)²/2 per direction component.
"""

from __future__ import annotations

import warnings

import numpy as np

from gyrojax import tails, units
from gyrojax.data.record import Record
from gyrojax.data.triad import TRIAD_KIND
from gyrojax.data.triad_segments import triad_segments
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.campaign import check_one_instrument
from gyrojax.inference.identifiability import IdentifiabilityError, alias_analysis, alias_message, residue_columns
from gyrojax.inference.scoring import ALPHA
from gyrojax.inference.solver import solve
from gyrojax.inference.triad_accel import accelerometer_json, fit_accelerometer, needs_calibration
from gyrojax.inference.triad_checks import divergence_hint, plausibility_notes, terms_for_force
from gyrojax.inference.triad_components import Group, boundary_p, estimate_components, select_components, whiten_rows
from gyrojax.inference.triad_result import TriadFit
from gyrojax.inference.triad_rows import pack_moves, pack_segments, scale_matrix, segment_rows
from gyrojax.inference.triad_turn_on import BIAS, move_rows_with_steps, power_ups, split_terms, step_names
from gyrojax.inference.triad_turn_on import check as check_turn_on
from gyrojax.noise.spec import SessionNoise
from gyrojax.noise.whiten import pooled_autocovariance
from gyrojax.optimize import least_squares, remember_last
from gyrojax.physics import triad as tp
from gyrojax.runtime.threads import narrow_blas

MAX_NOISE_PASSES = 8  # fits at fixed noise, the noise updated with the fitted S between them (2–3 suffice)
NOISE_PASS_TOL = 1e-10  # relative change of S below which the noise is settled (χ² then changes by ≲ 1e-10)
MOVE_DIVERGED_DEG = 10.0  # median angle left at the moves above which the fit of the moves has diverged
WALK_STEPS = 5  # Gauss–Newton steps of the fit under a bias walk at most (the moves are nearly linear: 1–2 suffice)
NW_MAX_LAG = 50  # samples: longest autocovariance lag of the long-run variance (MEMS filters span a few samples)


def long_run_variance(resid: list[np.ndarray], max_lag: int = NW_MAX_LAG) -> np.ndarray:
    """Long-run variance q_c ((deg/h)², per channel) of static residual series: Var(mean of N samples) ≈ q_c / N.

    The pooled autocovariance γ_l (lagged products never cross a segment) summed with Bartlett weights,
    q = γ_0 + 2 Σ_{l=1..L} (1 − l/(L+1)) γ_l (Newey & West 1987), L = min(``max_lag``, shortest segment / 4);
    floored at γ_0 / 10 (a negative sum means L is too short to tell, not that the mean is exact)."""
    lens = [len(r) for r in resid if len(r)]
    if not lens:
        raise ModelError("no static segment: the noise of the pose means cannot be estimated")
    lag = int(max(1, min(max_lag, min(lens) // 4)))
    r_all = np.concatenate(resid, axis=0)
    bounds, i0 = [], 0
    for n in lens:
        bounds.append((i0, i0 + n))
        i0 += n
    w = 1.0 - np.arange(1, lag + 1) / (lag + 1)
    # each segment's mean was removed: its lagged products sum low by ≈ q each, so the pooled γ_l are low by
    # ≈ q / n̄ (n̄: mean segment length) and the window sum by the factor 1 − (1 + 2 Σ w_l)/n̄; divided out
    n_h = sum(lens) / len(lens)
    shrink = max(1.0 - (1.0 + 2.0 * float(w.sum())) / n_h, 0.5)
    q = np.zeros(3)
    for c in range(3):
        gam, _ = pooled_autocovariance(r_all[:, c], bounds, lag)
        q[c] = max(gam[0] + 2.0 * float(w @ gam[1:]), gam[0] / 10.0) / shrink
    return q


def default_terms(records) -> tuple:
    """The terms :func:`fit_triad` takes by default for ``records``: the linear model with scale factor and
    misalignment when a rotation or move segment is there, else bias and g-terms."""
    recs = [records] if isinstance(records, Record) else list(records)
    moving = any(s["type"] in ("rotation", "move") for r in recs for s in r.meta["segments"])
    return tp.DEFAULT_ROTATION_TERMS if moving else tp.DEFAULT_STATIC_TERMS


def is_triad_input(records) -> bool:
    """True when ``records`` (a record or a list) hold an ``imu-triad`` record: the triad fit answers for them (and
    refuses any other record among them)."""
    recs = [records] if isinstance(records, Record) else records
    return isinstance(recs, (list, tuple)) and any(isinstance(r, Record) and r.kind == TRIAD_KIND for r in recs)


class TriadDivergence(ModelError):
    """The fit of the moves diverged: a fitted S no triad has, or moves left far off (its numbers are no answer)."""


@narrow_blas
def fit_triad(records, terms=None, **kw) -> TriadFit:
    """Fit per-channel SDF coefficients of a gyro triad to ``imu-triad`` records of one instrument (module doc),
    checked at its boundary (:mod:`gyrojax.inference.triad_checks`): g-terms only where the segments have a specific
    force, coefficients beyond the MEMS limits said in the notes with the import flag they point to, and a fit that
    diverges refused naming the flag the data point to. Arguments as :func:`fit_triad_unchecked`."""
    try:
        fit = fit_triad_unchecked(records, terms, **kw)
    except TriadDivergence as e:
        recs = [records] if isinstance(records, Record) else list(records)
        parts = [triad_segments(r, kw.get("earth_rate")) for r in recs]
        hint = divergence_hint([s for p in parts for s in p[0]], [m for p in parts for m in p[3]])
        if not hint:
            raise
        raise TriadDivergence(f"{str(e).split('; check ')[0]}; {hint}") from None
    fit.notes.extend(plausibility_notes(fit.values))
    return fit


def fit_triad_unchecked(
    records,
    terms=None,
    *,
    earth_rate: bool | None = None,
    allow_aliases: bool = False,
    noise_q=None,
    max_iter: int = 30,
    components: bool = True,
) -> TriadFit:
    """The fit of :func:`fit_triad` without the checks of the answer (the g-terms' specific force is checked).

    Args:
      records: a triad :class:`Record` or a list of them (one instrument: ``instrument.id`` decides).
      terms: effect names applied to every channel (default D_F, D_I, D_O, D_S, plus sf_error and
        ia_misalignment when there are rotations).
      earth_rate: override the records' ``earth_rate`` (False: no Earth rate in the model or the covariance).
      allow_aliases: return a minimum-norm fit instead of raising when the segments cannot separate some effects.
      noise_q: per-channel long-run noise variance (deg/h)² per sample, or a
        :class:`~gyrojax.noise.spec.SessionNoise` (its channels at the records' sample interval), instead of
        estimating it.
      max_iter: iterations of the fit of gravity-to-gravity moves (the only nonlinear part): at most this many
        evaluations of the moves' residual by Levenberg–Marquardt (about one per iteration; 5 to 10 suffice).
      components: in a session with moves, estimate a per-pose bias scatter and a per-move angle noise by REML
        (:mod:`gyrojax.inference.triad_components`) and let σ carry them, and a bias walk between poses where it is
        significant (:func:`~gyrojax.inference.triad_components.select_components`; the fit is then generalised
        least squares under its dense covariance) (False: white noise only).

    Returns: a :class:`TriadFit`; coefficients ``<name>[<channel>]`` in report units.
    Raises: :class:`~gyrojax.inference.identifiability.IdentifiabilityError` naming what the segments cannot separate.
    """
    recs = [records] if isinstance(records, Record) else list(records)
    if not recs:
        raise ModelError("no records to fit")
    if not all(isinstance(r, Record) and r.kind == TRIAD_KIND for r in recs):
        raise ModelError("fit_triad takes imu-triad records only")
    check_one_instrument(recs)
    acc_fit = fit_accelerometer(recs)
    if needs_calibration(acc_fit, recs):  # off g beyond the tolerance: calibrated here, never taken on trust
        recs = [with_calibrated_accelerometer(r, acc_fit) for r in recs]
        acc_fit["applied"] = True
    segments, resid, modes, moves, seg_rec, mv_rec = [], [], set(), [], [], []
    for i, r in enumerate(recs):
        s, q, mode, mv = triad_segments(r, earth_rate)
        segments.extend(s)
        resid.extend(q)
        modes.add(mode)
        moves.extend(mv)
        seg_rec += [i] * len(s)
        mv_rec += [i] * len(mv)
    if not segments:
        raise ModelError("the records hold no static or rotation segment to fit")
    has_rot = any(s.kind == "rotation" for s in segments) or bool(moves)
    default = terms is None
    if default:
        terms = tp.DEFAULT_ROTATION_TERMS if has_rot else tp.DEFAULT_STATIC_TERMS
    terms, turn_on = split_terms(terms)
    terms, force_notes = terms_for_force(terms, segments, default)
    model = tp.channel_model(terms)
    if turn_on:
        kinds = [[s.kind for s, i in zip(segments, seg_rec) if i == k] for k in range(len(recs))]
        check_turn_on(model, [r.name for r in recs], kinds)
    pu = power_ups(model, seg_rec, mv_rec, len(recs), turn_on)
    names = [*tp.channel_names(model), *step_names(pu.count)]
    n_theta = len(names)
    dt_s = float(np.median([np.median(np.diff(s.t_h)) for s in segments if len(s.t_h) > 1] or [0.0])) * 3600.0
    q = long_run_variance(resid) if noise_q is None else _channel_variances(noise_q, dt_s)

    # one compiled call each for the segment means and the moves (triad_rows), at shapes bucketed across sessions
    base, jac = segment_rows(model, np.zeros(3 * model.size), pack_segments(segments, bucketed=True), len(segments))
    jac = pu.segment_jacobian(jac)  # the power-ups' bias steps beside the channel coefficients (triad_turn_on)
    y = np.concatenate([s.y for s in segments])
    packed = pack_moves(moves, bucketed=True) if moves else None
    # the noise of every row in indicated units at the fitted S (whiten_segments, move_whitening): the model is
    # linear in S, so a record whose nominal scale is off by k gives the same fit with S, b, G times k, the same χ²
    theta = np.zeros(n_theta)
    if moves and not any(s.kind == "rotation" for s in segments):
        # statics alone see S only through the vertical Earth rate (≤ 15 deg/h): the start holds S = I and fits
        # bias and g-terms, the moves then find S (a free S would split Ω sin φ into absurd scale and misalignment)
        free = np.array([not _scale_coefficient(n) for n in names])
    else:
        free = np.ones(len(names), dtype=bool)
    lin_r, lin_j = whiten_segments(segments, y - base, jac, q, np.eye(3))
    theta[free] = solve(lin_j[:, free], lin_r)[0]
    iterations, why, s_prev = 0, "", None
    # S is seen by rotations or moves only; without them the body-rate covariances stay at the nominal scale
    passes = MAX_NOISE_PASSES if moves or any(s.kind == "rotation" for s in segments) else 1
    for _pass in range(passes):  # fixed noise per pass; the passes update it with the fitted S
        s_mat = scale_matrix(model, pu.split(theta)[0]) if passes > 1 else np.eye(3)
        if s_prev is not None and np.max(np.abs(s_mat - s_prev)) <= NOISE_PASS_TOL * np.max(np.abs(s_prev)):
            break
        _check_scale_matrix(s_mat)
        s_prev = s_mat
        lin_r, lin_j = whiten_segments(segments, y - base, jac, q, s_mat)
        if moves:  # Levenberg–Marquardt on the linear rows and the moves' direction residuals (2 rows per move)
            move_w = move_whitening(moves, q, s_mat)
            system = _moves_system(model, packed, lin_r, lin_j, move_w, pu)
            sol = least_squares(system, theta, max_iter)
            theta, n_eval, why = sol.x, sol.steps, sol.reason
            iterations += n_eval
            if why:
                break
        else:
            theta = np.zeros(n_theta) + solve(lin_j, lin_r)[0]
            iterations += 1
    else:
        if passes > 1:
            why = why or f"the noise did not settle with the fitted scale in {MAX_NOISE_PASSES} passes"
    tau2, why_components, walk_note = {}, "", ""
    if moves:
        base_w = (lin_r, lin_j, move_w)  # the white-noise model's rows: its χ² says how poor that model is
        if components and not why:
            rows, jrows = system(theta)  # the search's last evaluation
            moves_at = (rows[len(lin_r) :], jrows[len(lin_r) :])
            groups = component_groups(segments, y - base - jac @ theta, jac, q, s_mat, moves_at, move_w)
            tau2, why_components = estimate_components(groups)
        if any(v > 0 for v in tau2.values()):  # refit with the components in the covariance
            lin_r, lin_j = whiten_segments(segments, y - base, jac, q, s_mat, tau2.get("pose", 0.0))
            move_w = move_whitening(moves, q, s_mat, tau2.get("move", 0.0))
            system = _moves_system(model, packed, lin_r, lin_j, move_w, pu)
            sol = least_squares(system, theta, max_iter)
            theta, n_eval, why = sol.x, sol.steps, sol.reason
            iterations += n_eval
        rw, jw = system(theta)
        why = why or why_components
        if components and not why and BIAS in model.terms:  # a bias that walks between poses: the σ carry it
            walk_at = _walk_groups(model, segments, moves, y - base, jac, q, s_mat, packed, pu, (seg_rec, mv_rec))
            tau2_walk, lr_walk = select_components(walk_at(theta), ALPHA)
            if tau2_walk.get("walk", 0.0) > 0.0:
                tau2 = tau2_walk
                theta, rw, jw = _fit_with_walk(walk_at, theta, tau2)
                walk_note = (
                    f"the bias walks between poses (REML likelihood ratio {lr_walk:.3g} against independent pose "
                    f"scatter, p {boundary_p(lr_walk):.2g}): the coefficients are generalised least squares and their "
                    "standard errors carry the walk, the pose scatter and the move angle noise (variance_components)"
                )
    else:
        rw, jw = lin_r, lin_j
        theta = np.zeros(n_theta)
    report = alias_analysis(jw, names, names)
    not_excited = report["unexcited"]
    if (report["aliases"] or not_excited) and not allow_aliases:
        raise IdentifiabilityError(alias_message(report, "add poses/rotations that separate them"), report)
    step, cov = solve(jw, rw)  # rank-cut SVD in normalised columns; unseen coefficients get NaN rows and columns
    theta = theta + step
    bad = ~np.isfinite(np.diag(cov))
    s_fit = scale_matrix(model, pu.split(theta)[0])
    if moves:  # one evaluation of the moves at the fitted θ: their Up residuals and rows of the white-noise model
        lr0, lj0, mw0 = base_w
        r_moves, mr, _ = move_rows_with_steps(model, theta, packed, mw0, pu)
        _check_moves_converged(s_fit, r_moves, moves)
        e = np.concatenate([lr0 - lj0 @ theta, mr])
    else:
        r_moves, mw0 = None, None
        e = rw - np.where(residue_columns(jw), 0.0, jw) @ theta
    dof = int(len(e) - report["rank"])
    chi2 = float(e @ e)
    raw_res = y - base - jac @ np.where(bad, 0.0, theta)
    seg_rows = _segment_residuals(segments, e, raw_res, moves, r_moves, mw0)
    mode = " / ".join(sorted(modes))
    notes = list(force_notes)
    if "latitude unknown" in modes and any(t == "D_I" for t in model.terms):
        notes.append(
            "site latitude unknown: the vertical Earth rate Omega sin(phi) (|.| <= 15.04 deg/h) cannot be told from "
            "g-sensitivity along each sensing axis, so each D_I[c] includes it (G includes Omega sin(phi) S / |a|: "
            "also M_O, M_S times it in D_O, D_S); the horizontal Earth rate (unknown heading) is marginalised with "
            "its mean square over the sites of the sphere, (2/3) (15.04 deg/h)^2"
        )
    p_scatter = float(tails.chi2_sf(chi2, dof)) if dof > 0 else 1.0
    if p_scatter < ALPHA:
        comp = components_report(tau2, s_fit)
        if any(v > 0 for v in comp.values()):
            tail = "the standard errors include the variance components estimated by REML: " + ", ".join(
                f"{k} {v:.3g}" for k, v in comp.items() if "indicated" not in k
            )
        else:
            tail = "the standard errors assume the noise model and may be too small"
        drivers = ", ".join(f"{r['name']} ({r['chi2']:.3g})" for r in sorted(seg_rows, key=lambda r: -r["chi2"])[:3])
        notes.append(
            f"the segment means scatter more than the sample noise explains (chi2 {chi2:.3g} on {dof} dof, "
            f"p {p_scatter:.2g}; largest shares: {drivers}): bias shifts between poses, hand-move "
            f"errors or a missing effect; {tail}"
        )
    if walk_note:
        notes.append(walk_note)
    if pu.n_steps:
        notes.append(
            f"bias_turn_on: D_F is the bias of the first power-up ({recs[0].name}); "
            + "; ".join(f"D_F_step_{k} that of {recs[k].name} less it" for k in range(1, len(recs)))
            + " (apply calibrates a fitted power-up's record with its own bias, any other with the first's)"
        )
    if acc_fit is not None and acc_fit["poorly_determined"]:  # the gyro fit takes the specific force as calibrated
        notes.append(f"{acc_fit['poorly_determined']}; the gyro's standard errors do not include that error")
    if why:
        warnings.warn(f"triad fit with moves did not converge: {why}", ConvergenceWarning, stacklevel=3)
    scales = {float(r.meta["instrument"].get("gyro_counts_per_dps") or 0.0) for r in recs}
    k = scales.pop() if len(scales) == 1 else None
    return TriadFit(
        model,
        names,
        theta,
        cov,
        segments,
        raw_res,
        q,
        chi2,
        dof,
        mode,
        [r.name for r in recs],
        not_excited,
        counts_per_dps=k or None,
        notes=notes,
        iterations=iterations,
        converged=not why,
        convergence_note=why,
        variance_components=components_report(tau2, s_fit),
        segment_residuals=seg_rows,
        accelerometer=accelerometer_json(acc_fit),
        dt_s=dt_s,
    )


def with_calibrated_accelerometer(record: Record, acc_fit: dict) -> Record:
    """``record`` with its ``acc_<c>_g`` columns calibrated by the fitted accelerometer model."""
    from gyrojax.inference.triad_accel import calibrate

    a = calibrate(acc_fit, np.column_stack([record.columns[f"acc_{c}_g"] for c in tp.CHANNELS]))
    cols = dict(record.columns)
    for j, c in enumerate(tp.CHANNELS):
        cols[f"acc_{c}_g"] = a[:, j]
    return Record(record.meta, cols)


def _channel_variances(noise_q, dt_s: float) -> np.ndarray:
    """A given long-run noise variance of each channel, (deg/h)² per sample, checked: three finite values > 0;
    from a :class:`~gyrojax.noise.spec.SessionNoise`, its channels' at the records' sample interval ``dt_s``."""
    if isinstance(noise_q, SessionNoise):
        noise_q = noise_q.sample_variances(dt_s)
    try:
        q = np.asarray(noise_q, dtype=float)
    except (TypeError, ValueError):
        q = np.zeros(0)
    if q.shape != (3,) or not np.all(np.isfinite(q)) or not np.all(q > 0):
        raise ModelError(
            f"the triad noise is the long-run variance of each channel x, y, z: three finite numbers > 0 "
            f"((deg/h)² per sample), got {noise_q!r}"
        )
    return q


def _scale_coefficient(name: str) -> bool:
    """True for the coefficients that multiply the rate (E_SF, M_O, M_S, E_A, E_2 of any channel)."""
    return tp.split_channel_name(name)[0] in ("E_SF", "M_O", "M_S", "E_A", "E_2")


def _moves_system(model, packed, lin_r, lin_j, move_w, pu):
    """The whitened rows of a fit with moves and their Jacobian at θ: the linear rows, then the moves' two direction
    rows each (:func:`gyrojax.inference.triad_turn_on.move_rows_with_steps`: the power-ups' steps ``pu`` included)."""

    def system(th):
        _, mr, mj = move_rows_with_steps(model, th, packed, move_w, pu)
        return np.concatenate([lin_r - lin_j @ th, mr]), np.concatenate([lin_j, mj])

    return remember_last(system)


def whiten_segments(segments, resid, jac, q, s_mat, pose_var: float = 0.0):
    """Whitened residual and Jacobian rows of the segment means, by the Cholesky factor of each segment's 3×3
    covariance diag(q / n) + S E Sᵀ: q the channels' long-run noise (indicated units, (deg/h)²), E the segment's
    covariance of body rates (heading, angle error; deg²/h²) seen through the scale-and-misalignment matrix S;
    ``pose_var`` the per-pose bias scatter τ_b² I₃ added to every static pose ((deg/h)²)."""
    m = len(segments)
    cov = _segment_covs(segments, q, s_mat)
    cov += pose_var * np.array([seg.kind == "static" for seg in segments], dtype=float)[:, None, None] * np.eye(3)
    low = np.linalg.cholesky(cov)
    both = np.concatenate([resid.reshape(m, 3, 1), jac.reshape(m, 3, -1)], axis=2)
    out = np.linalg.solve(low, both)
    return out[:, :, 0].reshape(-1), out[:, :, 1:].reshape(3 * m, -1)


def _check_scale_matrix(s_mat) -> None:
    """Refuse a fitted S that no gyro triad has (left-handed, or a singular value outside 0.2–5): the fit of the
    moves has diverged, and its numbers are not an answer."""
    sv = np.linalg.svd(s_mat, compute_uv=False)
    if np.linalg.det(s_mat) <= 0 or sv.min() < 0.2 or sv.max() > 5.0:
        raise TriadDivergence(
            f"the triad fit with moves diverged: the fitted scale-and-misalignment matrix has singular values "
            f"{np.array2string(sv, precision=3)} and determinant {np.linalg.det(s_mat):.3g} (a triad's are near 1); "
            "check the record's latitude, the nominal gyro scale and the move segments"
        )


def _angles_deg(r) -> np.ndarray:
    """Angles (deg) of the moves' Up residuals ``r`` (M, 3) (chord length 2 sin(angle/2))."""
    return np.degrees(2.0 * np.arcsin(np.clip(np.linalg.norm(r, axis=1) / 2.0, 0.0, 1.0)))


def _check_moves_converged(s_mat, r_moves, moves) -> None:
    """Refuse a fit of the moves that leaves them far off (median > :data:`MOVE_DIVERGED_DEG`) or a fitted S
    (``s_mat``) that no triad has: diverged. ``r_moves`` (M, 3): the moves' Up residuals at the fit."""
    _check_scale_matrix(s_mat)
    ang = _angles_deg(r_moves)
    if np.median(ang) > MOVE_DIVERGED_DEG:
        worst = int(np.argmax(ang))
        raise TriadDivergence(
            f"the triad fit with moves diverged: the fitted model leaves the moves {np.median(ang):.3g} deg off in "
            f"the median (worst {moves[worst].name}: {ang[worst]:.3g} deg); check the record's latitude, the nominal "
            "gyro scale and the move segments"
        )


def components_report(tau2: dict, s_mat=None) -> dict:
    """The REML components as standard deviations in report units (empty when none were estimated). The per-pose
    bias scatter τ_b is estimated in indicated units (τ_b² I₃ on each pose's rows); reported in calibrated deg/h,
    the rms over the body axes of S⁻¹ τ_b² S⁻ᵀ (τ_b √(tr(S⁻¹ S⁻ᵀ)/3) at the fitted S: independent of the nominal
    scale given at import), and as estimated, ``pose_bias_scatter_indicated_deg_per_h``; the bias walk τ_w likewise,
    per √pose."""
    out = {}
    if "pose" in tau2:
        s_inv = np.linalg.inv(np.eye(3) if s_mat is None else np.asarray(s_mat))
        tau = float(np.sqrt(tau2["pose"]))
        out["pose_bias_scatter_deg_per_h"] = tau * float(np.sqrt(np.trace(s_inv @ s_inv.T) / 3.0))
        out["pose_bias_scatter_indicated_deg_per_h"] = tau
    if "move" in tau2:
        out["move_angle_noise_deg"] = float(np.degrees(np.sqrt(tau2["move"])))
    if "walk" in tau2:  # calibrated as the scatter is (SessionNoise.bias_walk)
        s_inv = np.linalg.inv(np.eye(3) if s_mat is None else np.asarray(s_mat))
        tau = float(np.sqrt(tau2["walk"]))
        out["bias_walk_deg_per_h_per_sqrt_pose"] = tau * float(np.sqrt(np.trace(s_inv @ s_inv.T) / 3.0))
        out["bias_walk_indicated_deg_per_h_per_sqrt_pose"] = tau
    return out


def components_tau2(report: dict) -> dict:
    """The variance components τ² (natural units, as estimated) of a :func:`components_report`."""
    out = {}
    if "pose_bias_scatter_deg_per_h" in report:
        out["pose"] = report.get("pose_bias_scatter_indicated_deg_per_h", report["pose_bias_scatter_deg_per_h"]) ** 2
    if "move_angle_noise_deg" in report:
        out["move"] = np.radians(report["move_angle_noise_deg"]) ** 2
    if "bias_walk_deg_per_h_per_sqrt_pose" in report:
        walk = report.get("bias_walk_indicated_deg_per_h_per_sqrt_pose", report["bias_walk_deg_per_h_per_sqrt_pose"])
        out["walk"] = walk**2
    return out


def walk_clocks(segments, moves) -> tuple[np.ndarray, np.ndarray]:
    """The bias walk's clock (:mod:`gyrojax.inference.triad_components`, dimensionless: segments counted) of each
    segment (its ordinal in order of its mid time, h) and each move (between its neighbours: k + ½ after segment k)."""
    seg_mid = np.array([float(np.mean(sg.t_h)) for sg in segments])
    clock = np.empty(len(segments))
    clock[np.argsort(seg_mid, kind="stable")] = np.arange(len(segments))
    move_mid = np.array([float(np.mean(m.t_h)) for m in moves])
    return clock, np.searchsorted(np.sort(seg_mid), move_mid) - 0.5


def _segment_residuals(segments, e, raw_res, moves, r_moves, move_w) -> list:
    """Per segment (poses, rotations, then moves): the residual whitened by the white-noise model (its rows of
    χ², dimensionless), in natural units (deg/h for poses and rotations; deg for a move: its two direction
    components and the angle between measured and carried Up, from its Up residual, a row of ``r_moves``) and its
    share of χ²."""
    rows = []
    for i, seg in enumerate(segments):
        w = e[3 * i : 3 * i + 3]
        rows.append(
            {
                "name": seg.name,
                "kind": seg.kind,
                "whitened": w.tolist(),
                "natural": raw_res[3 * i : 3 * i + 3].tolist(),
                "unit": "deg/h",
                "chi2": float(w @ w),
            }
        )
    if moves:
        ang = _angles_deg(r_moves)
        off = 3 * len(segments)
        for k, (m, (p, _sd)) in enumerate(zip(moves, move_w)):
            w = e[off + 2 * k : off + 2 * k + 2]
            rows.append(
                {
                    "name": m.name,
                    "kind": "move",
                    "whitened": w.tolist(),
                    "natural": np.degrees(p.T @ r_moves[k]).tolist(),
                    "angle_deg": float(ang[k]),
                    "unit": "deg",
                    "chi2": float(w @ w),
                }
            )
    return rows


def _segment_covs(segments, q, s_mat) -> np.ndarray:
    """White-noise covariance (m, 3, 3) of every segment's mean, indicated units (:func:`whiten_segments`)."""
    n = np.array([seg.n for seg in segments], dtype=float)
    extra = np.stack([seg.extra for seg in segments])
    return (q / n[:, None])[:, :, None] * np.eye(3) + s_mat @ extra @ s_mat.T


def component_groups(segments, e, jac, q, s_mat, moves_at, move_w, extra=(), walk=None) -> list:
    """The rows of a fit at θ as :class:`~gyrojax.inference.triad_components.Group` s, natural units: each
    segment's 3 rows (``e`` = y − f(θ), deg/h, and ``jac``; static poses carry the bias-scatter component), each
    move's 2 direction rows (``moves_at``: the whitened rows and Jacobian of :func:`gyrojax.inference.triad_rows.
    move_rows` at θ with the whitening ``move_w``, the angle noise component). ``extra``: more regressors as
    (segment rows (3m, k), move rows (M, 3, k)) pairs, beside the Jacobian. ``walk``: (each segment's clock, each
    move's clock, each move's (2, 3) change of its two rows (natural units) per deg/h of each channel's bias, each
    segment's power-up, each move's)
    where a bias walk is estimated (it restarts at each power-up: :mod:`gyrojax.inference.triad_components`)."""
    groups = []
    covs = _segment_covs(segments, q, s_mat)
    seg_clock, move_clock, move_bias, seg_power, move_power = walk if walk is not None else (None,) * 5
    for i, seg in enumerate(segments):
        sl = slice(3 * i, 3 * i + 3)
        j = np.column_stack([jac[sl]] + [sg[sl] for sg, _ in extra])
        step, power = (None, 0) if walk is None else (float(seg_clock[i]), int(seg_power[i]))
        groups.append(Group(covs[i], e[sl], j, "pose" if seg.kind == "static" else "", step, power_up=power))
    rows, jrows = moves_at  # whitened by σ_k: natural units are σ_k times them
    for k, (p, sd) in enumerate(move_w):
        j = np.column_stack([sd * jrows[2 * k : 2 * k + 2]] + [p.T @ mv[k] for _, mv in extra])
        if walk is None:
            step, bias_rows, power = None, None, 0
        else:
            step, bias_rows, power = float(move_clock[k]), move_bias[k], int(move_power[k])
        groups.append(Group(sd**2 * np.eye(2), sd * rows[2 * k : 2 * k + 2], j, "move", step, bias_rows, power))
    return groups


def _walk_groups(model, segments, moves, resid0, jac, q, s_mat, packed, pu, records):
    """θ ↦ the fit's rows at θ as REML groups with the bias walk's clock (:func:`component_groups`): ``resid0`` the
    segment means less the model at θ = 0 (linear in θ, ``jac``), the moves' rows redone at θ, each move's change per
    deg/h of each channel's bias its D_F columns; ``records`` the power-up of each segment and each move."""
    move_w = move_whitening(moves, q, s_mat)
    clock, move_clock = walk_clocks(segments, moves)
    bias = [c * model.size + model.coefficient_names.index(BIAS) for c in range(3)]

    @remember_last
    def at(theta):
        rows, jrows = move_rows_with_steps(model, theta, packed, move_w, pu)[1:]
        move_bias = [sd * jrows[2 * k : 2 * k + 2, bias] for k, (_p, sd) in enumerate(move_w)]
        walk = (clock, move_clock, move_bias, np.asarray(records[0]), np.asarray(records[1]))
        return component_groups(segments, resid0 - jac @ theta, jac, q, s_mat, (rows, jrows), move_w, (), walk)

    return at


def _fit_with_walk(groups_at, theta, tau2: dict):
    """(θ, whitened rows, their Jacobian) of the generalised least squares under the covariance ``tau2`` with its
    walk (:func:`gyrojax.inference.triad_components.whiten_rows`: one dense whitening), by Gauss–Newton from θ: the
    segment means are linear in θ, the moves nearly so."""
    for _ in range(WALK_STEPS):
        e, x = whiten_rows(groups_at(theta), tau2)
        step = np.nan_to_num(solve(x, e)[0])
        theta = theta + step
        if np.linalg.norm(x @ step) <= 1e-8 * max(1.0, float(np.linalg.norm(e))):
            break
    e, x = whiten_rows(groups_at(theta), tau2)
    return theta, e, x


def move_whitening(moves, q, s_mat, angle_var_extra: float = 0.0) -> list:
    """Per move: (P (3, 2) basis ⟂ u_to, σ (rad) of each of the two residual components). The variance is the
    gyro noise integrated over the move — in calibrated units, S⁻¹ diag(q) S⁻ᵀ, its mean over the three axes
    (the body turns during the move) × n dt² — the noise of the two Up directions, and the Earth turning Up
    unseen during the move (:attr:`Move.earth_var`, heading unknown); ``angle_var_extra`` the per-move angle noise
    τ_m² (rad², :mod:`gyrojax.inference.triad_components`)."""
    s_inv = np.linalg.inv(s_mat)
    q_cal = float(np.trace(s_inv @ np.diag(q) @ s_inv.T)) / 3.0
    n = np.array([len(m.g) for m in moves], dtype=float)
    dt = np.array([m.dt for m in moves])
    angle_var = q_cal * n * dt**2 * units.DEG_PER_H**2
    var = angle_var + np.array([m.earth_var for m in moves]) + np.array([m.var_dir for m in moves]) + angle_var_extra
    u = np.array([m.u_to for m in moves])
    e1 = np.cross(u, np.eye(3)[np.argmin(np.abs(u), axis=1)])
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(u, e1)
    return [(np.column_stack([a, b]), float(np.sqrt(v))) for a, b, v in zip(e1, e2, var)]
