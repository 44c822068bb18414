"""The noise fit of a campaign: noise groups, the pooled REML noise model of each group, the Satterthwaite degrees
of freedom of the GLS variances and the small-sample widening of the standard errors."""

from __future__ import annotations

import warnings

import numpy as np

from gyrojax import tails
from gyrojax.data.timebase import interval_key
from gyrojax.errors import ConvergenceWarning
from gyrojax.inference.campaign import Campaign, Linearized
from gyrojax.inference.solver import solve, stack_whitened
from gyrojax.noise import reml
from gyrojax.noise.readout import record_readout_variance, white_beside_readout
from gyrojax.noise.spec import NoiseSpec
from gyrojax.noise.whiten import (
    FIT_TAU_SPAN_FRACTION,
    first_difference_std,
    fit_noise,
    gls_residual,
    gm_reml,
    reml_curvature_covariance,
    reml_u_covariance,
    with_reml_covariance,
)
from gyrojax.runtime.threads import parallel_map


def noise_groups(campaign: Campaign) -> list[list[int]]:
    """Indices of the records that share one noise model: same mode and sample interval (s). One instrument's
    drift is one random process, whatever the position; a servo record's interval means, or another sample
    interval, see it through a different filter.

    The interval is the median step rounded to 3 significant digits (:func:`gyrojax.data.timebase.interval_key`),
    so the last digits of the timestamps (a clock written with 7 digits, logger jitter) never split a group.
    A record JSON key ``noise_group`` (any string) chooses the group instead."""
    groups: dict[tuple, list[int]] = {}
    for i, (rec, t, lab) in enumerate(zip(campaign.records, campaign.times, campaign.labels)):
        user = rec.meta.get("noise_group")
        if user is not None:
            groups.setdefault(("user", str(user)), []).append(i)
            continue
        groups.setdefault((rec.mode, interval_key(mean_interval(t, lab))), []).append(i)
    return list(groups.values())


def mean_interval(times: np.ndarray, labels: np.ndarray) -> float:
    """Sample interval (s) of a record's measurements: the median over its continuous segments of each segment's
    mean step (span / steps), so that timestamps rounded to a few digits give the interval, not their last digit."""
    steps = []
    for s in np.unique(labels[labels >= 0]):
        t = times[labels == s]
        if len(t) > 1:
            steps.append((t[-1] - t[0]) / (len(t) - 1))
    return float(np.median(steps)) if steps else 0.0


def campaign_noise(lin, campaign: Campaign, keep_drift: bool = False) -> list:
    """Noise model of every record, fitted jointly over each :func:`noise_groups` group: the residuals of the
    group's records stacked as independent series (each restarts), REML with the fit's regressors of all of them.

    Pooling matters for campaigns of many short records (the 8-position test): a Gauss–Markov drift slower than a
    position shows only in the scatter of the position means, which per-record noise fits cannot see; the joint
    REML does, so the GLS standard errors stay honest (``benchmarks/bench_coverage.py``). White + Gauss–Markov is
    preferred to AR(p) whenever it can be fitted (``prefer_gm``), and a drift the REML cannot tell from white noise
    is dropped (:data:`WHITE_LR_CRITICAL`) unless ``keep_drift``: a coefficient tested beside the drift
    (:func:`gyrojax.inference.turntable_diagnosis.wald_beside_drift`) must not be tested against white noise because
    one realisation of the drift happened to look small.

    ``lin`` as from :func:`linearize` (residuals in the output unit, deg/h or g; times in s). Returns one
    :class:`~gyrojax.noise.spec.NoiseSpec` per record, white + Gauss–Markov (with the REML covariance of N, σ, T) or
    AR (per-sample variances in the output unit squared, τ in s); records of one group share the same object.
    """

    def one(idx):  # the groups' fits are independent: they run side by side (gyrojax.runtime.threads.parallel_map)
        r, j, lab, t = group_series(lin, idx)
        q = group_readout_variance(campaign, idx)
        kw = {"tau_span_fraction": FIT_TAU_SPAN_FRACTION, "neutral_start": True, "prefer_gm": True, "readout_var": q}
        nz = fit_noise(r, lab, t, design=j, **kw)
        if nz.gauss_markov and not keep_drift:
            nz = _white_unless_drift(r, j, lab, t, nz)
        if nz.gauss_markov:
            nz = with_reml_covariance(nz, r, j, lab, t, FIT_TAU_SPAN_FRACTION)
        return nz

    groups = noise_groups(campaign)
    noises = [None] * len(lin)
    for idx, nz in zip(groups, parallel_map(one, groups)):
        for i in idx:
            noises[i] = nz
    return noises


