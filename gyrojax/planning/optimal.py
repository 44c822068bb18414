"""Optimal test-plan design by gradients through the measurement model: the Fisher information of
:mod:`gyrojax.planning.fisher`, a criterion of :mod:`gyrojax.planning.criteria`, minimised over the positions.

**Parameterisation.** N positions on the two-axis table (``plans.TWO_AXIS``): free angles (trunnion, platform) in
rad, and dwell fractions p = m + (1 − N m)·softmax(z) (minimum fraction m) of the total dwell time. Adam then a few
L-BFGS steps, ``vmap`` over random starts; the best start is kept. :func:`design_plan` turns the result into a
:class:`gyrojax.data.plans.Plan` that ``gyrojax simulate`` runs. ``Table.fixture()`` replaces the table by a free
orientation (an E–N–U Euler chain) for a fixture; a discrete N is chosen by :func:`sweep_positions`.

**Limits.** A static SDF position gives one scalar, so a p-coefficient model needs N ≥ p positions (the 9-term
model cannot be identified from 8). In every static 1-g position a_I² + a_O² + a_S² = (g/g0)², so D_OO is aliased
with D_F, D_II, D_SS: ``detect:D_OO`` for the 9-term model has zero noncentrality whatever the plan, and
:func:`design` refuses it (only a centrifuge changes |f|).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.data import plans
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model
from gyrojax.planning import search
from gyrojax.planning.criteria import (
    Criterion,
    criterion_values,
    detect_noncentrality,
    detect_power,
    noncentrality,
)
from gyrojax.planning.fisher import DEFAULT_NOISE, Table, check_static, position_rows, static_fisher

SDF9 = ("D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS")
"""The SDF drift model of Hu 2-45 less D_OO (the design tests' model; D_OO is the effect left out)."""


@dataclass
class DesignResult:
    """A designed static plan and its convergence report."""

    angles_deg: np.ndarray  # (n, k)
    dwell_s: np.ndarray  # (n,)
    loss: float
    criterion: Criterion
    model: Model
    table: Table
    noise: NoiseSpec
    dt_s: float
    history: np.ndarray  # best start's loss per iteration (adam then L-BFGS)
    grad_norm: float  # at the end, best start
    start_losses: np.ndarray  # final loss of every start
    fisher: np.ndarray = field(default=None)  # of the model (not the augmented one)
    timing: dict = field(default_factory=dict)  # compile_s, run_s

    @property
    def convergence_note(self) -> str:
        """Why the search is not taken as converged ("" when it is; :func:`gyrojax.planning.search.convergence_note`
        of the best start's history)."""
        return search.convergence_note(self.history, self.loss, "raise adam_steps / lbfgs_steps")

    @property
    def converged(self) -> bool:
        """Whether the best start's search settled (see :attr:`convergence_note`)."""
        return not self.convergence_note

    def plan(self, name: str = "designed", gap_s: float = 30.0) -> plans.Plan:
        """The design as a plan (see :func:`design_plan`); ``gap_s`` in s between positions."""
        return design_plan(self, name, gap_s)

    def summary(self) -> dict:
        """JSON-ready report: criterion, loss, convergence, timing (s), positions (angles in deg, dwell in s),
        D/A/E and the Cramér–Rao std of every coefficient (report units)."""
        d = criterion_values(self.fisher, self.model)
        out = {
            "criterion": self.criterion.label(),
            "loss": self.loss,
            "grad_norm": self.grad_norm,
            "iterations": len(self.history),
            "converged": self.converged,
            **({"reason": self.convergence_note} if not self.converged else {}),
            **self.timing,
            "start_losses": self.start_losses.tolist(),
            "positions": [
                {"angles_deg": a.tolist(), "dwell_s": float(t)} for a, t in zip(self.angles_deg, self.dwell_s)
            ],
            **d,
        }
        if self.criterion.kind == "detect":
            lam = detect_noncentrality(
                self.model, self.criterion, self.table, np.deg2rad(self.angles_deg), self.dwell_s, self.noise, self.dt_s
            )
            out["noncentrality"] = lam
            out["power_1pct"] = detect_power(lam, len(self.criterion.magnitude))
        return out


def _check_detectable(model, crit, table, angles_rad, dwell_s, noise, dt_s) -> None:
    """Raise when the omitted effect's regressor lies in the model's span at generic static positions.

    Example: D_OO with D_F, D_II, D_SS in the model, since a_I² + a_O² + a_S² = (g/g0)² is the same in every
    static 1-g position: no static plan can reveal it (its score-test noncentrality is zero).
    """
    full = crit.design_model(model)
    n = angles_rad.shape[0]
    f = static_fisher(full, table, angles_rad, jnp.full(n, dwell_s), noise, dt_s)
    p = model.size
    delta = jnp.asarray(crit.magnitude)
    ratio = float(noncentrality(f, p, delta) / (delta @ f[p:, p:] @ delta))
    if not ratio > 1e-9:
        raise ModelError(
            f"detect:{crit.effect}: its regressors lie in the span of the model's at every static "
            f"position tried (orthogonal fraction {ratio:.1e}); no static plan can reveal it"
        )


def dwell_from_logits(z, total_s: float, min_fraction: float):
    """Dwell times in s from unconstrained logits ``z``: each at least ``min_fraction`` of ``total_s`` (s),
    summing to ``total_s`` (a softmax; keeps the optimiser's dwells positive)."""
    n = z.shape[-1]
    return total_s * (min_fraction + (1.0 - n * min_fraction) * jax.nn.softmax(z))


KEEP_COMPILED = 8
"""Compiled optimisers a process keeps, the most recent (a repeated design skips compilation)."""
_COMPILED: dict = {}


def _optimiser(model, crit, n_positions, total, m, free_dwell, noise, dt_s, adam_steps, lbfgs_steps, learning_rate):
    """The multi-start optimiser: f((angles, logits), template, thetas) -> (params, history, losses, |grad|)."""
    full = crit.design_model(model)

    def loss_fn(params, template, thetas):
        ang, z = params
        dw = dwell_from_logits(z, total, m) if free_dwell else jnp.full(n_positions, total / n_positions)
        tab = Table.of_template(template)

        def one(th):
            return crit.loss(static_fisher(full, tab, ang, dw, noise, dt_s, th), model.size)

        return jnp.mean(jax.vmap(one)(thetas))

    def optimise(params, template, thetas):
        def one(p0):
            return search.minimise(lambda p: loss_fn(p, template, thetas), p0, adam_steps, lbfgs_steps, learning_rate)

        return jax.vmap(one)(params)

    return optimise


def design(
    terms,
    n_positions: int = 24,
    hours: float = 4.0,
    criterion="D",
    *,
    table: Table | None = None,
    noise: NoiseSpec | None = None,
    dt_s: float = 1.0,
    starts: int = 8,
    seed: int = 0,
    adam_steps: int = 600,
    lbfgs_steps: int = 40,
    learning_rate: float = 0.05,
    min_fraction: float | None = None,
    free_dwell: bool = True,
    prior_thetas=None,
    kind: str = fx.SDF,
) -> DesignResult:
    """Design a static ``n_positions`` plan of ``hours`` total dwell that minimises the criterion's loss.

    ``prior_thetas`` (s, p): a prior sample of θ for nonlinear models (the mean loss over it is minimised).
    ``min_fraction`` defaults to 0.25/N (every position keeps at least a quarter of the equal share).
    """
    model = terms if isinstance(terms, Model) else Model.of(terms, kind)
    check_static(model)
    crit = criterion if isinstance(criterion, Criterion) else Criterion.parse(criterion, model)
    full = crit.design_model(model)
    table = table or Table.two_axis()
    noise = DEFAULT_NOISE if noise is None else noise
    total = hours * 3600.0
    m = 0.25 / n_positions if min_fraction is None else min_fraction
    k = len(table.axis_names)
    thetas = jnp.zeros((1, full.size)) if prior_thetas is None else jnp.atleast_2d(jnp.asarray(prior_thetas))
    if thetas.shape[1] == model.size and full.size > model.size:
        thetas = jnp.concatenate([thetas, jnp.zeros((thetas.shape[0], full.size - model.size))], axis=1)

    key = jax.random.PRNGKey(seed)
    ang0 = jax.random.uniform(key, (starts, n_positions, k), minval=0.0, maxval=2 * math.pi)
    channels = position_rows(full, table, ang0[0]).shape[0]
    if n_positions * channels < full.size:
        # F = Σ jᵀj/Var has rank ≤ positions × channels: its log-determinant would be round-off, and the search
        # would climb it to NaN on one CPU and to a meaningless plan on another
        raise ModelError(
            f"{n_positions} static positions give at most {n_positions * channels} independent means for the "
            f"{full.size} coefficients of {', '.join(full.terms)}: the Fisher information is singular for every "
            f"plan; use at least {-(-full.size // channels)} positions or fewer terms"
        )
    if crit.kind == "detect":
        _check_detectable(model, crit, table, ang0[0], total / n_positions, noise, dt_s)
    z0 = jnp.zeros((starts, n_positions))
    config = (model, crit, n_positions, total, m, free_dwell, noise, dt_s, adam_steps, lbfgs_steps, learning_rate)
    args = ((ang0, z0), table.template, thetas)
    ckey = (config, jax.tree_util.tree_structure(args), tuple(x.shape for x in jax.tree_util.tree_leaves(args)))
    t0 = time.perf_counter()
    if ckey not in _COMPILED:
        if len(_COMPILED) >= KEEP_COMPILED:
            del _COMPILED[next(iter(_COMPILED))]  # the oldest: each holds an executable
        _COMPILED[ckey] = jax.jit(_optimiser(*config)).lower(*args).compile()
    t1 = time.perf_counter()
    (ang, z), hist, vals, gn = jax.block_until_ready(_COMPILED[ckey](*args))
    timing = {"compile_s": t1 - t0, "run_s": time.perf_counter() - t1}
    b = search.best_start(vals, "design")
    vals = np.where(np.isfinite(np.asarray(vals)), np.asarray(vals), np.inf)
    dwell = np.asarray(dwell_from_logits(z[b], total, m)) if free_dwell else np.full(n_positions, total / n_positions)
    angles_deg = np.mod(np.rad2deg(np.asarray(ang[b])), 360.0)
    f = np.asarray(static_fisher(model, table, jnp.deg2rad(jnp.asarray(angles_deg)), jnp.asarray(dwell), noise, dt_s))
    res = DesignResult(
        angles_deg,
        dwell,
        float(vals[b]),
        crit,
        model,
        table,
        noise,
        dt_s,
        np.asarray(hist[b]),
        float(gn[b]),
        vals,
        f,
        timing,
    )
    if not res.converged:
        warnings.warn(f"design did not converge: {res.convergence_note}", ConvergenceWarning, stacklevel=2)
    return res


def design_plan(res: DesignResult, name: str = "designed", gap_s: float = 30.0) -> plans.Plan:
    """The designed positions as a :class:`gyrojax.data.plans.Plan` (one run; dwell in s rounded to whole samples,
    ``gap_s`` in s between positions)."""
    t = res.table
    segs = []
    for i, (a, d) in enumerate(zip(res.angles_deg, res.dwell_s)):
        n = max(1, int(round(d / res.dt_s)))
        segs.append(plans.Segment(tuple(round(float(x), 6) for x in a), n * res.dt_s, res.dt_s, label=i))
    run = plans.Run(f"{len(segs)}pos-designed", tuple(zip(t.axis_names, t.axes_enu)), t.mount, tuple(segs), gap_s=gap_s)
    return plans.Plan(
        name,
        (run,),
        t.latitude_deg,
        description=f"{len(segs)}-position {res.criterion.label()}-optimal static plan for "
        f"{', '.join(res.model.terms)} (gyrojax.design)",
        reference="Fisher information of the measurement model; Hu ch. 4 (least squares)",
    )


def sweep_positions(terms, counts=(6, 8, 12, 16, 24), **kw) -> dict:
    """Design for each position count (discrete N by sweep): {N: DesignResult}."""
    return {n: design(terms, n, **kw) for n in counts}
