"""gyrojax's own compiled functions kept across processes: a function wrapped in :class:`Kept` is traced once per
argument shape and saved as a ``jax.export`` module in gyrojax's cache folder (:func:`folder`), so a fresh process
(the command line, a notebook's kernel) neither traces nor lowers it again; the command line's persistent compilation
cache (:func:`gyrojax.runtime.cache.use_persistent_cache`) spares the compile there. A notebook's process gets the
same cache when it imports gyrojax (:func:`gyrojax.runtime.cache.default_for_import`).

A saved module is keyed by the function's name, the argument tree, shapes and dtypes (the callers pad records to a few
lengths, :func:`gyrojax.noise.reml.series`), the digest of the whole ``gyrojax`` source (its version included), the JAX
and jaxlib versions and the backend: any edit of the library makes new keys, so a stale trace is never called. The file
name carries the first :data:`DIGEST_CHARS` hex digits of the source digest, and the first use of the folder in a
process deletes the files of other library sources (:func:`prune`) but those of the :data:`KEEP_OTHER_SOURCES` most
recently written, so that the folder does not grow with every edit of the library (two checkouts sharing one cache keep
theirs). A module is exported over the arguments' flat leaves (the tree, in the key, may hold types ``jax.export``
cannot serialise, e.g. :class:`~gyrojax.physics.model.RecordData`); a file that cannot be read, or whose module's inputs
are not the call's, is traced again with a warning and replaced, never called. Nothing is kept when gyrojax's cache is
off (``GYROJAX_NO_CACHE=1``), when the arguments are tracers (the function inside another transformation), when the
outputs hold types ``jax.export`` cannot name, or without the ``flatbuffers`` package that ``jax.export`` serialises
with: the jitted function itself runs then.
"""

from __future__ import annotations

import hashlib
import importlib.util
import io
import re
import threading
import warnings
from functools import lru_cache
from pathlib import Path

import jax
import numpy as np

from gyrojax.protocol import atomic_write_bytes
from gyrojax.runtime.cache import cache_dir

SERIALIZABLE = importlib.util.find_spec("flatbuffers") is not None
"""``jax.export`` serialises with the ``flatbuffers`` package; without it nothing is kept (the answers are the same,
a fresh process traces again)."""
SUFFIX = "-exported"
"""The folder of the kept traces is the compilation cache's folder with this suffix (a sibling, not inside it)."""
DIGEST_CHARS = 16
"""Hex digits of the source digest in a kept file's name (``NAME-DIGEST-KEY.bin`` / ``.npz``)."""
KEEP_OTHER_SOURCES = 2
"""Other library sources whose kept files :func:`prune` leaves (the most recently written ones)."""
_NAMED = re.compile(rf"^.+-(?P<digest>[0-9a-f]{{{DIGEST_CHARS}}})-[0-9a-f]{{32}}\.(bin|npz)$")
_UNNAMED = re.compile(r"^.+-[0-9a-f]{32}\.(bin|npz)$")  # the names before the digest was in them
_PRUNED: set = set()
_UNWRITABLE: set = set()  # folders a kept file could not be written to (said once)
_LOCK = threading.RLock()  # a trace loaded (and the folder pruned) by one thread at a time


@lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 of every ``.py`` file of the installed ``gyrojax`` package (paths and contents)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def folder() -> Path | None:
    """Where kept traces live (beside the command line's compilation cache), or ``None`` when gyrojax's cache is off
    (:func:`gyrojax.runtime.cache.cache_dir`) or ``jax.export`` cannot serialise."""
    d = cache_dir()
    if not SERIALIZABLE:
        return None
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
    said once per process and then left alone: the process traces or computes again what it could not keep."""
    try:
        atomic_write_bytes(path, data)
    except OSError as e:
        with _LOCK:
            if path.parent in _UNWRITABLE:
                return
            _UNWRITABLE.add(path.parent)
        warnings.warn(
            f"{path.parent}: kept {what} not saved ({e.strerror or e}); this process traces and computes them again "
            "(GYROJAX_CACHE_DIR moves the cache, GYROJAX_NO_CACHE=1 turns it off)",
            stacklevel=stacklevel,
        )


def _path(where: Path, name: str, key: str, suffix: str) -> Path:
    """The file of a kept trace or array set; the folder is pruned (:func:`prune`) at its first use in a process."""
    with _LOCK:
        if where not in _PRUNED:
            _PRUNED.add(where)
            prune(where)
    return where / f"{name}-{source_digest()[:DIGEST_CHARS]}-{key}{suffix}"


def _key(name: str, tree, specs) -> str:
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
    )
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


class Kept:
    """A jitted function ``fn`` called through its ``jax.export`` module, saved and reloaded per argument shape."""

    def __init__(self, name: str, fn):
        self.name, self.fn, self._calls = name, fn, {}
        self.__doc__ = getattr(fn, "__doc__", None)

    def _load(self, where: Path, tree, specs):
        """The exported module of ``fn`` at the argument tree ``tree`` and flat ``specs``: read from its file when
        that holds a module of this function at these shapes, else traced (and the file written or replaced)."""
        path = _path(where, self.name, _key(self.name, tree, specs), ".bin")
        if path.is_file():
            try:
                exported = jax.export.deserialize(bytearray(path.read_bytes()))
                _check(exported, specs)
                return exported
            except Exception as e:  # a damaged or foreign file: say so, trace again and replace it
                warnings.warn(f"{path}: kept trace unreadable ({type(e).__name__}: {e}); traced again", stacklevel=3)

        def flat(*leaves):  # exported over the leaves: the argument tree (in the key) may hold unregistered types
            return self.fn(*jax.tree_util.tree_unflatten(tree, leaves))

        flat.__name__ = self.name
        exported = jax.export.export(jax.jit(flat))(*specs)
        try:
            data = exported.serialize()
        except (ValueError, TypeError, NotImplementedError):  # an output tree of types export cannot name
            return None
        _save(path, data, "traces", stacklevel=4)
        return exported

    def __call__(self, *args):
        where = folder()
        leaves, tree = jax.tree_util.tree_flatten(args)
        if where is None or any(isinstance(x, jax.core.Tracer) for x in leaves):
            return self.fn(*args)
        leaves = [x if isinstance(x, jax.Array) else np.asarray(x) for x in leaves]
        key = (where, tree, tuple((x.shape, str(x.dtype)) for x in leaves))
        call = self._calls.get(key)
        if call is None:
            with (
                _LOCK
            ):  # worker threads (gyrojax.runtime.threads.parallel_map) at a new shape: one loads, the others wait
                call = self._calls.get(key)
                if call is None:
                    specs = [jax.ShapeDtypeStruct(x.shape, x.dtype) for x in leaves]
                    exported = self._load(where, tree, specs)
                    call = self._calls[key] = False if exported is None else jax.jit(exported.call)
        if call is False:
            return self.fn(*args)
        return call(*leaves)


def _check(exported, specs) -> None:
    """Refuse (ValueError) an exported module whose inputs are not ``specs`` (a file of another function or layout
    under this name: never called with arguments it was not traced for)."""
    want = [(tuple(s.shape), np.dtype(s.dtype)) for s in specs]
    got = [(tuple(a.shape), np.dtype(a.dtype)) for a in exported.in_avals]
    if exported.in_tree.num_leaves != len(specs) or got != want:
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
