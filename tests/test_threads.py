"""gyrojax.runtime.threads: the library's entry points run BLAS on the threads GYROJAX_BLAS_THREADS names (1 by default)
for the call, and give the caller's setting back after it."""

import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from gyrojax.inference import diagnose, identify
from gyrojax.runtime import threads


def _blas_threads() -> set:
    return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}


@pytest.fixture
def two_threads():
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can limit")
    with threadpool_limits(2, user_api="blas"):
        if _blas_threads() != {2}:
            pytest.skip("this BLAS cannot be set to two threads")
        yield


def test_call_runs_on_one_thread_and_restores(two_threads, monkeypatch):
    monkeypatch.delenv(threads.ENV, raising=False)
    seen = []

    @threads.narrow_blas
    def inner():
        seen.append(_blas_threads())
        return np.linalg.qr(np.ones((50, 3)))[1]

    @threads.narrow_blas
    def outer():
        seen.append(_blas_threads())
        return inner()

    outer()
    assert seen == [{1}, {1}]
    assert _blas_threads() == {2}  # the caller's setting is back


def test_restored_after_an_error(two_threads):
    @threads.narrow_blas
    def fails():
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        fails()
    assert _blas_threads() == {2}
    assert getattr(threads._state, "depth", 0) == 0


def test_environment_names_the_threads(two_threads, monkeypatch):
    monkeypatch.setenv(threads.ENV, "2")
    assert threads.blas_threads() == 2
    seen = []
    threads.narrow_blas(lambda: seen.append(_blas_threads()))()
    assert seen == [{2}]
    for bad in ("0", "two", "-1"):
        monkeypatch.setenv(threads.ENV, bad)
        with pytest.raises(ValueError, match="GYROJAX_BLAS_THREADS"):
            threads.blas_threads()


def test_entry_points_are_wrapped():
    for f in (identify.fit, diagnose.diagnose, diagnose.add_and_refit):
        assert f.__wrapped__.__name__ == f.__name__  # functools.wraps: docstring and signature are the function's
        assert f.__doc__ == f.__wrapped__.__doc__


def test_parallel_map_keeps_order_and_raises(monkeypatch):
    monkeypatch.setenv(threads.WORKERS_ENV, "2")
    assert threads.parallel_map(lambda x: x * x, range(7)) == [x * x for x in range(7)]

    def fails(x):
        if x == 3:
            raise KeyError(x)
        return x

    with pytest.raises(KeyError):
        threads.parallel_map(fails, range(6))
    assert threads.parallel_map(fails, []) == []


def test_nested_calls_run_in_the_worker(monkeypatch):
    """A parallel_map inside a worker runs there, one item after the other: two workers each waiting for an inner
    item that no free worker could take would wait for ever."""
    monkeypatch.setenv(threads.WORKERS_ENV, "2")

    def outer(i):
        me = threading.current_thread()
        inner = threads.parallel_map(lambda k: (threading.current_thread() is me, i * 10 + k), range(3))
        return inner

    out = threads.parallel_map(outer, range(4))
    assert [[v for _, v in row] for row in out] == [[i * 10 + k for k in range(3)] for i in range(4)]
    assert all(same for row in out for same, _ in row)


def test_in_background_runs_on_a_worker_and_inside_one_runs_there(monkeypatch):
    """``in_background`` runs its call on a worker of the pool (its Future gives the value, or raises the error);
    called from every worker at once it runs each call in its own worker, so that no worker waits for a free one."""
    monkeypatch.setenv(threads.WORKERS_ENV, "2")
    main = threading.current_thread()
    elsewhere, total = threads.in_background(
        lambda a, b: (threading.current_thread() is not main, a + b), 2, 3
    ).result()
    assert elsewhere and total == 5
    with pytest.raises(KeyError):
        threads.in_background(lambda: {}[1]).result()

    def outer(i):
        me = threading.current_thread()
        return threads.in_background(lambda: (threading.current_thread() is me, i)).result(timeout=30)

    assert threads.parallel_map(outer, range(4)) == [(True, i) for i in range(4)]


def test_workers_from_the_environment(monkeypatch):
    monkeypatch.setenv(threads.WORKERS_ENV, "3")
    assert threads.workers() == 3
    monkeypatch.delenv(threads.WORKERS_ENV)
    assert 1 <= threads.workers() <= threads.MAX_WORKERS
    monkeypatch.setenv(threads.WORKERS_ENV, "none")
    with pytest.raises(ValueError, match="GYROJAX_WORKERS"):
        threads.workers()


def test_noise_fits_on_workers_are_the_serial_ones(monkeypatch):
    """The REML fits of separate series, side by side on two workers, are bit for bit the fits one after the other
    (each is the same computation; only when it runs changes)."""
    from gyrojax.noise import reml

    rng = np.random.default_rng(5)
    series = []
    for k in range(3):
        n = 600 + 50 * k
        t = np.arange(n) * 1.0
        g = np.zeros(n)
        for i in range(1, n):
            g[i] = 0.97 * g[i - 1] + 0.3 * rng.normal()
        r = g + rng.normal(size=n)
        series.append(reml.prepare(r, np.ones((n, 1)), np.zeros(n, int), t, 4.0))
    start = (20.0, 1.0, 1.0)
    monkeypatch.setenv(threads.WORKERS_ENV, "1")
    serial = [reml.fit(s, start) for s in series]
    monkeypatch.setenv(threads.WORKERS_ENV, "2")
    side = threads.parallel_map(lambda s: reml.fit(s, start), series)
    for a, b in zip(serial, side):
        assert np.array_equal(a.x, b.x) and a.value == b.value and a.steps == b.steps and a.status == b.status
