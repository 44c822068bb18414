"""The least-squares core (identify, bigfit and the Monte Carlo share it) against numpy/scipy references."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from gyrojax.inference import lstsq as ls


def _problem(seed, m=200, p=5):
    rng = np.random.default_rng(seed)
    j = rng.normal(size=(m, p)) * 10.0 ** rng.uniform(-4, 4, p)  # columns in very different units
    return j, j @ rng.normal(size=p) + rng.normal(size=m)


@pytest.mark.parametrize("method", ls.METHODS)
def test_every_method_and_both_array_libraries_give_the_textbook_solution(method):
    j, r = _problem(1)
    x_ref = scipy.linalg.lstsq(j, r)[0]
    inv_ref = np.linalg.inv(j.T @ j)
    x, inv = ls.lstsq(j, r, method)
    assert isinstance(x, np.ndarray)  # numpy in, numpy out (no compilation)
    np.testing.assert_allclose(x, x_ref, rtol=1e-9)
    np.testing.assert_allclose(inv, inv_ref, rtol=1e-8)
    xj, invj = jax.jit(lambda a, b: ls.lstsq(a, b, method))(jnp.asarray(j), jnp.asarray(r))
    np.testing.assert_allclose(np.asarray(xj), x_ref, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(invj), inv_ref, rtol=1e-8)
    for nm in ls.NORMAL_METHODS:
        xn, invn = ls.lstsq_normal(j.T @ j, j.T @ r, nm)
        np.testing.assert_allclose(xn, x_ref, rtol=1e-7)
        np.testing.assert_allclose(invn, inv_ref, rtol=1e-7)


def test_vmap_over_problems():
    probs = [_problem(s, m=60, p=3) for s in range(4)]
    js, rs = jnp.asarray(np.stack([a for a, _ in probs])), jnp.asarray(np.stack([b for _, b in probs]))
    xs, _ = jax.vmap(lambda a, b: ls.lstsq(a, b, "cholesky"))(js, rs)
    for (a, b), x in zip(probs, np.asarray(xs)):
        np.testing.assert_allclose(x, np.linalg.lstsq(a, b, rcond=None)[0], rtol=1e-9)


@pytest.mark.parametrize("normal", [False, True])
def test_rank_cut_gives_the_minimum_norm_fit_and_nan_for_the_unseen(normal):
    """Two identical columns: the plan sees only their sum; both get NaN variance, the third a finite one, and the
    step is numpy's minimum-norm pseudo-inverse solution."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(100, 2))
    j = np.column_stack([a[:, 0], a[:, 0], a[:, 1]])
    r = rng.normal(size=100)
    if normal:
        x, inv = ls.lstsq_normal(j.T @ j, j.T @ r, "eigh", 1e-7)
    else:
        x, inv = ls.lstsq(j, r, "svd", 1e-7)
    np.testing.assert_allclose(x, np.linalg.pinv(j) @ r, rtol=1e-7)
    assert np.isnan(inv[0, 0]) and np.isnan(inv[1, 2]) and np.isfinite(inv[2, 2])
    with pytest.raises(ValueError, match="method"):
        ls.lstsq(j, r, "lu")
