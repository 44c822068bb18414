"""Which built-in test plan would separate effects that a campaign cannot tell apart: the plans in which their
regressors (with D_F) are not collinear (the ``separated_by`` of :class:`gyrojax.inference.diagnose.Candidate`)."""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.data.arrays import record_data
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, jacobian


@lru_cache(maxsize=4)
def _plan_jacobians(kind: str):
    """Regressors of every named effect in a few short built-in plans (computed once per process)."""
    from gyrojax.data import plans
    from gyrojax.simulation.simulator import plan_records

    options = {
        "multiposition-24": lambda: plans.multiposition(24, minutes=1.0, dt_s=6.0),
        "tumble (flipped, CW/CCW)": lambda: plans.tumble(revolutions=1.0, dt_s=60.0),
        "two-axis-tumble 5:1": lambda: plans.two_axis_tumble(5, 1, revolutions=1.0, dt_s=60.0),
        "rate-ladder": lambda: plans.rate_ladder(seconds=5.0, dt_s=1.0),
        "eight-position": lambda: plans.eight_position(minutes=1.0, dt_s=6.0),
    }
    model = Model(tuple(n for n in fx.names(kind) if n != "bias_temperature"), kind)
    runs, owner = [], []
    for name, build in options.items():
        for rec in plan_records(build()):
            runs.append(rec)
            owner.append(name)
    # one compile for all: every run padded to two table axes (a still dummy axis outermost) and one length
    n_max = max(r.n for r in runs)
    padded, lengths = [], []
    for rec in runs:
        d = record_data(rec)
        n = rec.n
        pad = lambda a: np.concatenate([a, np.repeat(a[-1:], n_max - n, axis=0)], axis=0)  # noqa: E731
        angles, rates, axes = np.asarray(d.angles), np.asarray(d.rates), np.asarray(d.axes)
        if axes.shape[0] == 1:
            angles = np.column_stack([np.zeros(n), angles])
            rates = np.column_stack([np.zeros(n), rates])
            axes = np.vstack([[0.0, 0.0, 1.0], axes])
        padded.append(
            dataclasses.replace(
                d,
                axes=axes,
                angles=pad(angles),
                rates=pad(rates),
                time_s=pad(np.asarray(d.time_s)),
                temperature=pad(np.asarray(d.temperature)),
                y=pad(np.asarray(d.y)),
                weight=pad(np.asarray(d.weight)),
                command=pad(np.asarray(d.command)),
                dt=np.zeros(n_max - 1),
                triad=np.asarray(d.triad),
                latitude=np.asarray(d.latitude),
                gravity=np.asarray(d.gravity),
                encoder_axis=1,
            )
        )
        lengths.append(n)
    batch = jax.tree_util.tree_map(lambda *xs: np.stack(xs), *padded)
    jac = jax.jit(jax.vmap(lambda d: jacobian(model, jnp.zeros(model.size), d)))(batch)
    out: dict = {}
    for name, n, j in zip(owner, lengths, np.asarray(jac)):
        out.setdefault(name, []).append(j[:n])
    return model, {k: np.concatenate(v, axis=0) for k, v in out.items()}


def separating_plans(kind: str, effects: tuple) -> list:
    """Built-in plans in which the regressors of ``effects`` (with D_F) are not collinear: the extra test to run."""
    if kind != fx.SDF:
        return []
    model, jacs = _plan_jacobians(kind)
    sl = model.slices()
    names = tuple(dict.fromkeys(("D_F",) + tuple(effects)))
    if any(n not in sl for n in names):
        return []
    cols = np.concatenate([np.arange(model.size)[sl[n]] for n in names])
    out = []
    for plan, j in jacs.items():
        sub = j[:, cols]
        norms = np.sqrt((sub * sub).sum(axis=0))
        if np.any(norms == 0):
            continue
        s = np.linalg.svd(sub / norms, compute_uv=False)
        if s[-1] > 1e-3 * s[0]:
            out.append(plan)
    return out
