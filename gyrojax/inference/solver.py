"""The solver of a campaign fit for fixed noise models: the whitened stacked system, the rank-cut solve and the
damped nonlinear least squares of the set-up effects."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.identifiability import ALIAS_TOL, residue_columns
from gyrojax.inference.lstsq import lstsq
from gyrojax.noise.whiten import whiten
from gyrojax.physics.model import Model


def stack_whitened(lin, noises, scales):
    """Whitened, weighted stacked system from per-record (r, J, labels)."""
    rows_r, rows_j = [], []
    for (r, j, lab, t), nz, s in zip(lin, noises, scales):
        if nz is None:
            rows_r.append(r / s)
            rows_j.append(j / s)
        else:
            both = np.column_stack([r, j])
            w, _ = whiten(both, lab, nz, t)
            rows_r.append(w[:, 0])
            rows_j.append(w[:, 1:])
    return np.concatenate(rows_r), np.concatenate(rows_j, axis=0)


def solve(jw, rw, rank_tol=ALIAS_TOL):
    """Least-squares step and (JᵀJ)⁻¹ in normalised columns, by SVD with a rank cut
    (:func:`gyrojax.inference.lstsq.lstsq`). Floating-point residue columns (:func:`residue_columns`) get no step
    and no finite uncertainty."""
    if jw.shape[1]:
        jw = np.where(residue_columns(jw), 0.0, jw)
    return lstsq(jw, rw, "svd", rank_tol)


def weighted_least_squares(model: Model, theta, campaign: Campaign, noises, scales, max_iter: int):
    """θ minimising the weighted (``noises[i] is None``: divided by ``scales[i]``) or whitened residual of every
    record, for fixed noise models. Returns (θ, iterations, reason it did not converge or ``""``).

    A model linear in θ needs one solve (:func:`solve`, rank-cut SVD). The nonlinear set-up effects (table tilt
    and azimuth, encoder harmonics; conventions §6) are fitted by Levenberg–Marquardt
    (``scipy.optimize.least_squares``, method ``"lm"``, MINPACK) with the exact ``jax.jacfwd`` Jacobian, so a start
    far from the optimum is damped instead of overshooting. The trust region is measured in report units (arcsec,
    ppm, deg/h …, the natural scale of each coefficient): scaling it by the Jacobian's columns instead lets the
    first steps wander along the weakly seen set-up angles when a record is nearly noise-free. The whitening is
    linear in the data, so the whitened residual and Jacobian of :func:`stack_whitened` are exact for the solver too.
    """
    if model.is_linear or model.size == 0:
        rw, jw = stack_whitened(linearize(model, theta, campaign), noises, scales)
        step, _ = solve(jw, rw)
        return theta + step, 1, ""
    return damped_least_squares(
        lambda th: stack_whitened(linearize(model, th, campaign), noises, scales), theta, max_iter * (model.size + 1)
    )


def damped_least_squares(system, theta0, max_nfev: int):
    """θ minimising |r(θ)|² by Levenberg–Marquardt (``scipy.optimize.least_squares``, method ``"lm"``, MINPACK)
    with the exact Jacobian: ``system(θ)`` returns (r, J), r the whitened residual "y − f(θ)" and J = ∂f/∂θ, whitened
    alike. The trust region is measured in the coefficients' own units (``x_scale=1``). At most ``max_nfev``
    evaluations. Returns (θ, evaluations, why it did not converge: scipy's status message, or ``""``)."""
    cache = {}

    def cached(th):
        key = th.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = system(th)
        return cache[key]

    sol = least_squares(
        lambda th: -cached(th)[0],
        np.asarray(theta0, dtype=float),
        jac=lambda th: cached(th)[1],
        method="lm",
        x_scale=1.0,
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=max_nfev,
    )
    why = "" if sol.status > 0 else f"Levenberg–Marquardt stopped after {sol.nfev} evaluations: {sol.message}"
    return np.asarray(sol.x, dtype=float), int(sol.nfev), why
