"""The LAPACK kernels of JAX's CPU backend made ready before a kept executable that calls them is loaded.

jaxlib resolves the LAPACK routines behind its CPU kernels (``lapack_dpotrf_ffi`` and the like) when a linear-algebra
operation is *lowered*, not when an executable is loaded: an executable read from disk by a process that has lowered
no such operation calls routines that were never resolved, and the process dies. :func:`prepare` lowers (never runs
nor compiles) a 2×2 instance of the public operation behind each kernel an executable names, once per process.
:data:`PRIMERS` names the kernels it can prepare; an executable that names any other custom call is not kept
(:mod:`gyrojax.runtime.kept` compiles it in each process).
"""

from __future__ import annotations

import re
import threading
from functools import partial

import jax
import jax.numpy as jnp
from jax.lax import linalg

TARGET = re.compile(r'custom_call_target="([^"]+)"')
"""A custom call in an executable's HLO text."""


# LAPACK's name of each routine for real and complex matrices, and the public operation that lowers to it
_ROUTINES = (
    ("potrf", "potrf", linalg.cholesky),
    ("getrf", "getrf", linalg.lu),
    ("trsm", "trsm", lambda a: linalg.triangular_solve(a, a, left_side=True, lower=True)),
    ("geqrf", "geqrf", partial(linalg.qr, full_matrices=False)),
    ("orgqr", "ungqr", partial(linalg.qr, full_matrices=False)),
    ("ormqr", "unmqr", lambda a: linalg.ormqr(a, jnp.ones(2, a.dtype), a)),
    ("geqp3", "geqp3", partial(linalg.qr, pivoting=True, full_matrices=False)),
    ("syevd", "heevd", linalg.eigh),
    ("gesdd", "gesdd", partial(linalg.svd, full_matrices=False, algorithm=linalg.SvdAlgorithm.DIVIDE_AND_CONQUER)),
    ("gesvd", "gesvd", partial(linalg.svd, full_matrices=False, algorithm=linalg.SvdAlgorithm.QR)),
    ("geev", "geev", partial(linalg.eig, compute_left_eigenvectors=False)),
    ("gees", "gees", linalg.schur),
    ("gehrd", "gehrd", linalg.hessenberg),
    ("sytrd", "hetrd", linalg.tridiagonal),
)
_TYPES = (("s", "float32", False), ("d", "float64", False), ("c", "complex64", True), ("z", "complex128", True))

PRIMERS = {
    f"lapack_{prefix}{complex_name if is_complex else real_name}_ffi": (op, dtype)
    for prefix, dtype, is_complex in _TYPES
    for real_name, complex_name, op in _ROUTINES
}
"""Each LAPACK kernel :func:`prepare` can make ready: the operation that lowers to it and the dtype it is lowered
at."""

_READY: set = set()
_LOCK = threading.Lock()


def targets(hlo_text: str) -> set[str]:
    """The custom calls an executable's HLO text (``Compiled.as_text()``) names."""
    return set(TARGET.findall(hlo_text))


def preparable(names) -> bool:
    """Whether every custom call in ``names`` is a LAPACK kernel :func:`prepare` can make ready."""
    return set(names) <= PRIMERS.keys()


def prepare(names) -> None:
    """Make the LAPACK kernels ``names`` ready in this process: lower each one's operation once (a KeyError names a
    kernel outside :data:`PRIMERS`)."""
    with _LOCK:
        for name in sorted(set(names) - _READY):
            op, dtype = PRIMERS[name]
            jax.jit(op).lower(jax.ShapeDtypeStruct((2, 2), dtype))
            _READY.add(name)
