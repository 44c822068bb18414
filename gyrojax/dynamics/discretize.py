"""Exact zero-order-hold discretisation of continuous LTI systems, in JAX.

For ẋ = A x + B u, y = C x + D u with u held constant over each step of length Δt,

    x[k+1] = A_d x[k] + B_d u[k],   A_d = e^{AΔt},   B_d = ∫₀^Δt e^{As} ds · B,

and C, D are unchanged. Both blocks come from one matrix exponential of the augmented matrix (Van Loan, 1978):

    exp( [[A, B], [0, 0]] · Δt ) = [[A_d, B_d], [0, I]].

Everything is a pure function of arrays (``jit``/``vmap``/``grad``-safe: ``jax.scipy.linalg.expm`` is
differentiable), float64 when x64 is enabled (the package enables it on import).
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.scipy.linalg import expm

__all__ = ["zoh", "zoh_ab"]


def zoh_ab(a, b, dt):
    """(A_d, B_d) of the zero-order-hold discretisation of (A, B) at step ``dt`` (s, may be traced).

    a: (n, n), b: (n, m). Uses expm of the (n+m)×(n+m) augmented matrix [[A, B], [0, 0]]·dt. The state after
    holding u for ``dt`` from x is A_d x + B_d u (also for sub-step pulse timing).
    """
    a = jnp.asarray(a)
    b = jnp.asarray(b)
    n, m = b.shape
    top = jnp.concatenate([a, b], axis=1)
    aug = jnp.concatenate([top, jnp.zeros((m, n + m), dtype=top.dtype)], axis=0)
    e = expm(aug * dt)
    return e[:n, :n], e[:n, n:]


def zoh(a, b, c, d, dt):
    """Zero-order-hold discretisation of the continuous system (A, B, C, D) at step ``dt`` (s).

    Returns (A_d, B_d, C, D); matches ``scipy.signal.cont2discrete((A, B, C, D), dt, method="zoh")``.
    """
    ad, bd = zoh_ab(a, b, dt)
    return ad, bd, jnp.asarray(c), jnp.asarray(d)
