"""The one least-squares search (:func:`gyrojax.optimize.least_squares`) against scipy's, and the memory of its last
points that spares the evaluations a search comes back to."""

import numpy as np
import scipy.optimize

from gyrojax.optimize import Status, least_squares, remember_last


def test_remember_last_evaluates_a_point_once_while_it_is_among_the_last_two():
    calls = []

    def f(x):
        calls.append(float(x[0]))
        return np.array([x[0] ** 2])

    g = remember_last(f)
    a, b, c = np.array([1.0]), np.array([2.0]), np.array([3.0])
    first = g(a)
    assert g(b)[0] == 4.0 and g(a) is first  # a is still among the last two: the same value, not evaluated again
    g(c)  # c evicts the oldest point (a)
    assert g(b)[0] == 4.0 and calls == [1.0, 2.0, 3.0]
    g(a)
    assert calls == [1.0, 2.0, 3.0, 1.0]


T = np.linspace(0.0, 4.0, 30)
Y = 2.0 * np.exp(-1.3 * T) + 0.3 * np.sin(3.0 * T) + 0.01 * np.random.default_rng(0).normal(size=30)


def _decay_system(calls):
    """A decay and a sine fitted to noisy samples: (r = y − f(x), J = ∂f/∂x); the residual at the answer is not 0,
    so the search ends on a trial step it rejects and asks for J at the answer after it."""

    def system(x):
        calls.append(x.tobytes())
        e = np.exp(-x[1] * T)
        return Y - (x[0] * e + x[2] * np.sin(3.0 * T)), np.column_stack([e, -x[0] * T * e, np.sin(3.0 * T)])

    return system


def test_least_squares_is_scipys_levenberg_marquardt_evaluating_each_point_once():
    calls = []
    sol = least_squares(_decay_system(calls), np.array([1.0, 1.0, 0.0]), 200)
    assert sol.status == Status.CONVERGED and sol.reason == ""
    assert len(calls) == len(set(calls))  # MINPACK's request for J at the answer is answered from memory
    ref_calls = []
    system = _decay_system(ref_calls)
    ref = scipy.optimize.least_squares(
        lambda x: -system(x)[0],
        np.array([1.0, 1.0, 0.0]),
        jac=lambda x: system(x)[1],
        method="lm",
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=200,
    )
    np.testing.assert_array_equal(sol.x, ref.x)  # the same search, point by point
    np.testing.assert_allclose(sol.x, [2.0, 1.3, 0.3], atol=0.03)
    assert len(set(ref_calls)) == len(calls) < len(ref_calls)
