"""The searches of gyrojax and how they end: one minimiser of smooth objectives within bounds, one least squares for
nonlinear models, and the :class:`Solution` both return — the answer, a :class:`Status` a caller can branch on, the
work done and, when it did not converge, why.

* :func:`minimize`: a trust-region quasi-Newton method on the exact gradient (the REML searches of the noise models,
  :mod:`gyrojax.noise.reml`, and of a triad's variance components, :mod:`gyrojax.inference.triad_components`). The
  curvature starts from differences of the exact gradient (:func:`difference_curvature`; eigenvalues made positive)
  and is updated by BFGS; a variable at a bound with the gradient pushing outward is held there.
* :func:`least_squares`: Levenberg–Marquardt (MINPACK's, by ``scipy.optimize.least_squares``) on the exact Jacobian
  that the caller computes (``jax.jacfwd`` of the measurement model), its trust region measured in the coefficients'
  own units.
* :func:`minimize_scalar`: the minimum of a function of one variable within a bracket (Brent's bounded method, by
  ``scipy.optimize.minimize_scalar``): a Gauss–Markov correlation time, a white level beside a readout, a scale.
* :func:`bisect`: the bracket where a monotone yes/no question turns to yes (the shortest dwell that suffices).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np


class Status(enum.Enum):
    """How a search ended."""

    CONVERGED = "converged"
    ITERATION_LIMIT = "iteration limit"
    NOT_FINITE = "not finite"


@dataclass(frozen=True)
class Solution:
    """A search's answer: ``x`` (the caller's units), ``value`` the objective there, its ``status``, the ``steps``
    taken (iterations, or evaluations of a least-squares system) and the ``reason`` it stopped short ("" when it
    converged)."""

    x: np.ndarray
    value: float
    status: Status
    steps: int
    reason: str = ""

    @property
    def converged(self) -> bool:
        """Whether the search converged (``status`` is :attr:`Status.CONVERGED`)."""
        return self.status is Status.CONVERGED


DECREMENT_TOL = 1e-2
"""Largest decrease of the objective still predicted at the iteration limit for :func:`minimize` to count as
converged: a flat direction (τ of a vanishing Gauss–Markov variance) crawls without changing the likelihood. Under
1/200 of the smallest likelihood-ratio critical value the searches feed (2.71, the drift test), so no test, interval
or degree of freedom built on them moves."""


def difference_curvature(grad, x, g, steps) -> np.ndarray:
    """A positive-definite start of the curvature at ``x``: differences of the exact gradient (``grad`` of each
    ``x + steps[k] e_k``, a list; ``g`` the gradient at ``x``), symmetrised, eigenvalues made positive; a scaled
    identity where a difference is not finite."""
    n = len(x)
    h0 = np.column_stack([(gk - g) / steps[k] for k, gk in enumerate(grad)])
    if not np.all(np.isfinite(h0)):
        h0 = np.eye(n) * max(float(np.abs(np.nan_to_num(g)).max()), 1.0)
    ev, vec = np.linalg.eigh(0.5 * (h0 + h0.T))
    ev = np.maximum(np.abs(ev), 1e-8 * max(float(np.abs(ev).max()), 1e-300) + 1e-300)
    return (vec * ev) @ vec.T


def minimize(
    value_and_grad,
    x0,
    lo,
    hi,
    curvature,
    max_steps: int = 80,
    ftol: float = 1e-10,
    what: str = "search",
    first=None,
) -> Solution:
    """The minimum of a smooth objective within the bounds [``lo``, ``hi``] from ``x0`` (module doc).
    ``value_and_grad(x)`` -> (f, ∇f); ``curvature`` the starting Hessian approximation (positive definite).

    Converged when the predicted decrease falls below ``ftol``, every variable is held at a bound, or the trust
    region shrinks below 1e-8 without a lower value (a minimum to rounding); not converged on a non-finite gradient,
    or at ``max_steps`` iterations unless the quasi-Newton decrement ½gᵀB⁻¹g (the decrease a full step would still
    bring) is below :data:`DECREMENT_TOL`. ``what`` names the search in its reason; ``first`` the value and gradient
    at ``x0`` (within the bounds) when the caller has them."""
    x = np.clip(np.asarray(x0, dtype=float), lo, hi)
    f, g = value_and_grad(x) if first is None else first
    f, g = float(f), np.asarray(g)
    b = np.asarray(curvature, dtype=float)
    n = len(x)
    radius, it = 2.0, 0
    status, why = Status.ITERATION_LIMIT, ""
    while it < max_steps:
        it += 1
        free = ~(((x >= hi - 1e-12) & (g < 0)) | ((x <= lo + 1e-12) & (g > 0)))
        if not np.all(np.isfinite(g)):
            status, why = Status.NOT_FINITE, f"{what} stopped at a non-finite gradient"
            break
        if not free.any():
            status = Status.CONVERGED
            break
        gf, bf = g[free], b[np.ix_(free, free)]
        d = _newton_step(bf, gf)
        if not np.all(np.isfinite(d)):  # the curvature broke down: start it again from a scaled identity
            b = np.eye(n) * max(float(np.abs(g).max()), 1.0)
            bf = b[np.ix_(free, free)]
            d = -gf / bf[0, 0]
        norm = float(np.linalg.norm(d))
        if norm > radius:
            d *= radius / norm
        pred = -(gf @ d + 0.5 * d @ bf @ d)
        if pred < ftol:
            status = Status.CONVERGED
            break
        step = np.zeros(n)
        step[free] = d
        xn = np.clip(x + step, lo, hi)
        fn, gn = value_and_grad(xn)
        fn, gn = float(fn), np.asarray(gn)
        if not (np.isfinite(fn) and fn < f):
            radius = 0.25 * min(radius, norm)
            if radius < 1e-8:
                if np.isfinite(f):
                    status = Status.CONVERGED
                else:
                    status, why = Status.NOT_FINITE, f"{what} found no finite value"
                break
            continue
        sk, yk = xn - x, gn - g
        bs = b @ sk
        if sk @ yk > 1e-12 * np.linalg.norm(sk) * np.linalg.norm(yk) and sk @ bs > 0:  # BFGS update of the curvature
            b = b - np.outer(bs, bs) / (sk @ bs) + np.outer(yk, yk) / (sk @ yk)
        ratio = (f - fn) / pred
        if ratio > 0.75 and norm >= 0.99 * radius:
            radius = min(2.0 * radius, 8.0)
        elif ratio < 0.25:
            radius = 0.5 * min(radius, norm)
        x, f, g = xn, fn, gn
    else:  # at the iteration limit: converged when the quasi-Newton decrement says f is at its minimum
        free = ~(((x >= hi - 1e-12) & (g < 0)) | ((x <= lo + 1e-12) & (g > 0)))
        gf = g[free]
        dec = -0.5 * float(gf @ _newton_step(b[np.ix_(free, free)], gf)) if free.any() else 0.0
        if np.isfinite(dec) and dec < DECREMENT_TOL:
            status = Status.CONVERGED
        else:
            why = f"{what} stopped at its iteration limit ({max_steps}), the objective still falling ({dec:.2g})"
    return Solution(x, f, status, it, why)


def _newton_step(b, g) -> np.ndarray:
    """−B⁻¹g, NaN where B is singular."""
    try:
        return -np.linalg.solve(b, g)
    except np.linalg.LinAlgError:
        return np.full_like(g, np.nan)


def least_squares(system, x0, max_nfev: int) -> Solution:
    """x minimising |r(x)|² by Levenberg–Marquardt (``scipy.optimize.least_squares``, method ``"lm"``, MINPACK) with
    the exact Jacobian: ``system(x)`` returns (r, J), r the whitened residual "y − f(x)" and J = ∂f/∂x, whitened
    alike. The trust region is measured in the coefficients' own units (``x_scale=1``), so a start far from the
    optimum is damped instead of overshooting. At most ``max_nfev`` evaluations (``steps``); ``value`` is |r|² at
    the answer."""
    from scipy.optimize import least_squares as lm

    cached = remember_last(system)  # MINPACK asks for J at the answer after a trial step beyond it
    sol = lm(
        lambda x: -cached(x)[0],
        np.asarray(x0, dtype=float),
        jac=lambda x: cached(x)[1],
        method="lm",
        x_scale=1.0,
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=max_nfev,
    )
    if sol.status > 0:
        status, why = Status.CONVERGED, ""
    else:
        status = Status.ITERATION_LIMIT if sol.status == 0 else Status.NOT_FINITE
        why = f"Levenberg–Marquardt stopped after {sol.nfev} evaluations: {sol.message}"
    return Solution(np.asarray(sol.x, dtype=float), 2.0 * float(sol.cost), status, int(sol.nfev), why)


def remember_last(f, points: int = 2):
    """``f`` of one float array, its values at the last ``points`` arguments kept: a search that comes back to a
    point (the answer after a trial beyond it, the caller's evaluation at the answer) does not evaluate it again.
    The values are returned as they are (shared, not copied): for functions whose results are read, never written."""
    kept: dict = {}

    def remembered(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in kept:
            while len(kept) >= points:
                del kept[next(iter(kept))]
            kept[key] = f(x)
        return kept[key]

    return remembered


def minimize_scalar(f, lo: float, hi: float, xatol: float = 1e-5, what: str = "search") -> Solution:
    """The minimum of ``f`` (one float → float) within [``lo``, ``hi``] by Brent's method (golden sections and
    parabolic steps; ``scipy.optimize.minimize_scalar``, method ``"bounded"``) to ``xatol`` in x, at most 500
    evaluations. ``x`` is a float array of shape (); ``what`` names the search in its reason."""
    from scipy.optimize import minimize_scalar as brent

    sol = brent(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    if sol.success:
        status, why = Status.CONVERGED, ""
    else:
        status = Status.NOT_FINITE if not np.isfinite(sol.fun) else Status.ITERATION_LIMIT
        why = f"{what} stopped after {sol.nfev} evaluations: {sol.message}"
    return Solution(np.asarray(sol.x, dtype=float), float(sol.fun), status, int(sol.nfev), why)


def bisect(ok, lo: float, hi: float) -> tuple[float, float]:
    """(lo, hi) halved until ``hi`` − ``lo`` < 10⁻³ ``hi`` (at most 40 halvings), ``ok`` a predicate true at and
    above some point of [lo, hi] (the caller knows ``ok(hi)``): ``hi`` passes, ``lo`` does not (unless it is the
    start); in the units of ``lo`` and ``hi``."""
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
        if hi - lo < 1e-3 * hi:
            break
    return lo, hi
