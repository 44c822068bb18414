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

import jax
import jax.numpy as jnp
from jax.lax import linalg

TARGET = re.compile(r'custom_call_target="([^"]+)"')
"""A custom call in an executable's HLO text."""


def _lu(a):
    return linalg.lu(a)


def _solve_triangular(a):
    return linalg.triangular_solve(a, a, left_side=True, lower=True)


def _qr(a):
    return linalg.qr(a, full_matrices=False)


def _qr_pivoted(a):
    return linalg.qr(a, pivoting=True, full_matrices=False)


def _ormqr(a):
    return linalg.ormqr(a, jnp.ones(2, a.dtype), a)


def _svd_qr(a):
    return linalg.svd(a, full_matrices=False, algorithm=linalg.SvdAlgorithm.QR)


def _svd(a):
    return linalg.svd(a, full_matrices=False, algorithm=linalg.SvdAlgorithm.DIVIDE_AND_CONQUER)


def _eig(a):
    return linalg.eig(a, compute_left_eigenvectors=False)


def _schur(a):
    return linalg.schur(a)


def _hessenberg(a):
    return linalg.hessenberg(a)


def _tridiagonal(a):
    return linalg.tridiagonal(a)


# LAPACK's name of each routine for real and complex matrices, and the public operation that lowers to it
_ROUTINES = (
    ("potrf", "potrf", linalg.cholesky),
    ("getrf", "getrf", _lu),
    ("trsm", "trsm", _solve_triangular),
    ("geqrf", "geqrf", _qr),
    ("orgqr", "ungqr", _qr),
    ("ormqr", "unmqr", _ormqr),
    ("geqp3", "geqp3", _qr_pivoted),
    ("syevd", "heevd", linalg.eigh),
    ("gesdd", "gesdd", _svd),
    ("gesvd", "gesvd", _svd_qr),
    ("geev", "geev", _eig),
    ("gees", "gees", _schur),
    ("gehrd", "gehrd", _hessenberg),
    ("sytrd", "hetrd", _tridiagonal),
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
