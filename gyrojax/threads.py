"""BLAS threads for gyrojax's linear algebra: one by default (``GYROJAX_BLAS_THREADS=N`` for N).

The matrices of a fit and a diagnosis are tall and narrow (samples × a few dozen regressors): QR, projections and
least squares on them gain little from BLAS threads, while OpenBLAS threads that spin between calls take the cores
JAX's compiled likelihood runs on. Measured on 2 cores (the demo campaign's warm fit + diagnose,
``benchmarks/bench_mainloop.py``): 3.2–4.0 s CPU with numpy's default two threads, 2.7–3.1 s with one, the wall
time 0–15 % shorter. The command line sets this for its whole process (:func:`single_threaded_blas`); the library's
entry points (:func:`narrow_blas`) set it for the call and restore the caller's setting after it, so a notebook's
own numpy keeps its threads.
"""

from __future__ import annotations

import functools
import os
import sys
import threading

ENV = "GYROJAX_BLAS_THREADS"

_state = threading.local()
_controller = None


def blas_threads() -> int:
    """The BLAS threads gyrojax runs with: ``GYROJAX_BLAS_THREADS`` (a positive integer), else 1."""
    raw = os.environ.get(ENV, "").strip()
    if not raw:
        return 1
    try:
        n = int(raw)
    except ValueError:
        raise ValueError(f"{ENV}={raw!r}: not a number of threads (a positive integer)") from None
    if n < 1:
        raise ValueError(f"{ENV}={raw!r}: not a number of threads (a positive integer)")
    return n


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
    """The threadpoolctl controller of the BLAS libraries loaded now (found once: 2 ms; each limit then 0.05 ms)."""
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
