"""The folder where gyrojax keeps what it compiled, and JAX's persistent compilation cache there: for the command
line's process (:func:`use_persistent_cache`) and for a notebook or script that imports gyrojax
(:func:`default_for_import`, unless the process chose a cache of its own). gyrojax's kept traces
(:mod:`gyrojax.runtime.kept`) live beside it.
"""

from __future__ import annotations

import os
import sys

JAX_SETTINGS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


def cache_dir() -> str | None:
    """Where gyrojax keeps JAX's persistent compilation cache of the command line: ``GYROJAX_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/gyrojax/jax`` or ``~/.cache/gyrojax/jax``; ``None`` when ``GYROJAX_NO_CACHE`` is set. The
    kept traces live in a sibling folder (:func:`gyrojax.runtime.kept.folder`)."""
    if os.environ.get("GYROJAX_NO_CACHE", "").strip() not in ("", "0"):
        return None
    if os.environ.get("GYROJAX_CACHE_DIR"):
        return os.environ["GYROJAX_CACHE_DIR"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "gyrojax", "jax")


def use_persistent_cache() -> None:
    """Turn on JAX's persistent compilation cache at :func:`cache_dir` (nothing when it is switched off) for every
    compiled function however small (a diagnosis compiles dozens): the command line, the test suite, and (through
    :func:`default_for_import`) a process that imports gyrojax. Before JAX's import its variables are set, after
    it its config is updated."""
    path = cache_dir()
    if path is None:
        return
    values = (path, 0.0, 0)
    if "jax" in sys.modules:
        for name, value in zip(JAX_SETTINGS, values):
            sys.modules["jax"].config.update(name, value)
    else:  # JAX reads them when (and if) it is imported: `gyrojax plans` and `import` never do
        for name, value in zip(JAX_SETTINGS, values):
            os.environ[name.upper()] = str(value)


def default_for_import() -> None:
    """The persistent compilation cache for a notebook or script that imports gyrojax, as for the command: without
    it each new process compiles every function of a diagnosis again. A cache the process chose itself
    (``JAX_COMPILATION_CACHE_DIR``, or JAX's config set before the import) is left as it is, and
    ``GYROJAX_NO_CACHE=1`` turns it off. JAX's cache is process-wide: it keeps the user's compiled functions too
    (gyrojax cannot keep only its own: JAX's CPU executables serialised by ``jax.experimental.serialize_executable``
    crash when a fresh process loads them, jaxlib 0.10.2)."""
    if "jax" in sys.modules:
        if sys.modules["jax"].config.jax_compilation_cache_dir:
            return
    elif os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return
    use_persistent_cache()
