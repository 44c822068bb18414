"""gyrojax's own compiled functions kept across processes: a function wrapped in :class:`Kept` is compiled once per
argument shape and its executable saved in gyrojax's cache folder (:func:`folder`), so that a fresh process (the command
line, a notebook's kernel) neither traces, lowers nor compiles it again. Nothing global is switched on for this: JAX's
persistent compilation cache stays the process owner's choice (the command line turns it on for itself,
:func:`gyrojax.runtime.cache.use_persistent_cache`).

A kept executable is keyed by the function's name, the argument tree, shapes and dtypes (a record's rows reach them in
chunks of a few sizes, :mod:`gyrojax.runtime.rows`, or padded to a few lengths, :func:`gyrojax.noise.reml.bucket_rows`),
the digest of the whole ``gyrojax`` source (its version included), the JAX and jaxlib versions, the backend, the host
CPU (:func:`host_cpu`: XLA compiles for the instruction set of the machine it runs on, so a cache shared over a network
or copied to an older machine must never run code for features that CPU lacks), the XLA flags (which may hold XLA to
another instruction set) and the process' index and count in a ``jax.distributed`` job (an executable runs on the
device it was compiled for: one kept by another process of the job would wait for that process' device for ever).
Any edit of the library makes new keys, so a stale executable is never called. The file holds its whole key, checked
on reading, and the LAPACK kernels it calls, made ready before it is loaded (:mod:`gyrojax.runtime.lapack`); a loaded
executable whose inputs are not the call's, a file that cannot be read, or one of another key is compiled again with a
warning and replaced, never called.

The file name carries the first :data:`DIGEST_CHARS` hex digits of the source digest, and the first use of the folder
in a process deletes the files of other library sources (:func:`prune`) but those of the :data:`KEEP_OTHER_SOURCES`
most recently written, so that the folder does not grow with every edit of the library (two checkouts sharing one
cache keep theirs). A function is compiled over the arguments' flat leaves (the tree, in the key, may hold types that
are not arrays, e.g. :class:`~gyrojax.physics.model.RecordData`). Nothing is kept when gyrojax's cache is off
(``GYROJAX_NO_CACHE=1``), when the arguments are tracers (the function inside another transformation), or when the
executable calls a kernel that cannot be made ready in a fresh process (it is compiled in each process then).

Like JAX's own persistent cache, the folder holds machine code that this process runs: it is the user's own cache,
never a place for files from elsewhere.
"""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import platform
import re
import secrets
import threading
import warnings
import weakref
from functools import lru_cache
from pathlib import Path

import jax
import numpy as np
from jax.experimental.serialize_executable import deserialize_and_load, serialize

from gyrojax.protocol import atomic_write_bytes
from gyrojax.runtime import lapack
from gyrojax.runtime.cache import cache_dir

SUFFIX = "-kept"
"""The folder of the kept executables is the compilation cache's folder with this suffix (a sibling, not inside
it)."""
DIGEST_CHARS = 16
"""Hex digits of the source digest in a kept file's name (``NAME-DIGEST-KEY.xla`` / ``.npz``)."""
KEEP_OTHER_SOURCES = 2
"""Other library sources whose kept files :func:`prune` leaves (the most recently written ones)."""
MAGIC = b"gyrojax kept executable 1\n"
"""The first bytes of a kept executable's file."""
_NAMED = re.compile(rf"^.+-(?P<digest>[0-9a-f]{{{DIGEST_CHARS}}})-[0-9a-f]{{32}}\.(bin|npz|xla)$")
_UNNAMED = re.compile(r"^.+-[0-9a-f]{32}\.(bin|npz)$")  # the names before the digest was in them
_PRUNED: set = set()
_UNWRITABLE: set = set()  # folders a kept file could not be written to (said once)
_LOCK = threading.RLock()  # an executable loaded (and the folder pruned) by one thread at a time
_ALL: weakref.WeakSet = weakref.WeakSet()  # every Kept of the process (release)


@lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 of every ``.py`` file of the installed ``gyrojax`` package (paths and contents)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


CPU_FIELDS = (
    "vendor_id",
    "cpu family",
    "model",
    "model name",
    "flags",
    "Features",
    "CPU implementer",
    "CPU part",
    "isa",
)
"""The fields of Linux's ``/proc/cpuinfo`` (x86, ARM, RISC-V) that name a CPU and its instruction set."""


