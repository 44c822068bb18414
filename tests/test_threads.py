"""gyrojax.threads: the library's entry points run BLAS on the threads GYROJAX_BLAS_THREADS names (1 by default)
for the call, and give the caller's setting back after it."""

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from gyrojax import threads
from gyrojax.inference import diagnose, identify


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
