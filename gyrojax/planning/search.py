"""The gradient search every design runs: Adam (optax) over a differentiable loss, scanned on the device so that a
``vmap`` over starts compiles once, and the judgement of whether it settled (never silent: a search cut short says
so)."""

from __future__ import annotations

import jax
import numpy as np
import optax

CONVERGED_WINDOW = 10
"""Iterations over which a settled search's loss may fall by at most :data:`CONVERGED_RTOL` (relative)."""
CONVERGED_RTOL = 1e-6


def adam_scan(value_and_grad, p0, steps: int, learning_rate: float, *args):
    """``steps`` Adam iterations from ``p0`` on ``value_and_grad(p, *args) -> (loss, grad)``; returns (p, the loss
    at each iteration). Pure (jit and vmap it over starts); the loss is dimensionless, as the criteria's are."""
    opt = optax.adam(learning_rate)

    def step(carry, _):
        p, state = carry
        val, g = value_and_grad(p, *args)
        upd, state = opt.update(g, state, p)
        return (optax.apply_updates(p, upd), state), val

    (p, _), history = jax.lax.scan(step, (p0, opt.init(p0)), None, length=steps)
    return p, history


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
