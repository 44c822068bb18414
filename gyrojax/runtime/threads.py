"""The threads gyrojax runs on: BLAS on one thread by default (``GYROJAX_BLAS_THREADS=N`` for N), and independent
compiled computations (the noise fits of separate records, the points of a likelihood grid) on a few worker threads
(:func:`parallel_map`, ``GYROJAX_WORKERS=N`` for N).

The matrices of a fit and a diagnosis are tall and narrow (samples × a few dozen regressors): QR, projections and
least squares on them gain little from BLAS threads, while OpenBLAS threads that spin between calls take the cores
JAX's compiled likelihood runs on (``benchmarks/bench_mainloop.py``). The command line sets this for its whole process
(:func:`single_threaded_blas`); the library's entry points (:func:`narrow_blas`) set it for the call and restore
the caller's setting after it, so a notebook's own numpy keeps its threads.

One compiled evaluation of the REML likelihood keeps about one core busy, and JAX releases the GIL while it runs, so
independent evaluations dispatched from two threads run side by side, with bit-identical results (each computation is
the same; only when it runs changes).
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from concurrent.futures import Future, ThreadPoolExecutor

ENV = "GYROJAX_BLAS_THREADS"
WORKERS_ENV = "GYROJAX_WORKERS"
POOL_PREFIX = "gyrojax"
"""Name prefix of the worker pool's threads (:func:`parallel_map`)."""
MAX_WORKERS = 4
"""Default cap of the worker threads: each keeps about one core busy, and the default is the cores, at most this."""

_state = threading.local()
_controller = None
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


def _count(var: str, default: int) -> int:
    raw = os.environ.get(var, "").strip()
    if not raw:
        return default
    try:
        n = int(raw)
    except ValueError:
        raise ValueError(f"{var}={raw!r}: not a number of threads (a positive integer)") from None
    if n < 1:
        raise ValueError(f"{var}={raw!r}: not a number of threads (a positive integer)")
    return n


def blas_threads() -> int:
    """The BLAS threads gyrojax runs with: ``GYROJAX_BLAS_THREADS`` (a positive integer), else 1."""
    return _count(ENV, 1)


def workers() -> int:
    """The worker threads of :func:`parallel_map`: ``GYROJAX_WORKERS`` (a positive integer), else the cores this
    process may use, at most :data:`MAX_WORKERS`."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return _count(WORKERS_ENV, max(1, min(cores, MAX_WORKERS)))


def parallel_map(func, items) -> list:
    """``[func(x) for x in items]``, the calls spread over :func:`workers` threads, results in order; the first
    exception raised is raised here. For independent compiled computations (JAX releases the GIL while they run).
    A call made inside a worker (a noise fit's grid inside a per-record fit) runs its items one after the other, so
    that workers never wait for each other."""
    items = list(items)
    n = min(workers(), len(items))
    if n <= 1 or getattr(_state, "worker", False):
        return [func(x) for x in items]
    return list(_executor().map(_in_worker(func), items))


def in_background(func, *args) -> Future:
    """``func(*args)`` started on a worker thread of :func:`parallel_map`'s pool; its Future
    (``.result()`` waits, and raises what ``func`` raised). For work the caller's next step does not need, such as
    loading the executable of the step after it. Called inside a worker it runs ``func`` there and then (a worker
    that waited for another could wait for ever once every worker waits)."""
    if getattr(_state, "worker", False):
        done: Future = Future()
        try:
            done.set_result(func(*args))
        except Exception as e:
            done.set_exception(e)
        return done
    return _executor().submit(_in_worker(lambda a: func(*a)), args)


def _in_worker(func):
    def run(x):
        _state.worker = True
        try:
            return func(x)
        finally:
            _state.worker = False

    return run


def _executor() -> ThreadPoolExecutor:
    """The process' worker pool (started at first use, resized when :func:`workers` changes)."""
    global _pool
    with _pool_lock:
        n = workers()
        if _pool is None or _pool._max_workers != n:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(max_workers=n, thread_name_prefix=POOL_PREFIX)
        return _pool


def stop_workers() -> None:
    """Stop the worker pool and wait for its threads to end (idle ones end at once); a later :func:`parallel_map`
    starts a new one."""
    global _pool
    with _pool_lock:
        pool, _pool = _pool, None
    if pool is not None:
        pool.shutdown(wait=True)


def single_threaded_blas() -> None:
    """:func:`blas_threads` BLAS threads for this whole process: the libraries loaded later (numpy's, scipy's) read
    the variables set here when they load, and those already loaded are limited now."""
    n = blas_threads()
    for var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
        os.environ[var] = str(n)
    if "numpy" in sys.modules:
        from threadpoolctl import threadpool_limits

        threadpool_limits(n, user_api="blas")


def _limits():
    """The threadpoolctl controller of the BLAS libraries loaded now (found once)."""
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller.limit(limits=blas_threads(), user_api="blas")


def narrow_blas(func):
    """Run ``func`` with :func:`blas_threads` BLAS threads and restore the caller's setting after it. Nested calls
    (a diagnosis calls fit) set it once."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        if getattr(_state, "depth", 0):
            return func(*args, **kwargs)
        _state.depth = 1
        try:
            with _limits():
                return func(*args, **kwargs)
        finally:
            _state.depth = 0

    return wrapper
