"""The designs' shared gradient search (gyrojax.planning.search): Adam scanned on the device, and its convergence
judgement, against closed forms."""

import jax
import jax.numpy as jnp
import numpy as np
import optax

from gyrojax.planning.search import CONVERGED_WINDOW, adam_scan, convergence_note


def test_adam_scan_is_optax_adam_step_by_step_and_reaches_the_quadratic_minimum():
    """On f(p) = |p − c|² the scan equals optax's Adam applied by hand, and ends at c (the closed-form minimum)."""
    c = jnp.array([1.5, -2.0])
    vg = jax.value_and_grad(lambda p: jnp.sum((p - c) ** 2))
    p, hist = jax.jit(lambda p0: adam_scan(vg, p0, 400, 0.05))(jnp.zeros(2))
    opt = optax.adam(0.05)
    q, state, ref = jnp.zeros(2), opt.init(jnp.zeros(2)), []
    for _ in range(400):
        val, g = vg(q)
        upd, state = opt.update(g, state, q)
        q = optax.apply_updates(q, upd)
        ref.append(float(val))
    np.testing.assert_allclose(np.asarray(hist), ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.asarray(p), np.asarray(q), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(p), np.asarray(c), atol=1e-3)


def test_convergence_note_says_why_a_search_is_not_settled():
    """Settled: a flat tail; not settled: a tail still falling (the fall is named), too short, or not finite."""
    flat = np.r_[np.linspace(10.0, 1.0, 50), np.ones(CONVERGED_WINDOW + 1)]
    assert convergence_note(flat, 1.0, "raise steps") == ""
    falling = np.linspace(10.0, 1.0, 60)
    note = convergence_note(falling, 1.0, "raise steps")
    assert "still fell by" in note and note.endswith("raise steps")
    assert "fewer than" in convergence_note(np.ones(CONVERGED_WINDOW), 1.0, "x")
    assert "not finite" in convergence_note(np.r_[1.0, np.nan], float("nan"), "x")
