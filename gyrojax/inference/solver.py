"""The solver of a campaign fit for fixed noise models: the whitened stacked system, the rank-cut solve and the
damped nonlinear least squares of the set-up effects."""

from __future__ import annotations

import numpy as np

from gyrojax.inference.campaign import Campaign, linearize
from gyrojax.inference.identifiability import ALIAS_TOL, residue_columns
from gyrojax.inference.lstsq import lstsq
from gyrojax.noise.whiten import whiten
from gyrojax.optimize import least_squares
from gyrojax.physics.model import Model


def stack_whitened(lin, noises, scales=None):
    """The records' rows (:class:`~gyrojax.inference.campaign.Linearized`) whitened by each record's noise model
    (``noises[i]`` None: divided by ``scales[i]``, the record's noise level) and stacked: (r̃ (n,), J̃ (n, p)),
    dimensionless. Whitening is linear in the data, so it is exact for the least squares of the fit and for the
    score tests of the diagnosis alike."""
    rows_r, rows_j = [], []
    for i, (rec, nz) in enumerate(zip(lin, noises)):
        if nz is None:
            rows_r.append(rec.residual / scales[i])
            rows_j.append(rec.jacobian / scales[i])
        else:
            w, _ = whiten(np.column_stack([rec.residual, rec.jacobian]), rec.labels, nz, rec.times)
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


def weighted_least_squares(model: Model, theta, campaign: Campaign, noises, scales, max_iter: int, lin=None):
    """θ minimising the weighted (``noises[i] is None``: divided by ``scales[i]``) or whitened residual of every
    record, for fixed noise models. Returns (θ, iterations, reason it did not converge or ``""``).

    A model linear in θ needs one solve (:func:`solve`, rank-cut SVD). The nonlinear set-up effects (table tilt
    and azimuth, encoder harmonics; conventions §6) are fitted by Levenberg–Marquardt
    (:func:`gyrojax.optimize.least_squares`) with the exact ``jax.jacfwd`` Jacobian, so a start
    far from the optimum is damped instead of overshooting. The trust region is measured in report units (arcsec,
    ppm, deg/h …, the natural scale of each coefficient): scaling it by the Jacobian's columns instead lets the
    first steps wander along the weakly seen set-up angles when a record is nearly noise-free. The whitening is
    linear in the data, so the whitened residual and Jacobian of :func:`stack_whitened` are exact for the solver too.
    ``lin``: the rows of :func:`~gyrojax.inference.campaign.linearize` at ``theta`` when the caller has them.
    """
    if model.is_linear or model.size == 0:
        rw, jw = stack_whitened(linearize(model, theta, campaign) if lin is None else lin, noises, scales)
        step, _ = solve(jw, rw)
        return theta + step, 1, ""
    sol = least_squares(
        lambda th: stack_whitened(linearize(model, th, campaign), noises, scales), theta, max_iter * (model.size + 1)
    )
    return sol.x, sol.steps, sol.reason
