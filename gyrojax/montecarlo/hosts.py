"""A Monte Carlo study as N processes of one ``jax.distributed`` job (one per host, or several on one machine).

Every draw depends only on (seed, draw index) (:mod:`gyrojax.montecarlo.pipeline`), so the processes need no
communication while they compute: process k of N evaluates the contiguous block of draw indices
:func:`share` gives it, on its own devices, and the blocks are then gathered (an all-gather over JAX's
cross-process collectives; on CPU these are gloo's TCP collectives, JAX's default
``jax_cpu_collectives_implementation``). The union of the blocks is the single-process run, draw for draw.

Launch (the same command on every host, ``--process-id`` 0 … N−1; process 0 runs the coordinator and writes)::

    gyrojax mc study.json --out results/ --coordinator 10.0.0.1:1234 --num-processes 2 --process-id 0

or set ``JAX_COORDINATOR_ADDRESS`` and let JAX take the process count and id from the cluster environment it
detects (SLURM, Open MPI, Kubernetes, …).
"""

from __future__ import annotations

import contextlib
import os
import sys

import jax
import numpy as np

from gyrojax.errors import GyrojaxError


class DistributedError(GyrojaxError, RuntimeError):
    """The distributed runtime could not be set up, or another process of the job failed (the message says which)."""


def initialize(coordinator: str | None = None, num_processes: int | None = None, process_id: int | None = None) -> bool:
    """Join the ``jax.distributed`` job when one is asked for; True when this process is one of several.

    Asked for: any of the three arguments given, or ``JAX_COORDINATOR_ADDRESS`` set in the environment. Missing
    values are left to JAX (its environment variables and cluster detection); what JAX cannot determine is refused
    with a :class:`DistributedError` naming the option. Must run before any JAX computation in the process.
    """
    asked = any(v is not None for v in (coordinator, num_processes, process_id))
    if not asked and not os.environ.get("JAX_COORDINATOR_ADDRESS"):
        return False
    if coordinator is not None and (":" not in coordinator or not coordinator.rsplit(":", 1)[1].isdigit()):
        raise DistributedError(f"--coordinator must look like HOST:PORT, got {coordinator!r}")
    if num_processes is not None and num_processes < 1:
        raise DistributedError(f"--num-processes must be >= 1, got {num_processes}")
    if process_id is not None and num_processes is not None and not 0 <= process_id < num_processes:
        raise DistributedError(f"--process-id must be in 0 … {num_processes - 1}, got {process_id}")
    if num_processes == 1 and process_id in (None, 0) and coordinator is None:
        return False
    try:
        jax.distributed.initialize(coordinator, num_processes, process_id, initialization_timeout=120)
    except (ValueError, TypeError) as e:  # JAX could not determine a value: name the option that supplies it
        raise DistributedError(
            f"jax.distributed could not start ({e}); give --coordinator HOST:PORT --num-processes N --process-id K"
        ) from None
    except RuntimeError as e:
        raise DistributedError(f"jax.distributed could not start: {str(e).splitlines()[0]}") from None
    return jax.process_count() > 1


@contextlib.contextmanager
def _quiet_stdout():
    """Send what native code prints to file descriptor 1 to stderr meanwhile (gloo announces its connections on
    stdout, which would spoil ``--json`` output)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def _allgather(tree):
    from jax.experimental import multihost_utils

    with _quiet_stdout():
        return multihost_utils.process_allgather(tree)


def share(n: int, num_processes: int, process_id: int) -> tuple[int, int]:
    """[lo, hi): the block of the draw offsets 0 … n−1 that process ``process_id`` of ``num_processes`` evaluates.

    Contiguous blocks, sizes ⌊n/N⌋ or ⌈n/N⌉, in process order; their union is 0 … n−1, each offset once.
    """
    return n * process_id // num_processes, n * (process_id + 1) // num_processes


def agree(error: Exception | None) -> None:
    """A barrier over every process that also carries failure: when any process passes an error, every process
    raises (its own message, or one naming the first failed process), so no process waits forever for a peer that
    gave up. Single process: raises ``error`` if given."""
    if jax.process_count() == 1:
        if error is not None:
            raise error
        return
    flags = np.asarray(_allgather(np.array([error is not None])))
    flags = flags.reshape(jax.process_count())
    if error is not None:
        raise error
    if flags.any():
        k = int(np.flatnonzero(flags)[0])
        raise DistributedError(f"process {k} of the job failed (see its error); this process stops too")


def gather(local: dict, counts: list[int]) -> dict:
    """Concatenate the per-process blocks of ``local`` (numpy arrays with the draws along axis 0; process k holds
    ``counts[k]`` rows) in process order, on every process. Blocks are padded to the largest for the all-gather."""
    if jax.process_count() == 1:
        return local
    rows = max(max(counts), 1)
    mine = counts[jax.process_index()]
    padded = {k: np.concatenate([v, np.zeros((rows - mine,) + v.shape[1:], v.dtype)]) for k, v in local.items()}
    allg = _allgather(padded)  # (N, rows, …) per key
    return {k: np.concatenate([np.asarray(v)[i, : counts[i]] for i in range(len(counts))]) for k, v in allg.items()}