WHITE_LR_CRITICAL = 2.71
"""REML likelihood ratio below which a fitted Gauss–Markov component is dropped for white noise: the 5 % point of
½χ²₀ + ½χ²₁, the null law of a variance on its boundary."""


def group_readout_variance(campaign: Campaign, idx) -> float:
    """The servo readout's noise σ_q² ((deg/h)², :mod:`gyrojax.noise.readout`) of the records ``idx`` of one noise
    group (their largest; 0 for records that are not servo or not quantised)."""
    return max(
        record_readout_variance(campaign.records[i], mean_interval(campaign.times[i], campaign.labels[i])) for i in idx
    )


def _white_unless_drift(r, j, lab, t, gm: NoiseSpec):
    """White noise instead of ``gm`` when the pooled REML cannot tell the drift from white (ratio below
    :data:`WHITE_LR_CRITICAL`). On white data a Gauss–Markov variance is estimated on its boundary, so positive by
    construction, and it would widen the standard errors of position means for nothing (8-position, white noise:
    ±2σ coverage 0.974 with it, 0.959 without). The pooled REML sees the scatter of the position means, so a drift
    that matters for them is not missed by this test (8-position, τ = 300 s drift: 0.934)."""
    ok = lab >= 0
    if gm.readout_var > 0:  # white rate noise beside the known readout: its REML optimum by a 1-D search
        white = white_beside_readout(r, j, lab, t, gm)
        if gm_reml(r, j, lab, t, white) - gm_reml(r, j, lab, t, gm) >= WHITE_LR_CRITICAL:
            return gm
        return white.with_status(gm.converged, gm.reason)
    e, _ = gls_residual(r[ok], j[ok])
    rank = np.linalg.matrix_rank(j[ok]) if j.shape[1] else 0
    var = float(e @ e) / max(int(ok.sum()) - rank, 1)
    if var <= 0:
        return gm
    white = NoiseSpec.from_sample_variances(var, gm.dt_s, method="reml")  # REML optimum of white noise: |ẽ|²/(n − p)
    if gm_reml(r, j, lab, t, white) - gm_reml(r, j, lab, t, gm) >= WHITE_LR_CRITICAL:
        return gm
    return white.with_status(gm.converged, gm.reason)


def group_series(lin, idx) -> Linearized:
    """The rows of the records ``idx`` of ``lin`` stacked as independent series: labels kept apart, each record's
    clock (s) restarted at 0, so that the noise model restarts at each record."""
    rs, js, labs, ts, off = [], [], [], [], 0
    for i in idx:
        r, j, lab, t = lin[i]
        rs.append(r)
        js.append(j)
        labs.append(lab + off)
        ts.append(t - t[0] if len(t) else t)
        off += int(lab.max()) + 1 if len(lab) else 0
    return Linearized(*(np.concatenate(v) for v in (rs, js, labs, ts)))


# ---- small-sample correction ------------------------------------------------------------------------------------

INTERVAL_LEVEL = 0.97725
"""P(Z ≤ 2): standard errors are widened so that θ̂ ± 2σ keeps this one-sided level under Student's t."""


