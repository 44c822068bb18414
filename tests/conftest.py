import gc
import json
import os
from pathlib import Path

import pytest

import gyrojax  # noqa: F401  (x64 is switched on by the package, once)
from gyrojax.runtime import kept
from gyrojax.runtime.cache import use_persistent_cache
from gyrojax.runtime.threads import single_threaded_blas

single_threaded_blas()  # two test workers on two cores: BLAS threads would only spin against each other
# JAX's persistent compilation cache for the whole session, kept in the repository's pytest cache (not the user's):
# many tests compile the same computations through different function objects, and even a fresh cache pays for
# itself within one run (the suite took 5 min 24 s with it, 5 min 58 s without, on 2 cores)
os.environ.setdefault("GYROJAX_CACHE_DIR", str(Path(__file__).resolve().parent.parent / ".pytest_cache" / "jax"))
use_persistent_cache()


@pytest.fixture(autouse=True, scope="module")
def _release_executables():
    """The session is one process that compiles thousands of functions, and the machine code of every executable
    held (by a jitted function's cache, by a kept function) takes a few entries of the process' memory map: once
    Linux's vm.max_map_count (65530) of them are used, XLA cannot compile and the process dies. After a test module,
    past half of the limit, the compiled executables are dropped (compiled again or read from the caches when met
    again)."""
    yield
    maps = kept.map_entries()
    if maps is not None and maps[0] > maps[1] // 2:
        import jax  # imported by then (the modules that compile imported it)

        jax.clear_caches()
        kept.release()
        gc.collect()


DATA = Path(__file__).resolve().parent / "data"
EXAMPLES = DATA / "examples"
"""Campaigns written by an independent tool, vendored (tests/data/README.md)."""
IMUCAL = DATA / "imucal"
"""A real MEMS-IMU session and imucal's calibration of it (MIT), vendored."""


@pytest.fixture(scope="session")
def example_campaigns():
    return json.loads((EXAMPLES / "examples.json").read_text())
