"""Where the test suite's time goes: a pytest plugin that adds up JAX's own timings of tracing, lowering and XLA
compilation per test file, beside the file's wall time, and prints the files that spend most.

    python -m pytest -p benchmarks.suite_compile -n 2 --dist loadfile tests       # from the repository root
    GYROJAX_CACHE_DIR=$(mktemp -d) python -m pytest -p benchmarks.suite_compile ... # as a clean clone's CI runs it

Each process (an xdist worker, or the only one) listens to JAX's duration events (``jax.monitoring``) and writes its
sums to a folder the controlling process made; the controller adds them up and prints the table at the end of the
run. Processes the tests start themselves (notebook kernels, command lines) are not counted: their files show wall
time only.
"""

from __future__ import annotations

import collections
import json
import os
import tempfile
import time
from pathlib import Path

import jax.monitoring

EVENTS = {
    "/jax/core/compile/jaxpr_trace_duration": "trace",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
    "/jax/core/compile/backend_compile_duration": "compile",
}
"""JAX's duration events, by the column they add to."""
FOLDER = "GYROJAX_SUITE_COMPILE_DIR"
"""The environment variable naming the folder the processes write their sums to (set by the controller)."""
SHOWN = 30
"""Files in the printed table."""

_current = ["(collection)"]
_sums: dict = collections.defaultdict(collections.Counter)
_functions: dict = collections.defaultdict(collections.Counter)
"""XLA compilation by the compiled function's name: which computations the suite compiles most."""


def _listen(event: str, duration: float, fun_name: str = "?", **_) -> None:
    column = EVENTS.get(event)
    if column is not None:
        _sums[_current[0]][column] += duration
        _sums[_current[0]][column + "_n"] += 1
        if column == "compile":
            _functions[fun_name]["compile"] += duration
            _functions[fun_name]["n"] += 1


def pytest_configure(config):
    if not os.environ.get(FOLDER):  # the controller (or a run without workers): the folder the processes write to
        os.environ[FOLDER] = tempfile.mkdtemp(prefix="suite-compile-")
    jax.monitoring.register_event_duration_secs_listener(_listen)


def pytest_runtest_protocol(item, nextitem):
    _current[0] = item.nodeid.split("::")[0]
    _sums[_current[0]]["start"] = _sums[_current[0]]["start"] or time.perf_counter()


def pytest_runtest_logfinish(nodeid, location):
    file = nodeid.split("::")[0]
    _sums[file]["wall"] += time.perf_counter() - _sums[file].pop("start", time.perf_counter())


def pytest_sessionfinish(session):
    name = os.environ.get("PYTEST_XDIST_WORKER", "main")
    Path(os.environ[FOLDER], f"{name}.json").write_text(
        json.dumps(
            {"files": {k: dict(v) for k, v in _sums.items()}, "functions": {k: dict(v) for k, v in _functions.items()}}
        )
    )


def pytest_terminal_summary(terminalreporter):
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return
    total: dict = collections.defaultdict(collections.Counter)
    functions: dict = collections.defaultdict(collections.Counter)
    for path in Path(os.environ[FOLDER]).glob("*.json"):
        sums = json.loads(path.read_text())
        for file, s in sums["files"].items():
            total[file].update(s)
        for name, s in sums["functions"].items():
            functions[name].update(s)
    write = terminalreporter.write_line
    whole = collections.Counter()
    for sums in total.values():
        whole.update(sums)
    spent = sum(whole[c] for c in EVENTS.values())
    write("")
    write(
        f"JAX in the test processes: {whole['wall']:.0f} s of tests, of which tracing {whole['trace']:.0f} s "
        f"({whole['trace_n']:.0f} traces), lowering {whole['lower']:.0f} s, XLA compilation {whole['compile']:.0f} s "
        f"({whole['compile_n']:.0f} executables): {spent / max(whole['wall'], 1e-9):.0%}"
    )
    write(f"{'wall s':>8} {'trace':>7} {'lower':>7} {'compile':>8} {'execs':>6}  file")
    for file, s in sorted(total.items(), key=lambda kv: -kv[1]["wall"])[:SHOWN]:
        write(f"{s['wall']:8.1f} {s['trace']:7.1f} {s['lower']:7.1f} {s['compile']:8.1f} {s['compile_n']:6.0f}  {file}")
    write(f"{'compile':>8} {'execs':>6}  compiled function")
    for name, s in sorted(functions.items(), key=lambda kv: -kv[1]["compile"])[:SHOWN]:
        write(f"{s['compile']:8.1f} {s['n']:6.0f}  {name}")