def satterthwaite_dof(lin, campaign: Campaign, noises, scales, gls_cov=None) -> np.ndarray:
    """Effective degrees of freedom ν_k of each coefficient's GLS variance V_k when the Gauss–Markov noise
    parameters are estimated (Satterthwaite 1946, as Giesbrecht & Burns 1985 apply it to REML fits):
    ν_k = 2 V_k² / Var(V̂_k), Var(V̂_k) ≈ ∇V_kᵀ I⁻¹ ∇V_k, with I the REML information of each group's
    u = (log τ, log σ_g², log σ_w²) — half the Hessian of −2 log L_R, by central differences of its exact gradient
    (:func:`gyrojax.noise.reml.reml_hessian`; the one :func:`campaign_noise` stored in the noise model's ``cov`` is
    reused, :func:`gyrojax.noise.whiten.reml_u_covariance`: the REML likelihood does not change when the residual
    moves along the regressors, as it does between the noise fit and the GLS pass) — and
    ∇V_k = −diag(V ∂(J̃ᵀJ̃)/∂u V), the derivative by central differences of the compiled whitened Gram matrix
    (:func:`gyrojax.noise.reml.whitened_gram`).

    Drift slower than a position is seen only in the scatter of the position means: an 8-position test leaves a
    handful of such degrees of freedom, and a plug-in σ̂ then covers ±2σ in ~0.88 of the cases, not 0.954.
    A τ at its cap is held fixed. Records with an AR or white model add nothing (their ν is large). A servo
    readout's known noise (``readout_var``) is in the likelihood and the Gram matrix as in the fit: without it the
    curvature is that of another likelihood, away from its optimum, where ν collapses towards 1 and the widened
    standard errors are several times too wide.
    ``gls_cov``: (J̃ᵀJ̃)⁻¹ of ``lin`` whitened by ``noises`` (:func:`gyrojax.inference.solver.solve`, unscaled), when
    the caller has it (the fit does), else computed here.
    Returns ν (dimensionless, ≥ 1; ``inf`` where no noise parameter was estimated).
    """
    if gls_cov is None:
        rw, jw = stack_whitened(lin, noises, scales)
        gls_cov = solve(jw, rw)[1]
    cov = np.asarray(gls_cov)
    v0 = np.diag(cov)
    var_v = np.zeros_like(v0)
    for idx in noise_groups(campaign):
        nz = noises[idx[0]]
        if not nz.gauss_markov or nz.gm_variance <= 0 or nz.white_variance <= 0:
            continue
        r, j, lab, t = group_series(lin, idx)
        theta = nz.whitening_theta()
        series = reml.prepare(r, j, lab, t, FIT_TAU_SPAN_FRACTION, readout_var=nz.readout_var)
        free = [1, 2] if nz.gm_tau >= 0.999 * series.tau_max else [0, 1, 2]
        kept = reml_u_covariance(nz)  # the curvature campaign_noise computed (with_reml_covariance), if at hand
        if kept is not None and np.all(np.isfinite(kept[np.ix_(free, free)])):
            cov_u = kept[np.ix_(free, free)]
        else:
            cov_u = reml_curvature_covariance(series, theta, free)
        if cov_u is None:
            names = ", ".join(campaign.records[i].name for i in idx)
            warnings.warn(
                f"the REML curvature of the noise of records {names} is not finite at its estimate"
                ": their Satterthwaite degrees of freedom are not computed and the standard errors are "
                "not widened for the estimated noise",
                ConvergenceWarning,
                stacklevel=3,
            )
            continue
        full = reml.prepare(r, j, lab, t, FIT_TAU_SPAN_FRACTION, select=False, readout_var=nz.readout_var)
        _, dgram = reml.whitened_gram(full, theta)
        grad = -np.einsum("ki,ija,jk->ka", cov, dgram, cov)[:, free]  # ∂V_k/∂u = −(V ∂A/∂u V)_kk
        var_v += np.einsum("ka,ab,kb->k", grad, cov_u, grad)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(var_v > 0, 2.0 * v0**2 / var_v, np.inf)
    return np.maximum(np.nan_to_num(nu, nan=np.inf, posinf=np.inf), 1.0)  # ∞ stays ∞ (no noise parameter)


def small_sample_factor(nu) -> np.ndarray:
    """t_ν / z at :data:`INTERVAL_LEVEL` (dimensionless, ≥ 1; 1 for ν = ∞): the widening of a standard error
    whose variance has ν effective degrees of freedom."""
    nu = np.asarray(nu, dtype=float)
    z = tails.norm_ppf(INTERVAL_LEVEL)
    return np.where(np.isfinite(nu), tails.t_ppf(INTERVAL_LEVEL, np.where(np.isfinite(nu), nu, 1.0)) / z, 1.0)


def _rms(r) -> float:
    return float(np.sqrt(np.mean(r * r))) if len(r) else 0.0


def noise_scale(r, labels) -> float:
    """Initial per-record noise level in the residual's unit (deg/h or g): from the residual's first differences
    (:func:`gyrojax.noise.whiten.first_difference_std`), floored for noise-free data."""
    return max(first_difference_std(r, labels), 1e-9 * _rms(r), 1e-15)


def white_scale(r) -> float:
    """Per-record σ of the white-noise fit (``noise="white"``), the residual's unit, floored for noise-free data."""
    return max(float(np.std(r)), 1e-9 * _rms(r), 1e-15)


def noise_not_converged(noises) -> str:
    """Reason a noise model's fit did not converge (an object with ``converged`` False), or ``""``."""
    bad = [nz for nz in noises if nz is not None and not nz.converged]
    if not bad:
        return ""
    return "the noise model's fit did not converge" + (f" ({bad[0].reason})" if bad[0].reason else "")
