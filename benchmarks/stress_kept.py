"""Stress of gyrojax's kept executables (gyrojax.runtime.kept) in one long process: many varied jitted functions
(linear algebra, while loops, scans, vmaps) at many shapes, each called through a fresh ``Kept`` (so that a shape met
before is read from its file and deserialised, as after an LRU eviction or in a fresh process), with plain jitted
functions compiled in between, as a long test session or notebook does. The process must end without a crash.

    python -X faulthandler -m benchmarks.stress_kept --rounds 3000 [--persistent] [--folder DIR]

``--persistent`` turns JAX's persistent compilation cache on (as the test suite and the command line do); without
``--folder`` a fresh temporary folder is used (cold), with it the files of an earlier run are read (warm).

The machine code of every executable held takes entries of the process' memory map (Linux: ``vm.max_map_count``,
65530 by default); when none are left, XLA's compile dies (``LLVM compilation error: Cannot allocate memory``, then a
segmentation fault: how a long test session ended). ``--keep-alive --fill-maps 3000`` reaches that in a few hundred
rounds (the map filled with pages of alternating protection, 3000 entries left); ``--release`` then drops the
executables (``jax.clear_caches()`` and :func:`gyrojax.runtime.kept.release`) whenever half of the entries left at
the start are used, as the test session does, and the run ends.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import mmap
import os
import random
import resource
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

import gyrojax  # noqa: F401  (x64)
from gyrojax.runtime import kept
from gyrojax.runtime.cache import use_persistent_cache


def _chol_solve(a, b):
    m = a @ a.T + a.shape[0] * jnp.eye(a.shape[0])
    c = jnp.linalg.cholesky(m)
    return jax.scipy.linalg.cho_solve((c, True), b)


def _eigh(a, b):
    w, v = jnp.linalg.eigh(a + a.T)
    return v @ (w[:, None] * b)


def _svd(a, b):
    u, s, vt = jnp.linalg.svd(a, full_matrices=False)
    return u @ (s[:, None] * (vt @ b))


def _qr_lstsq(a, b):
    q, r = jnp.linalg.qr(a)
    return jax.scipy.linalg.solve_triangular(r + jnp.eye(a.shape[0]), q.T @ b)


def _lu_solve(a, b):
    return jnp.linalg.solve(a + a.shape[0] * jnp.eye(a.shape[0]), b)


def _newton_while(a, b):
    def cond(s):
        return (s[1] < 50) & (jnp.max(jnp.abs(s[0] ** 2 - 2.0 - b)) > 1e-12)

    def body(s):
        x, k = s
        return x - (x**2 - 2.0 - b) / (2.0 * x), k + 1

    return lax.while_loop(cond, body, (jnp.ones_like(b) + jnp.abs(b), 0))[0] + jnp.sum(a)


def _scan_vmap(a, b):
    def step(c, row):
        c = jnp.tanh(c + row @ b)
        return c, c

    def one(row):
        return lax.scan(step, jnp.zeros(b.shape[1]), jnp.broadcast_to(row, (5,) + row.shape))[1]

    return jax.vmap(one)(a)


def _grad_lbfgs_like(a, b):
    def loss(x):
        return jnp.sum((a @ x - b) ** 2) + jnp.sum(jnp.log1p(x**2))

    h = jax.hessian(lambda v: jnp.sum(jnp.log1p((a @ v) ** 2)))(b[:, 0])
    return jax.grad(loss)(b) + jnp.sum(h)


FAMILIES = (_chol_solve, _eigh, _svd, _qr_lstsq, _lu_solve, _newton_while, _scan_vmap, _grad_lbfgs_like)


def map_entries() -> int:
    """Entries of this process' memory map."""
    with open("/proc/self/maps") as f:
        return sum(1 for _ in f)


_FILLED = []


def fill_maps(n: int) -> None:
    """Take ``n`` more memory-map entries: one anonymous reservation of ``n`` pages, every other page made
    read-only (neighbouring pages of equal protection would merge into one entry)."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.mmap.restype = ctypes.c_void_p
    libc.mmap.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_long]
    libc.mprotect.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    page = mmap.PAGESIZE
    base = libc.mmap(None, n * page, mmap.PROT_READ | mmap.PROT_WRITE, mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS, -1, 0)
    if base in (None, ctypes.c_void_p(-1).value):
        raise OSError(ctypes.get_errno(), "mmap failed")
    for i in range(0, n, 2):
        libc.mprotect(base + i * page, page, mmap.PROT_READ)
    _FILLED.append(base)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2000)
    ap.add_argument("--shapes", type=int, default=24, help="matrix sizes 2 .. 2 + SHAPES")
    ap.add_argument("--persistent", action="store_true", help="JAX's persistent compilation cache on")
    ap.add_argument("--folder", help="gyrojax's cache folder (default: a fresh temporary one)")
    ap.add_argument("--keep-alive", action="store_true", help="hold every Kept (and its executables) to the end")
    ap.add_argument("--plain-every", type=int, default=1, help="a plain jitted function compiled every N rounds")
    ap.add_argument("--threads", type=int, default=1, help="rounds run on this many threads at once")
    ap.add_argument("--fill-maps", type=int, help="fill the memory map until this many entries are left")
    ap.add_argument("--release", action="store_true", help="drop the executables when half the entries left are used")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    folder = a.folder or tempfile.mkdtemp(prefix="stress-kept-")
    os.environ["GYROJAX_CACHE_DIR"] = os.path.join(folder, "jax")
    if a.persistent:
        use_persistent_cache()
    limit = int(open("/proc/sys/vm/max_map_count").read())
    np.asarray(jax.jit(lambda v: v + 1.0)(np.ones(2)))  # the backend up before the map is measured
    if a.fill_maps is not None:
        fill_maps(limit - map_entries() - a.fill_maps)
    free_at_start = limit - map_entries()
    lock = threading.Lock()
    rng = random.Random(a.seed)
    plan = [(rng.choice(FAMILIES), 2 + rng.randrange(a.shapes)) for _ in range(a.rounds)]
    alive, t0 = [], time.perf_counter()

    def one(i):
        fn, n = plan[i]
        x = np.random.default_rng(i).standard_normal((n, n))
        y = np.random.default_rng(i + 1).standard_normal((n, 2))
        k = kept.Kept(f"stress{fn.__name__}", jax.jit(fn))  # a fresh object: a shape met before is read from file
        out = np.asarray(k(x, y))
        want = np.asarray(jax.jit(fn)(x, y)) if i % 50 == 0 else out  # now and then against a plain compile
        if not np.allclose(out, want, rtol=1e-9, atol=1e-9, equal_nan=True):
            raise AssertionError(f"round {i}: {fn.__name__} at {n} differs from the plain compile")
        if a.keep_alive:
            alive.append(k)
        del k
        if a.release and limit - map_entries() < free_at_start // 2:
            with lock:
                jax.clear_caches()
                print(f"round {i}: released {kept.release()} kept executables", flush=True)
        if a.plain_every and i % a.plain_every == 0:  # a function nobody compiled before: XLA compiles it here
            c = float(i)
            np.asarray(jax.jit(lambda v, c=c: jnp.sin(v * c) @ v.T + c)(x))

    with ThreadPoolExecutor(a.threads) as pool:
        for start in range(0, a.rounds, 100):
            list(pool.map(one, range(start, min(start + 100, a.rounds))))
            gc.collect()
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            used = map_entries()
            print(f"round {start}: {time.perf_counter() - t0:.0f} s, max RSS {rss:.0f} MB, map {used}", flush=True)
    print(f"done: {a.rounds} rounds in {time.perf_counter() - t0:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
