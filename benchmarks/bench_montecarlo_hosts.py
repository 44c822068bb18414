"""Monte Carlo across processes: ``gyrojax mc`` as one process and as a two-process ``jax.distributed`` job on this
machine (coordinator on localhost), on the study of :mod:`benchmarks.bench_montecarlo` (24 positions × 10 min at
1 Hz, own set-up errors per draw, 9-term fit).

    python -m benchmarks.bench_montecarlo_hosts [--draws 20000] [--processes 2]

Each configuration is a fresh command (cold start, compilation cache off) with one CPU device per process. Printed:
wall time of the whole command, the compile and run times process 0 reports (the slowest process's), draws/s of the
run, and the ratios to the single process. The results are checked equal draw for draw.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
NINE = ["D_F", "D_I", "D_O", "D_S", "D_II", "D_SS", "D_IO", "D_IS", "D_OS"]


def study(draws: int) -> dict:
    return {
        "plan": "multiposition",
        "plan_options": {"n": 24, "minutes": 10, "dt_s": 1},
        "terms": NINE,
        "priors": {c: {"normal": [0.0, 0.5]} for c in NINE},
        "setup": {
            "table_tilt": {"normal": [0.0, 10.0]},
            "table_azimuth": {"normal": [0.0, 10.0]},
            "encoder_harmonic": {"normal": [0.0, 3.0]},
        },
        "noise": {"white": 0.01},
        "draws": draws,
        "seed": 0,
    }


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(study_path: Path, out: Path, nproc: int) -> dict:
    """One ``gyrojax mc`` job of ``nproc`` processes; process 0's JSON report plus the wall time (s)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), JAX_PLATFORMS="cpu", GYROJAX_NO_CACHE="1", XLA_FLAGS="")
    base = [sys.executable, "-m", "gyrojax", "mc", str(study_path), "--out", str(out), "--json", "--force"]
    port = _free_port()
    procs = []
    t0 = time.perf_counter()
    try:
        for k in range(nproc):
            extra = [] if nproc == 1 else ["--coordinator", f"127.0.0.1:{port}", "--num-processes", str(nproc)]
            extra += [] if nproc == 1 else ["--process-id", str(k)]
            procs.append(
                subprocess.Popen(base + extra, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            )
        outs = [p.communicate(timeout=3600) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    wall = time.perf_counter() - t0
    for p, (_, err) in zip(procs, outs):
        if p.returncode != 0:
            raise SystemExit(f"gyrojax mc failed ({nproc} processes): {err[-1000:]}")
    rep = json.loads(outs[0][0].strip().splitlines()[-1])
    rep["wall_s"] = wall
    return rep


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=20_000)
    ap.add_argument("--processes", type=int, default=2)
    args = ap.parse_args(argv)
    from gyrojax.montecarlo import results

    with tempfile.TemporaryDirectory() as tmp:
        sp = Path(tmp) / "study.json"
        sp.write_text(json.dumps(study(args.draws)))
        reps = {}
        for n in (1, args.processes):
            reps[n] = run(sp, Path(tmp) / f"p{n}", n)
        a, b = results.load_result(Path(tmp) / "p1"), results.load_result(Path(tmp) / f"p{args.processes}")
        diff = max(float(np.abs(getattr(a, k) - getattr(b, k)).max()) for k in ("truth", "estimate", "std", "rms"))
    print(f"{args.draws} draws, {os.cpu_count()} cores; max |difference| between the runs: {diff:.3g}")
    head = ("processes", "wall s", "compile s", "run s", "draws/s", "wall ratio", "run ratio")
    print(" ".join(f"{h:>10}" for h in head))
    one = reps[1]
    for n, r in reps.items():
        print(
            f"{n:>10} {r['wall_s']:10.1f} {r['compile_s']:10.1f} {r['run_s']:10.2f} {args.draws / r['run_s']:10.0f} "
            f"{one['wall_s'] / r['wall_s']:10.2f} {one['run_s'] / r['run_s']:10.2f}"
        )


if __name__ == "__main__":
    main()