def cpu_fingerprint(cpuinfo: str) -> str:
    """SHA-256 of the :data:`CPU_FIELDS` of the first processor in a ``/proc/cpuinfo`` text."""
    first = cpuinfo.split("\n\n", 1)[0]
    fields = {}
    for line in first.splitlines():
        name, sep, value = line.partition(":")
        if sep and name.strip() in CPU_FIELDS:
            fields[name.strip()] = " ".join(value.split())
    return hashlib.sha256(repr(sorted(fields.items())).encode()).hexdigest()


@lru_cache(maxsize=1)
def host_cpu() -> str:
    """The host CPU as XLA compiles for it: its architecture and, on Linux, its model and instruction-set flags
    (:func:`cpu_fingerprint`); elsewhere what :mod:`platform` says of the machine."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            info = cpu_fingerprint(f.read())
    except OSError:
        info = repr((platform.processor(), platform.version()))
    return hashlib.sha256(repr((platform.machine(), platform.system(), info)).encode()).hexdigest()


def folder() -> Path | None:
    """Where kept executables live (beside the command line's compilation cache), or ``None`` when gyrojax's cache
    is off (:func:`gyrojax.runtime.cache.cache_dir`)."""
    d = cache_dir()
    return Path(str(d).rstrip("/\\") + SUFFIX) if d else None


def prune(where: Path) -> list[Path]:
    """Delete the kept files in ``where`` of library sources other than this one (and those named without the
    digest, an earlier layout), but the files of the :data:`KEEP_OTHER_SOURCES` other sources written last.
    Returns the paths deleted; a file that cannot be deleted (another process, permissions) is left."""
    if not where.is_dir():
        return []
    mine = source_digest()[:DIGEST_CHARS]
    others: dict[str, list] = {}
    gone = []
    for p in where.iterdir():
        m = _NAMED.match(p.name)
        if m is None:
            if _UNNAMED.match(p.name):
                gone.append(p)
        elif m["digest"] != mine:
            others.setdefault(m["digest"], []).append(p)

    def newest(paths):
        return max((q.stat().st_mtime for q in paths if q.exists()), default=0.0)

    for _, paths in sorted(others.items(), key=lambda kv: newest(kv[1]), reverse=True)[KEEP_OTHER_SOURCES:]:
        gone += paths
    deleted = []
    for p in gone:
        try:
            p.unlink()
            deleted.append(p)
        except OSError:
            pass
    return deleted


def _save(path: Path, data: bytes, what: str, stacklevel: int) -> None:
    """Write a kept file atomically; a folder that cannot be written (a read-only home, a path through a file) is
    said once per process and then left alone: the process compiles or computes again what it could not keep."""
    try:
        atomic_write_bytes(path, data)
    except OSError as e:
        with _LOCK:
            if path.parent in _UNWRITABLE:
                return
            _UNWRITABLE.add(path.parent)
        warnings.warn(
            f"{path.parent}: kept {what} not saved ({e.strerror or e}); this process compiles and computes them again "
            "(GYROJAX_CACHE_DIR moves the cache, GYROJAX_NO_CACHE=1 turns it off)",
            stacklevel=stacklevel,
        )


def _path(where: Path, name: str, key: str, suffix: str) -> Path:
    """The file of a kept executable or array set; the folder is pruned (:func:`prune`) at its first use in a
    process."""
    with _LOCK:
        if where not in _PRUNED:
            _PRUNED.add(where)
            prune(where)
    return where / f"{name}-{source_digest()[:DIGEST_CHARS]}-{key[:32]}{suffix}"


def _key(name: str, tree, specs) -> str:
    """The full key (SHA-256 hex) of ``name`` at the argument tree and flat specs, on this library, JAX and host."""
    import jaxlib

    parts = (
        name,
        str(tree),
        [(s.shape, str(s.dtype)) for s in specs],
        source_digest(),
        jax.__version__,
        jaxlib.__version__,
        jax.default_backend(),
        bool(jax.config.jax_enable_x64),
        host_cpu(),
        os.environ.get("XLA_FLAGS", ""),
        jax.process_count(),
        jax.process_index(),
    )
    return hashlib.sha256(repr(parts).encode()).hexdigest()


class Kept:
    """A jitted function ``fn`` called through its compiled executable, saved and reloaded per argument shape."""

    def __init__(self, name: str, fn):
        self.name, self.fn, self._calls = name, fn, {}
        self.__doc__ = getattr(fn, "__doc__", None)
        _ALL.add(self)

    @classmethod
    def of(cls, stem: str, fn, *statics) -> Kept:
        """``fn`` jitted and kept under ``stem`` and a digest of ``statics``: every value ``fn`` closes over, which
        (with the library's source, in every key) determine its code."""
        digest = hashlib.sha256(repr(statics).encode()).hexdigest()[:12]
        return cls(f"{stem}_{digest}", jax.jit(fn))

    def _load(self, where: Path, tree, specs):
        """The executable of ``fn`` at the argument tree ``tree`` and flat ``specs``: read from its file when that
        holds an executable of this key, else compiled (and the file written or replaced, when it can be kept)."""
        key = _key(self.name, tree, specs)
        path = _path(where, self.name, key, ".xla")
        if path.is_file():
            try:
                return _read(path.read_bytes(), key, specs)
            except Exception as e:  # a damaged or foreign file: say so, compile again and replace it
                warnings.warn(
                    f"{path}: kept executable not loaded ({type(e).__name__}: {e}); compiled again", stacklevel=4
                )

        def flat(*leaves):  # compiled over the leaves: the argument tree (in the key) may hold non-array types
            return self.fn(*jax.tree_util.tree_unflatten(tree, leaves))

        flat.__name__ = f"{self.name}_{key[:12]}"  # a module of its own: JAX's persistent cache does not hold it
        compiled, from_cache = _compile(flat, specs)
        if from_cache:  # JAX's persistent cache held it all the same (its kept file gone): compiled afresh
            flat.__name__ = f"{self.name}_{secrets.token_hex(8)}"
            compiled, _ = _compile(flat, specs)
        data = _written(compiled, key)
        if data is not None:
            _save(path, data, "executables", stacklevel=5)
        return compiled

    def __call__(self, *args):
        where = folder()
        leaves, tree = jax.tree_util.tree_flatten(args)
        if where is None or any(isinstance(x, jax.core.Tracer) for x in leaves):
            return self.fn(*args)
        leaves = [x if isinstance(x, jax.Array) else np.asarray(x) for x in leaves]
        return self._executable(where, tree, leaves)(*leaves)

    def prepare(self, *args):
        """Make the executable of arguments shaped as ``args`` ready (read from its file, or compiled) without
        calling it; an argument may be a :class:`jax.ShapeDtypeStruct` in place of an array. Returns the shapes of
        its outputs (a tree of :class:`jax.ShapeDtypeStruct`), or None when nothing is kept (the cache off). For a
        caller that loads one kept function on another thread while a first runs."""
        where = folder()
        if where is None:
            return None
        leaves, tree = jax.tree_util.tree_flatten(args)
        return self._executable(where, tree, [x if hasattr(x, "dtype") else np.asarray(x) for x in leaves]).out_info

    def _executable(self, where: Path, tree, leaves):
        """The executable of the argument tree ``tree`` at the shapes and dtypes of ``leaves``."""
        key = (where, tree, tuple((x.shape, x.dtype) for x in leaves))  # dtype objects: str() of each is slow
        call = self._calls.get(key)
        if call is None:
            # worker threads (gyrojax.runtime.threads.parallel_map) at a new shape: one loads, the others wait
            with _LOCK:
                call = self._calls.get(key)
                if call is None:
                    make_room()
                    specs = [jax.ShapeDtypeStruct(x.shape, x.dtype) for x in leaves]
                    call = self._calls[key] = self._load(where, tree, specs)
        return call


def release() -> int:
    """Drop the executables every :class:`Kept` of this process holds; each is read again from its file at its next
    call. Returns how many were dropped. For a long process that has met many functions and shapes (a test session, a
    notebook's kernel running for days): the machine code of each executable XLA's CPU backend holds takes a few
    entries of the process' memory map, Linux allows a process ``vm.max_map_count`` of them (65530 by default), and
    XLA cannot compile once they are used up (``LLVM compilation error: Cannot allocate memory``, then a segmentation
    fault). ``jax.clear_caches()`` drops those of the process' own jitted functions."""
    with _LOCK:
        kept = list(_ALL)
        dropped = sum(len(k._calls) for k in kept)
        for k in kept:
            k._calls.clear()
    return dropped


MAP_HEADROOM = 0.75
"""The share of ``vm.max_map_count`` past which a new executable is preceded by :func:`release`."""


def map_entries() -> tuple[int, int] | None:
    """(entries of this process' memory map, the most Linux allows it), or None where /proc does not say."""
    try:
        with open("/proc/self/maps", "rb") as f:
            used = sum(1 for _ in f)
        return used, int(Path("/proc/sys/vm/max_map_count").read_text())
    except (OSError, ValueError):
        return None


def make_room() -> None:
    """Before a kept function's new executable: past :data:`MAP_HEADROOM` of the memory-map limit (:func:`release`),
    drop the kept executables and say so, rather than let XLA's next compile die of the limit."""
    maps = map_entries()
    if maps is not None and maps[0] > MAP_HEADROOM * maps[1]:
        n = release()
        warnings.warn(
            f"this process holds {maps[0]} of the {maps[1]} memory-map entries Linux allows it (vm.max_map_count); "
            f"XLA cannot compile past the limit, so gyrojax dropped its {n} kept executables (read again from their "
            "files when called); jax.clear_caches() drops those of every other jitted function",
            RuntimeWarning,
            stacklevel=5,
        )


CACHE_HIT = "/jax/compilation_cache/cache_hits"
"""The event JAX records when its persistent compilation cache returns an executable: one read from that cache
serialises without its machine code (jaxlib 0.10.2 CPU: calling it fails with "Function … not found"), so it is never
kept."""


def _compile(fn, specs):
    """(``fn`` jitted and compiled at ``specs``, whether JAX's persistent cache returned it rather than XLA compiling
    it in this thread)."""
    me, hits = threading.get_ident(), []

    def listen(event, **_):
        if event == CACHE_HIT and threading.get_ident() == me:
            hits.append(event)

    jax.monitoring.register_event_listener(listen)
    try:
        return jax.jit(fn).lower(*specs).compile(), bool(hits)
    finally:
        jax.monitoring.unregister_event_listener(listen)


def _written(compiled, key: str) -> bytes | None:
    """The file of a compiled executable: :data:`MAGIC`, then its key, the LAPACK kernels it calls, its output tree and
    the serialised executable; ``None`` when it cannot be kept (a custom call :mod:`gyrojax.runtime.lapack` cannot
    make ready in a fresh process, constants JAX cannot serialise)."""
    kernels = lapack.targets(compiled.as_text())
    if not lapack.preparable(kernels):
        return None
    try:
        payload, _, out_tree = serialize(compiled)
    except (ValueError, TypeError, NotImplementedError):
        return None
    return MAGIC + pickle.dumps(
        {"key": key, "kernels": sorted(kernels), "out_tree": out_tree, "executable": payload},
        protocol=pickle.HIGHEST_PROTOCOL,
    )


def _read(data: bytes, key: str, specs):
    """The executable a kept file holds, loaded after the LAPACK kernels it calls are made ready; ValueError when
    the file is not a kept executable, is of another key, or its inputs are not ``specs``."""
    if not data.startswith(MAGIC):
        raise ValueError("not a kept executable")
    entry = pickle.loads(data[len(MAGIC) :])
    if entry["key"] != key:
        raise ValueError("an executable of another key (function, shapes, library, JAX, CPU or XLA flags)")
    lapack.prepare(entry["kernels"])
    in_tree = jax.tree_util.tree_structure((tuple(range(len(specs))), {}))
    compiled = deserialize_and_load(entry["executable"], in_tree, entry["out_tree"])
    _check(compiled, specs)
    return compiled


def _check(compiled, specs) -> None:
    """Refuse (ValueError) an executable whose inputs are not ``specs`` (never called with arguments it was not
    compiled for)."""
    want = [(tuple(s.shape), np.dtype(s.dtype)) for s in specs]
    got = [(tuple(a.shape), np.dtype(a.dtype)) for a in jax.tree_util.tree_leaves(compiled.in_avals)]
    if got != want:
        raise ValueError(f"its inputs {got} are not the call's {want}")


def kept_arrays(name: str, parts, compute):
    """The arrays ``compute()`` returns (a list of numpy arrays), kept on disk beside the compilation cache under
    ``name`` and the key ``parts`` (with the source digest and versions, as the traces): for results that depend on
    the library alone (built-in plans and effects), never on the user's data. Exact: saved and read as ``.npy``."""
    where = folder()
    if where is None:
        return compute()
    path = _path(where, name, _key(name, repr(parts), []), ".npz")
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as z:
                return [z[f"a{i}"] for i in range(len(z.files))]
        except Exception as e:  # a damaged file: say so, compute again and replace it
            warnings.warn(f"{path}: kept arrays unreadable ({type(e).__name__}: {e}); computed again", stacklevel=2)
    arrays = [np.asarray(a) for a in compute()]
    buf = io.BytesIO()
    np.savez(buf, **{f"a{i}": a for i, a in enumerate(arrays)})
    _save(path, buf.getvalue(), "arrays", stacklevel=3)
    return arrays
