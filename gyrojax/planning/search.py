"""The gradient search every design runs: Adam (optax), then a few L-BFGS steps, over a differentiable loss, scanned
on the device so that a ``vmap`` over starts compiles once; the best start; and the judgement of whether it settled
(never silent: a search cut short says so)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optax

from gyrojax.errors import ModelError

CONVERGED_WINDOW = 10
"""Iterations over which a settled search's loss may fall by at most :data:`CONVERGED_RTOL` (relative)."""
CONVERGED_RTOL = 1e-6


def adam_scan(value_and_grad, p0, steps: int, learning_rate, *args, keep_best: bool = False, schedule=None):
    """``steps`` Adam iterations from ``p0`` on ``value_and_grad(p, *args) -> (loss, grad)``; returns (p, the loss
    at each iteration). With ``schedule`` (an array of ``steps`` values: an annealed temperature), iteration i
    calls ``value_and_grad(p, schedule[i], *args)``. With ``keep_best``, p is the iterate of least loss (Adam's loss
    need not fall at every step) and a third value is that loss, with no evaluation beyond the iterations'. Pure
    (jit and vmap it over starts); the loss is dimensionless, as the criteria's are."""
    opt = optax.adam(learning_rate)

    def step(carry, x):
        p, state, best = carry
        val, g = value_and_grad(p, *args) if schedule is None else value_and_grad(p, x, *args)
        upd, state = opt.update(g, state, p)
        if keep_best:
            better = val < best[1]  # a NaN loss is never the best
            best = (
                jax.tree_util.tree_map(lambda a, b: jnp.where(better, a, b), p, best[0]),
                jnp.where(better, val, best[1]),
            )
        return (optax.apply_updates(p, upd), state, best), val

    best0 = (p0, jnp.asarray(jnp.inf)) if keep_best else None
    (p, _, best), history = jax.lax.scan(step, (p0, opt.init(p0), best0), schedule, length=steps)
    return (best[0], history, best[1]) if keep_best else (p, history)


def _lbfgs(loss):
    """(optax L-BFGS with its zoom line search, one iteration (p, state) ↦ (p, state, loss at p)) on ``loss``."""
    opt = optax.lbfgs()
    vg_state = optax.value_and_grad_from_state(loss)

    def iterate(p, state):
        val, g = vg_state(p, state=state)
        upd, state = opt.update(g, state, p, value=val, grad=g, value_fn=loss)
        return optax.apply_updates(p, upd), state, val

    return opt, iterate


def lbfgs_scan(loss, p0, steps: int):
    """``steps`` L-BFGS iterations (optax, zoom line search) from ``p0`` on ``loss(p)``; returns (p, the loss at
    each iteration). Pure."""
    opt, iterate = _lbfgs(loss)

    def step(carry, _):
        p, state, val = iterate(*carry)
        return (p, state), val

    (p, _), history = jax.lax.scan(step, (p0, opt.init(p0)), None, length=steps)
    return p, history


def lbfgs_while(loss, p0, max_steps: int, rtol: float = CONVERGED_RTOL * 1e-3):
    """L-BFGS iterations (optax, zoom line search) from ``p0`` on ``loss(p)`` until the loss falls by at most
    ``rtol`` (relative) over :data:`CONVERGED_WINDOW` iterations, or ``max_steps``; returns (p, the loss at each
    iteration, NaN after the last). A ``jax.lax.while_loop``: under ``vmap`` it runs until every lane has stopped,
    each lane frozen once its own test holds. Pure."""
    opt, iterate = _lbfgs(loss)

    def settled(hist, i):
        back = jnp.where(i > CONVERGED_WINDOW, hist[jnp.maximum(i - CONVERGED_WINDOW - 1, 0)], jnp.inf)
        return back - hist[jnp.maximum(i - 1, 0)] <= rtol * jnp.maximum(1.0, jnp.abs(hist[jnp.maximum(i - 1, 0)]))

    def go(carry):
        _, _, hist, i = carry
        return (i < max_steps) & ~settled(hist, i) & jnp.isfinite(hist[jnp.maximum(i - 1, 0)])

    def step(carry):
        p, state, hist, i = carry
        p, state, val = iterate(p, state)
        return p, state, hist.at[i].set(val), i + 1

    hist0 = jnp.full(max_steps, jnp.nan).at[0].set(loss(p0))
    p, _, hist, _ = jax.lax.while_loop(go, step, (p0, opt.init(p0), hist0, 0))
    return p, hist


def minimise(loss, p0, adam_steps: int, lbfgs_steps: int, learning_rate, grad_norm: bool = True):
    """One start of the search: :func:`adam_scan` then :func:`lbfgs_scan`, whose result is kept only where its loss
    is finite and no worse; the loss and ``learning_rate`` are dimensionless. Returns (p, the loss at every
    iteration, the final loss, |∇loss| there). Without
    ``grad_norm`` and L-BFGS steps, p is Adam's iterate of least loss and the norm NaN: the search then evaluates
    the loss at its iterations only. Pure: jit it, and ``vmap`` it over starts."""
    vg = jax.value_and_grad(loss)
    if not grad_norm and not lbfgs_steps:
        p, history, val = adam_scan(vg, p0, adam_steps, learning_rate, keep_best=True)
        return p, history, val, jnp.nan
    p, history = adam_scan(vg, p0, adam_steps, learning_rate)
    if lbfgs_steps:
        p2, h2 = lbfgs_scan(loss, p, lbfgs_steps)
        l1, l2 = loss(p), loss(p2)
        good = jnp.isfinite(l2) & (l2 <= l1)
        p = jax.tree_util.tree_map(lambda a, b: jnp.where(good, b, a), p, p2)
        history = jnp.concatenate([history, h2])
    if not grad_norm:
        return p, history, loss(p), jnp.nan
    val, grad = vg(p)
    return p, history, val, jnp.sqrt(sum(jnp.sum(g * g) for g in jax.tree_util.tree_leaves(grad)))


def best_start(losses, what: str) -> int:
    """Index of the start of least final loss; :class:`~gyrojax.errors.ModelError` naming ``what`` when every one
    is non-finite (a singular information or a search that diverged)."""
    v = np.where(np.isfinite(np.asarray(losses)), np.asarray(losses), np.inf)
    if not np.isfinite(v).any():
        raise ModelError(
            f"{what}: every one of the {v.size} starts ended at a non-finite loss (a singular Fisher information or a "
            "search that diverged); no plan is written. Try more starts, a smaller learning rate or fewer terms"
        )
    return int(np.argmin(v))


def convergence_note(history, final_loss: float, remedy: str) -> str:
    """Why a search is not taken as converged ("" when it is): a non-finite loss, too few iterations to judge, or a
    loss (dimensionless) that still fell by more than :data:`CONVERGED_RTOL` (relative) over the last
    :data:`CONVERGED_WINDOW` iterations of ``history``; ``remedy`` ends the note (e.g. "raise --adam-steps")."""
    h = np.asarray(history, dtype=float).ravel()
    if not np.isfinite(final_loss) or h.size == 0 or not np.isfinite(h[-1]):
        return "the best start's loss is not finite"
    if h.size <= CONVERGED_WINDOW:
        return f"only {h.size} iterations (fewer than {CONVERGED_WINDOW + 1} to judge convergence)"
    fall = h[-CONVERGED_WINDOW - 1] - h[-1]
    if fall > CONVERGED_RTOL * max(1.0, abs(h[-1])):
        return (
            f"the loss still fell by {fall:.3g} over the last {CONVERGED_WINDOW} iterations "
            f"(more than {CONVERGED_RTOL:g} relative): {remedy}"
        )
    return ""
