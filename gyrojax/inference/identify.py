"""Identification: joint fits of named effects to one or many records, with honest uncertainties.

:func:`fit` is the one public entry: the records' instrument kind chooses the fit (turntable records:
:func:`fit_campaign`, below; ``imu-triad`` records: :func:`gyrojax.inference.triad.fit_triad`), and an option the
chosen fit cannot honour is refused, never dropped.

The measurement model of every record (:func:`gyrojax.physics.model.predict`) is linearised by ``jax.jacfwd``; the
stacked system is solved by one least-squares step when every effect is linear in its coefficients; the set-up
effects, which enter through the kinematics, are fitted by Levenberg–Marquardt (``scipy.optimize.least_squares``,
method ``"lm"``) on the same weighted or whitened system with the exact ``jax.jacfwd`` Jacobian, and its stopping
status is the fit's ``converged`` flag (:class:`~gyrojax.errors.ConvergenceWarning` when it did not).

With ``noise="ar"`` (the default) a white + Gauss–Markov (or AR) noise model is fitted by REML to the residuals of
each group of records of one mode and sample interval, jointly (:func:`~gyrojax.inference.noisefit.campaign_noise`),
so the fit is feasible GLS and standard errors stay honest under coloured drift, also when the drift is slower than
one position (module :mod:`gyrojax.noise.whiten`).

Before any number is reported the plan's identifiability is checked: the singular values of the column-normalised,
whitened regressor matrix give the rank, the condition number and the groups of effects the plan cannot tell apart
(for example D_F, D_II, D_OO and D_SS in any 1 g test, since a_I² + a_O² + a_S² is constant). Such a fit raises
:class:`~gyrojax.inference.identifiability.IdentifiabilityError` naming the groups, unless ``allow_aliases=True``.

This is the torque-to-balance procedure of the 1967 CIGTF standard in modern form: least squares on all records of
all positions and modes at once, each coefficient with its standard error and significance.

The parts live in modules of one job each: the records as arrays (:mod:`~gyrojax.inference.campaign`), the
identifiability analysis (:mod:`~gyrojax.inference.identifiability`), the solver for fixed noise models
(:mod:`~gyrojax.inference.solver`), the noise fit of a campaign (:mod:`~gyrojax.inference.noisefit`) and the result
with its file (:mod:`~gyrojax.inference.result`); this module is the fit that joins them.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.campaign import Campaign, check_terms, input_hashes, linearize, split_by_instrument
from gyrojax.inference.identifiability import IdentifiabilityError, alias_message, identifiability
from gyrojax.inference.knee import profile_start
from gyrojax.inference.noisefit import (
    campaign_noise,
    noise_not_converged,
    noise_scale,
    satterthwaite_dof,
    small_sample_factor,
    white_scale,
)
from gyrojax.inference.result import FitResult
from gyrojax.inference.solver import solve, stack_whitened, weighted_least_squares
from gyrojax.inference.triad import fit_triad, is_triad_input
from gyrojax.kinds import TRIAD_KIND
from gyrojax.noise import reml
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.runtime.threads import narrow_blas

DEFAULT_TERMS = {
    fx.SDF: ("D_F", "D_I", "D_O", "D_S"),
    fx.TDF: ("DX_F", "DY_F"),
    fx.ACCEL: ("K_0", "K_1"),
    fx.FOG: ("D_F", "sf_error"),
    fx.RLG: ("D_F", "sf_error"),
}


@narrow_blas
def fit(
    records,
    terms=None,
    *,
    kind: str | None = None,
    noise=None,
    allow_aliases: bool = False,
    theta0=None,
    max_iter: int = 30,
    campaign: Campaign | None = None,
    earth_rate: bool | None = None,
):
    """The one public fit: the records' instrument kind chooses the fit, and every option is honoured by it or
    refused with one :class:`~gyrojax.errors.ModelError` naming the options it cannot honour.

    * Turntable records (``sdf``, ``tdf``, ``accel``, ``fog``, ``rlg``), or a ``campaign``: :func:`fit_campaign`
      (all options but ``earth_rate``; a record's Earth rate follows its site). ``noise`` ``None`` means ``"ar"``.
    * ``imu-triad`` records: :func:`gyrojax.inference.triad.fit_triad` with ``terms``, ``allow_aliases``,
      ``earth_rate``, ``max_iter`` (iterations of the gravity-to-gravity moves) and ``noise``: ``None`` (the
      long-run variance estimated from the static poses) or the three channels' long-run variances, (deg/h)² per
      sample. ``kind`` (other than ``"imu-triad"``), ``theta0`` and the turntable noise choices are refused.

    Returns: a :class:`~gyrojax.inference.result.FitResult`, or a :class:`~gyrojax.inference.triad_result.TriadFit`.
    """
    if campaign is None and is_triad_input(records):
        refused = []
        if kind not in (None, TRIAD_KIND):
            refused.append(f"kind={kind!r}")
        if theta0 is not None:
            refused.append("theta0 (every triad coefficient is linear: there is no start to give)")
        if isinstance(noise, (str, NoiseSpec)):
            refused.append(
                f"noise={noise!r} (a triad's noise is the long-run variance of each channel: None, three variances "
                "or a SessionNoise)"
            )
        if refused:
            raise ModelError(f"the fit of imu-triad records cannot honour {'; '.join(refused)}")
        return fit_triad(
            records, terms, earth_rate=earth_rate, allow_aliases=allow_aliases, noise_q=noise, max_iter=max_iter
        )
    if earth_rate is not None:
        raise ModelError(
            "earth_rate applies to imu-triad records; the Earth rate of a turntable record follows its site "
            "(JSON key site.latitude_deg)"
        )
    return fit_campaign(
        records,
        terms,
        kind=kind,
        noise="ar" if noise is None else noise,
        allow_aliases=allow_aliases,
        theta0=theta0,
        max_iter=max_iter,
        campaign=campaign,
    )


def fit_campaign(
    records,
    terms=None,
    *,
    kind: str | None = None,
    noise="ar",
    allow_aliases: bool = False,
    theta0=None,
    max_iter: int = 30,
    campaign: Campaign | None = None,
) -> FitResult:
    """Fit the named effects ``terms`` to turntable ``records`` jointly (conventions §6 names).

    Args:
      records: a :class:`Record`, or a list of records of one instrument kind (any plans, mountings, modes).
      terms: effect names (or coefficient names); default: D_F, D_I, D_O, D_S for an SDF gyro.
      noise: ``"ar"`` (GLS with a white + Gauss–Markov or AR noise model per group of records, :func:`campaign_noise`;
        default), ``"white"`` (WLS, one σ per record), or a given noise model (a
        :class:`gyrojax.noise.spec.NoiseSpec` of white + at most one Gauss–Markov term, e.g. from ``gyrojax noise``):
        GLS with that covariance, not re-estimated, and the standard errors not rescaled by the residual χ² (the
        noise is known).
      allow_aliases: return a minimum-norm fit instead of raising when the plan cannot separate some effects
        (those coefficients then have no finite standard error).
      theta0: starting coefficients (report units) for the nonlinear set-up effects.
      max_iter: iterations of the nonlinear solver (Jacobian evaluations per coefficient).
      campaign: the records already built into a :class:`Campaign` (``records`` is then not read).

    Returns: a :class:`FitResult`.

    Raises: :class:`IdentifiabilityError` naming the effects the plan cannot tell apart.
    """
    camp = campaign or Campaign.of(records)
    kind = kind or camp.kind
    model = Model.of(terms if terms is not None else DEFAULT_TERMS[kind], kind)
    check_terms(model, camp)
    theta = np.zeros(model.size) if theta0 is None else np.asarray(theta0, dtype=float).copy()
    n_rec = len(camp.records)
    if theta0 is None and any(e.knee is not None for e in model.effects):
        # a hinged effect's knee is seen only once its slope change is not zero: start from the knee's profile
        scales0 = [noise_scale(r, lab) for r, _, lab, _ in linearize(model, theta, camp)]
        theta = profile_start(model, camp, theta, scales0)

    # white pass: per-record σ from the high-frequency residual; one solve, or Levenberg–Marquardt when nonlinear
    lin = linearize(model, theta, camp)
    scales = [noise_scale(r, lab) for r, _, lab, _ in lin]
    noises = [None] * n_rec
    rw, jw = stack_whitened(lin, noises, scales)
    report = identifiability(jw, model)
    if (report["aliases"] or report["unexcited"]) and not allow_aliases:
        raise IdentifiabilityError(alias_message(report), report)
    theta, it, why = weighted_least_squares(model, theta, camp, noises, scales, max_iter, lin)
    lin = linearize(model, theta, camp)
    # noise model and GLS pass
    known = isinstance(noise, NoiseSpec)  # a given noise model (e.g. from gyrojax noise): GLS, not re-estimated
    if known:
        if kind == fx.ACCEL:
            raise ModelError(f"a noise model in deg/h applies to gyro records, not to {kind!r}")
        noise.whitening_theta(1.0)  # white + at most one Gauss-Markov process, or a NoiseModelError naming the rest
        noises = [replace(noise, dt_s=float(np.median(np.diff(t)))) for *_, t in lin]
        theta, it_gls, why_gls = weighted_least_squares(model, theta, camp, noises, scales, max_iter, lin)
        it, why = it + it_gls, why or why_gls
        lin = linearize(model, theta, camp)
    elif noise == "ar":
        noises = campaign_noise(lin, camp)
        theta, it_gls, why_gls = weighted_least_squares(model, theta, camp, noises, scales, max_iter, lin)
        it, why = it + it_gls, why or why_gls
        lin = linearize(model, theta, camp)
        why = why or noise_not_converged(noises)
    elif noise != "white":
        raise ModelError(f"noise must be 'ar' or 'white', got {noise!r}")
    else:
        scales = [white_scale(r) for r, *_ in lin]
    rw, jw = stack_whitened(lin, noises, scales)
    report = identifiability(jw, model)
    if len(rw) - report["rank"] < 1:
        raise ModelError(
            f"{len(rw)} measurement(s) for {report['rank']} coefficient(s): no degrees of freedom are left to "
            "estimate the noise, so no standard error can be stated; add samples or drop effects"
        )
    _, cov = solve(jw, rw)
    gls_cov = cov  # unscaled (J̃ᵀJ̃)⁻¹, for the Satterthwaite degrees of freedom
    dof = max(len(rw) - report["rank"], 1)
    chi2 = float(rw @ rw)
    if not known:
        cov = cov * chi2 / dof  # the noise levels were estimated: scale by the pooled reduced χ² of the whitened fit
    dof_eff = None
    if noise == "ar" and any(nz.gauss_markov for nz in noises):
        dof_eff = satterthwaite_dof(lin, camp, noises, scales, gls_cov)
        g = small_sample_factor(dof_eff)
        cov = cov * np.outer(g, g)  # Student-t widening: θ̂ ± 2σ keeps its coverage when ν is small
    noise_models = [
        nz if nz is not None else NoiseSpec.from_sample_variances(s * s, reml.sample_interval(t), method="ar")
        for nz, s, (*_, t) in zip(noises, scales, lin)
    ]
    if why:
        # stacklevel 3: the caller of the public fit (the facade) is the line to blame
        warnings.warn(f"fit of {', '.join(model.terms)} did not converge: {why}", ConvergenceWarning, stacklevel=3)
    return FitResult(
        model=model,
        theta=theta,
        cov=cov,
        residuals=[r for r, *_ in lin],
        labels=[lab for _, _, lab, _ in lin],
        record_names=[r.name for r in camp.records],
        record_paths=[r.path for r in camp.records],
        noise=noise_models,
        identifiability=report,
        n_samples=camp.n_measurements,
        iterations=it,
        converged=not why,
        convergence_note=why,
        chi2_whitened=chi2,
        dof=dof,
        inputs=input_hashes(camp.records),
        dof_eff=dof_eff,
    )


def fit_per_instrument(records, terms=None, **kw) -> dict:
    """One :func:`fit` per instrument (:func:`~gyrojax.inference.campaign.instrument_id`), never pooled:
    ``{id: FitResult or TriadFit}``."""
    return {k: fit(v, terms, **kw) for k, v in split_by_instrument(records).items()}
