"""Running a Monte Carlo study: draws in chunks (bounded memory) over a 1-D mesh of devices
(``jax.sharding.NamedSharding``), split over the processes of a ``jax.distributed`` job and gathered
(:mod:`gyrojax.montecarlo.hosts`). Every draw depends only on (seed, draw index) (:mod:`gyrojax.montecarlo.pipeline`),
so the chunking, the devices and the processes never change a result.
"""

from __future__ import annotations

import math
import sys
import time

import jax
import numpy as np

from gyrojax.montecarlo.pipeline import Pipeline, build_pipeline
from gyrojax.montecarlo.results import StudyResult
from gyrojax.montecarlo.study import Study, StudyError


def auto_chunk(pipe: Pipeline, n_devices: int = 1, budget_bytes: float = 1.5e9) -> int:
    """Draws per chunk so that the arrays of a chunk's draws (``pipe.draw_bytes`` each) stay within
    ``budget_bytes``."""
    c = max(1, int(budget_bytes // pipe.draw_bytes))
    return max(n_devices, (c // n_devices) * n_devices)


def _progress(done: int, total: int, t0: float, stream, last: list) -> None:
    """Progress bar on ``stream``: redrawn in place on a terminal at most 10 times a second, and written as a new
    line at most every 10 s elsewhere (log files), always at the end."""
    now = time.perf_counter()
    tty = getattr(stream, "isatty", lambda: False)()
    if done < total and now - last[0] < (0.1 if tty else 10.0):
        return
    last[0] = now
    frac = done / total
    bar = "#" * int(30 * frac)
    rate = done / max(time.perf_counter() - t0, 1e-9)
    head = "\r" if tty else ""
    stream.write(f"{head}[{bar:<30s}] {done}/{total} draws  {rate:,.0f} draws/s")
    if done == total or not tty:
        stream.write("\n")
    stream.flush()


def batched_draws(pipe: Pipeline, devices=None):
    """A jitted function of draw indices (n_dev, k) → per-draw results (n_dev, k, …), θ in report units.

    Axis 0 is sharded over a 1-D mesh of ``devices`` (default: all) with ``NamedSharding``; along axis 1 each
    device runs its draws one after another (``lax.map``), which keeps a draw's arrays in cache: on CPU this is
    several times faster than ``vmap`` over draws, whose batched intermediates do not fit.
    """
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    devices = list(devices if devices is not None else jax.devices())
    mesh = Mesh(np.array(devices), ("draws",))
    sh = NamedSharding(mesh, PartitionSpec("draws"))
    f = jax.jit(jax.vmap(lambda row: jax.lax.map(pipe.draw, row)), in_shardings=sh, out_shardings=sh)
    return f, sh, len(devices)


def run_study(
    study: Study,
    draws: int | None = None,
    chunk: int | None = None,
    devices=None,
    progress=False,
    pipeline: Pipeline | None = None,
    start: int = 0,
) -> StudyResult:
    """Evaluate draws ``start … start+draws−1`` of a study in chunks over a mesh of devices (module doc).

    In a ``jax.distributed`` job of N processes (:mod:`gyrojax.montecarlo.hosts`), process k evaluates the block
    :func:`gyrojax.montecarlo.hosts.share` of the draws on its own devices (``devices``: default its local ones),
    and every process returns the whole result, gathered in draw order: the same draws as one process computes.
    ``compile_s`` and ``run_s`` are then the slowest process's.
    """
    from gyrojax.montecarlo import hosts

    pipe = pipeline or build_pipeline(study)
    n = int(draws if draws is not None else study.draws)
    nproc, pid = jax.process_count(), jax.process_index()
    if nproc > 1:
        devices = list(devices) if devices is not None else jax.local_devices()
        if any(d.process_index != pid for d in devices):
            raise StudyError("run_study: in a multi-process job each process runs on its own (local) devices")
    lo, hi = hosts.share(n, nproc, pid)
    local, compile_s, run_s = _evaluate(pipe, start + lo, hi - lo, chunk or study.chunk, devices, progress)
    if nproc > 1:
        counts = [hosts.share(n, nproc, k)[1] - hosts.share(n, nproc, k)[0] for k in range(nproc)]
        local = hosts.gather(local, counts)
        times = hosts.gather({"t": np.array([[compile_s, run_s]])}, [1] * nproc)["t"]
        compile_s, run_s = float(times[:, 0].max()), float(times[:, 1].max())
    return StudyResult(
        study,
        pipe.truth_model.coefficient_names,
        pipe.fit_model.coefficient_names,
        np.arange(start, start + n),
        local["truth"],
        local["estimate"],
        local["std"],
        local["rms"],
        compile_s,
        run_s,
        pipe.fit_method,
    )


def _evaluate(pipe: Pipeline, start: int, n: int, chunk, devices, progress):
    """Per-draw arrays of draws ``start … start+n−1`` on ``devices`` (default: all): (dict, compile_s, run_s)."""
    f, sh, ndev = batched_draws(pipe, devices)
    chunk = chunk or auto_chunk(pipe, ndev)
    chunk = int(math.ceil(min(chunk, max(n, 1)) / ndev) * ndev)
    stream = sys.stderr
    outs = []
    t0 = time.perf_counter()
    per = chunk // ndev
    cache_key = (tuple(str(d) for d in (devices if devices is not None else jax.devices())), chunk)
    compiled = pipe.compiled.get(cache_key)
    if compiled is None:
        idx0 = jax.device_put(np.arange(start, start + chunk, dtype=np.int64).reshape(ndev, per), sh)
        compiled = pipe.compiled[cache_key] = f.lower(idx0).compile()
    compile_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    last = [-math.inf]
    for s in range(0, n, chunk):
        idx = np.arange(start + s, start + s + chunk, dtype=np.int64)  # the last chunk is padded, then trimmed
        out = compiled(jax.device_put(idx.reshape(ndev, per), sh))
        k = min(chunk, n - s)
        outs.append({key: np.asarray(v).reshape((chunk,) + v.shape[2:])[:k] for key, v in out.items()})
        if progress:
            _progress(s + k, n, t1, stream, last)
    run_s = time.perf_counter() - t1
    if outs:
        cat = {key: np.concatenate([o[key] for o in outs]) for key in outs[0]}
    else:  # no draws: empty arrays of the right widths
        p_true, p_fit = pipe.truth_model.size, pipe.fit_model.size
        cat = {"truth": np.zeros((0, p_true)), "estimate": np.zeros((0, p_fit)), "std": np.zeros((0, p_fit))}
        cat["rms"] = np.zeros(0)
    return cat, compile_s, run_s
