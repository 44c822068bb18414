"""Timing a command as a fresh process, shared by the benchmarks: wall seconds and the child's CPU seconds."""

from __future__ import annotations

import resource
import subprocess
import sys
import time
from pathlib import Path


def python_of(root) -> str:
    """The interpreter of the checkout ``root``: its own ``.venv`` when it has one (the versions of its lock, e.g. a
    baseline checkout's), else this process' interpreter."""
    own = Path(root) / ".venv" / "bin" / "python"
    return str(own) if own.exists() else sys.executable


def run_process(cmd, env=None, ok=(0,), cwd=None) -> tuple[float, float, str]:
    """(wall seconds, CPU seconds of the child: user + sys, stdout) of one run of ``cmd`` (in ``cwd``); the CPU
    reading is the one a loaded machine disturbs least. An exit code not in ``ok`` raises, with the end of its
    stderr."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    dt = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode not in ok:
        raise RuntimeError(f"{' '.join(map(str, cmd[:4]))} …: exit {out.returncode}: {out.stderr[-2000:]}")
    return dt, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out.stdout


def compile_here() -> None:
    """A benchmark process times compiling itself (cold − warm, reported apart from the run): JAX's persistent
    compilation cache is off in it (as after ``import gyrojax``), and so are gyrojax's kept executables, for this
    process only. Child processes it starts keep theirs, as any process does."""
    import jax

    import gyrojax  # noqa: F401  (x64)
    from gyrojax.runtime import kept

    jax.config.update("jax_compilation_cache_dir", None)
    kept.folder = lambda: None
