"""The folder where gyrojax keeps what it compiled, and JAX's persistent compilation cache there for a process that
is gyrojax's alone (the command line, the test suite: :func:`use_persistent_cache`). gyrojax's kept executables
(:mod:`gyrojax.runtime.kept`) live beside it; a notebook or script that imports gyrojax gets those, never a switch of
its own process' JAX settings.
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
    kept executables live in a sibling folder (:func:`gyrojax.runtime.kept.folder`)."""
    if os.environ.get("GYROJAX_NO_CACHE", "").strip() not in ("", "0"):
        return None
    if os.environ.get("GYROJAX_CACHE_DIR"):
        return os.environ["GYROJAX_CACHE_DIR"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "gyrojax", "jax")


def persistent_cache_settings() -> dict | None:
    """JAX's config values of :func:`use_persistent_cache` by name (the folder, and every compiled function kept
    however small or quick to compile; seconds, bytes), ``None`` when the cache is switched off."""
    path = cache_dir()
    return None if path is None else dict(zip(JAX_SETTINGS, (path, 0.0, 0)))


def use_persistent_cache() -> None:
    """Turn on JAX's persistent compilation cache at :func:`cache_dir` (nothing when it is switched off) for every
    compiled function however small: for a process that is gyrojax's alone (the command line, the test suite),
    never on import. Before JAX's import its variables are set, after it its config is updated."""
    settings = persistent_cache_settings()
    if settings is None:
        return
    if "jax" in sys.modules:
        for name, value in settings.items():
            sys.modules["jax"].config.update(name, value)
    else:  # JAX reads them when (and if) it is imported: `gyrojax plans` and `import` never do
        for name, value in settings.items():
            os.environ[name.upper()] = str(value)
